"""Descriptors for many grasps: a manifest in, resumable parts and one table out.

`run` holds `run_batch`, `manifest` the manifest reader, `store` the files of a run, `worker`
what runs on the workers; the ``exactgrasp batch`` command is `exactgrasp.cli.batch`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.batch.manifest import read_manifest
    from exactgrasp.batch.run import DEFAULT_PART_SIZE, BatchSummary, run_batch
    from exactgrasp.batch.store import read_batch
    from exactgrasp.batch.worker import compute_rows
    from exactgrasp.errors import BatchError

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.batch.manifest": ("read_manifest",),
        "exactgrasp.batch.run": ("DEFAULT_PART_SIZE", "BatchSummary", "run_batch"),
        "exactgrasp.batch.store": ("read_batch",),
        "exactgrasp.batch.worker": ("compute_rows",),
        "exactgrasp.errors": ("BatchError",),
    },
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
