"""The names the evaluation offers (distances, baselines, symmetries, bootstrap units), apart
from the code behind them, so that ``exactgrasp evaluate --help`` lists them without loading
it."""

from __future__ import annotations

__all__ = [
    "BASELINES",
    "BOOTSTRAP_UNITS",
    "DEFAULT_DISTANCES",
    "DISTANCES",
    "SYMMETRY_NAMES",
]

#: Baseline distances computed from the grasps themselves (`exactgrasp.evaluation.baselines`).
BASELINES = ("joints", "position", "origin", "pose", "contacts")
#: Descriptor distances (`exactgrasp.evaluation.distances`).
DISTANCES = ("l2", "l2_diff", "cbrt", "escape")
#: The distances `exactgrasp.evaluation.evaluate.evaluate` computes unless told otherwise.
DEFAULT_DISTANCES = ("l2", "l2_diff", "cbrt", "escape")
#: What the bootstrap can resample (`exactgrasp.evaluation.roc`).
BOOTSTRAP_UNITS = ("grasp", "group", "pair")
#: The starting configurations a distance can be minimised over
#: (`exactgrasp.evaluation.symmetry.SYMMETRIES`, in its order).
SYMMETRY_NAMES = ("mirror-x", "mirror-y", "mirror-z", "turn-x", "turn-y", "turn-z")
