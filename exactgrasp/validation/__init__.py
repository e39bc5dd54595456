"""Validation reports: the paper's voxel estimator against exact volumes on real grasps, and
the paper's noise tests with both backends (``exactgrasp validate``, ``docs/validation.md``).

    from exactgrasp.validation import ValidationConfig, run_validation
    run_validation("../shared/data", "report", ValidationConfig.quick())
"""

from exactgrasp.validation.config import ValidationConfig
from exactgrasp.validation.data import DataError
from exactgrasp.validation.noise import roc_auc
from exactgrasp.validation.run import run_validation

__all__ = ["DataError", "ValidationConfig", "roc_auc", "run_validation"]
