"""Descriptors for many grasps: a manifest in, resumable parts and one table out."""

from exactgrasp.batch.run import (
    DEFAULT_PART_SIZE,
    BatchError,
    BatchSummary,
    compute_rows,
    read_batch,
    read_manifest,
    run_batch,
)

__all__ = [
    "DEFAULT_PART_SIZE",
    "BatchError",
    "BatchSummary",
    "compute_rows",
    "read_batch",
    "read_manifest",
    "run_batch",
]
