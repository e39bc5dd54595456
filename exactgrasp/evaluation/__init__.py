"""What the descriptor tells you: distances evaluated against labelled pairs of grasps.

`roc` (AUC, ROC curve, bootstrap over grasps), `pairs` (labelled pairs from groups or a CSV),
`symmetry` (starting configurations), `distances` (the descriptor distances), `baselines`
(distances from the grasps themselves), `evaluate` (`evaluate`, `evaluate_matrix`), `write`
(the files of one evaluation), and the committed report
``docs/reports/descriptor-meaning/`` (``python -m exactgrasp.evaluation``): `study` (the
sections' numbers), `figures`, `text`, `run` and `__main__`. The
``exactgrasp evaluate`` command is `exactgrasp.cli.evaluate`.
"""

from exactgrasp.errors import EvaluationError
from exactgrasp.evaluation.baselines import BASELINES, baseline_matrix
from exactgrasp.evaluation.distances import DISTANCES, distance_matrix, escape_times
from exactgrasp.evaluation.evaluate import (
    DEFAULT_DISTANCES,
    Evaluation,
    EvaluationResult,
    evaluate,
    evaluate_matrix,
)
from exactgrasp.evaluation.pairs import LabelledPairs, pairs_from_groups, read_pairs
from exactgrasp.evaluation.roc import auc, bootstrap_auc, roc_curve
from exactgrasp.evaluation.symmetry import SYMMETRIES, object_symmetries

__all__ = [
    "BASELINES",
    "DEFAULT_DISTANCES",
    "DISTANCES",
    "SYMMETRIES",
    "Evaluation",
    "EvaluationError",
    "EvaluationResult",
    "LabelledPairs",
    "auc",
    "baseline_matrix",
    "bootstrap_auc",
    "distance_matrix",
    "escape_times",
    "evaluate",
    "evaluate_matrix",
    "object_symmetries",
    "pairs_from_groups",
    "read_pairs",
    "roc_curve",
]
