"""Validation reports: the paper's voxel estimator against exact volumes on real grasps, and
the paper's noise tests with both backends (``exactgrasp validate``,
``python -m exactgrasp.report``, ``docs/validation.md``).

    from exactgrasp.datapath import data_dir
    from exactgrasp.report import ValidationConfig, run_validation
    run_validation(data_dir(), "report", ValidationConfig.quick())

`run_validation` loads on first use: it pulls in the figures (matplotlib), which the
``exactgrasp`` command should not pay for when it only builds its parser (`report.args`).
"""

from __future__ import annotations

from exactgrasp.errors import DataError
from exactgrasp.report.config import ValidationConfig
from exactgrasp.report.noise import roc_auc

__all__ = ["DataError", "ValidationConfig", "roc_auc", "run_validation"]


def __getattr__(name: str):
    if name == "run_validation":
        from exactgrasp.report.run import run_validation

        return run_validation
    raise AttributeError(f"module 'exactgrasp.report' has no attribute {name!r}")
