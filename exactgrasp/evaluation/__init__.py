"""What the descriptor tells you: distances evaluated against labelled pairs of grasps.

`roc` (AUC, ROC curve, bootstrap over grasps), `pairs` (labelled pairs from groups or a CSV),
`symmetry` (starting configurations), `distances` (the descriptor distances), `baselines`
(distances from the grasps themselves), `evaluate` (`evaluate`, `evaluate_matrix`), `write`
(the files of one evaluation), and the committed report
``docs/reports/descriptor-meaning/`` (``python -m exactgrasp.evaluation``): `study` (the
sections' numbers), `figures`, `text`, `run` and `__main__`. The
``exactgrasp evaluate`` command is `exactgrasp.cli.evaluate`.
"""

from typing import TYPE_CHECKING

from exactgrasp.errors import EvaluationError
from exactgrasp.evaluation.names import BASELINES, DEFAULT_DISTANCES, DISTANCES
from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.evaluation.baselines import baseline_matrix
    from exactgrasp.evaluation.distances import distance_matrix, escape_times
    from exactgrasp.evaluation.evaluate import (
        Evaluation,
        EvaluationResult,
        evaluate,
        evaluate_matrix,
    )
    from exactgrasp.evaluation.pairs import LabelledPairs, pairs_from_groups, read_pairs
    from exactgrasp.evaluation.roc import auc, bootstrap_auc, roc_curve
    from exactgrasp.evaluation.symmetry import SYMMETRIES, object_symmetries

# The code behind the names loads on first use: ``exactgrasp evaluate --help`` lists the names
# without numpy's and scipy's share of the work.
__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.evaluation.baselines": ("baseline_matrix",),
        "exactgrasp.evaluation.distances": ("distance_matrix", "escape_times"),
        "exactgrasp.evaluation.evaluate": (
            "Evaluation",
            "EvaluationResult",
            "evaluate",
            "evaluate_matrix",
        ),
        "exactgrasp.evaluation.pairs": ("LabelledPairs", "pairs_from_groups", "read_pairs"),
        "exactgrasp.evaluation.roc": ("auc", "bootstrap_auc", "roc_curve"),
        "exactgrasp.evaluation.symmetry": ("SYMMETRIES", "object_symmetries"),
    },
)

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
