"""Validation reports: the paper's voxel estimator against exact volumes on real grasps, and
the paper's noise tests with both backends (``exactgrasp validate``,
``python -m exactgrasp.report``, ``docs/validation.md``).

    from exactgrasp.datapath import data_dir
    from exactgrasp.report import ValidationConfig, run_validation
    run_validation(data_dir(), "report", ValidationConfig.quick())

`run_validation` and `roc_auc` load on first use: it pulls in the figures (matplotlib), which the
``exactgrasp`` command should not pay for when it only builds its parser (`report.args`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.errors import DataError
from exactgrasp.lazy import lazy_names
from exactgrasp.report.config import ValidationConfig

if TYPE_CHECKING:
    from exactgrasp.report.noise import roc_auc
    from exactgrasp.report.run import run_validation

__all__ = ["DataError", "ValidationConfig", "roc_auc", "run_validation"]

__getattr__, __dir__ = lazy_names(
    __name__,
    {"exactgrasp.report.noise": ("roc_auc",), "exactgrasp.report.run": ("run_validation",)},
)
