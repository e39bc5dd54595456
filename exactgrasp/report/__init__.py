"""Validation reports: the paper's voxel estimator against exact volumes on real grasps, and
the paper's noise tests with both backends (``exactgrasp validate``, ``docs/validation.md``).

    from exactgrasp.report import ValidationConfig, run_validation
    run_validation("../shared/data", "report", ValidationConfig.quick())
"""

from exactgrasp.report.config import ValidationConfig
from exactgrasp.report.data import DataError
from exactgrasp.report.noise import roc_auc
from exactgrasp.report.run import run_validation

__all__ = ["DataError", "ValidationConfig", "roc_auc", "run_validation"]
