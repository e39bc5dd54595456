"""ROC AUC of a distance against labelled pairs, its curve, and its bootstrap interval.

A smaller distance should mean "same". The AUC is the Mann-Whitney statistic: the probability
that a "different" pair is farther apart than a "same" pair, ties counting one half. Graded
labels (higher = more alike) give the concordance over every two pairs of different grades,
which is the AUC when there are two grades.

The bootstrap resamples the *grasps* (or their groups), not the pairs: pairs that share a
grasp are not independent, so resampling pairs would make the interval too narrow. A
replicate draws the grasps with replacement; a pair then counts as often as the product of
its two grasps' draws (pairs of a grasp with itself never exist).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from exactgrasp.errors import EvaluationError
from exactgrasp.evaluation.names import BOOTSTRAP_UNITS

__all__ = ["BOOTSTRAP_UNITS", "auc", "bootstrap_auc", "roc_curve", "weighted_auc"]

#: What a bootstrap replicate resamples.


def weighted_auc(
    distance: np.ndarray, positive: np.ndarray, weight: np.ndarray | None = None
) -> float:
    """Weighted Mann-Whitney AUC: P(negative distance > positive distance), ties 1/2.

    Parameters
    ----------
    distance : numpy.ndarray, shape (n,)
    positive : numpy.ndarray, shape (n,), bool
        True for "same" pairs (which should have the smaller distances).
    weight : numpy.ndarray, shape (n,), optional
        Non-negative weight of each pair (default 1).

    Returns
    -------
    float
        In [0, 1]; NaN when either class has zero weight.
    """
    distance = np.asarray(distance, dtype=np.float64)
    positive = np.asarray(positive, dtype=bool)
    weight = np.ones(distance.shape) if weight is None else np.asarray(weight, float)
    values, inverse = np.unique(distance, return_inverse=True)
    pos = np.bincount(inverse, weights=weight * positive, minlength=values.size)
    neg = np.bincount(inverse, weights=weight * ~positive, minlength=values.size)
    total_pos, total_neg = pos.sum(), neg.sum()
    if total_pos <= 0 or total_neg <= 0:
        return float("nan")
    below = np.cumsum(pos) - pos  # positive weight strictly below each distinct value
    wins = np.sum(neg * (below + 0.5 * pos))
    return float(wins / (total_pos * total_neg))


def _concordance(distance: np.ndarray, grade: np.ndarray, weight: np.ndarray) -> float:
    levels = np.unique(grade)
    wins = total = 0.0
    for a, high in enumerate(levels):
        for low in levels[:a]:
            keep = (grade == high) | (grade == low)
            w = weight[keep]
            p = grade[keep] == high
            mass = w[p].sum() * w[~p].sum()
            if mass > 0:
                wins += weighted_auc(distance[keep], p, w) * mass
                total += mass
    return float(wins / total) if total > 0 else float("nan")


def _check(distance: Any, grade: Any) -> tuple[np.ndarray, np.ndarray]:
    distance = np.asarray(distance, dtype=np.float64).ravel()
    grade = np.asarray(grade, dtype=np.float64).ravel()
    if distance.shape != grade.shape:
        raise EvaluationError(
            f"{distance.size} distances but {grade.size} labels; give one label per pair."
        )
    if not np.all(np.isfinite(distance)):
        raise EvaluationError("distances contain NaN or infinite values.")
    if np.unique(grade).size < 2:
        raise EvaluationError(
            "all pairs carry the same label; an AUC needs both same and different pairs "
            "(or at least two grades)."
        )
    return distance, grade


def auc(distance: Any, label: Any) -> float:
    """AUC of a distance for telling "same" pairs (small distance) from "different" ones.

    Parameters
    ----------
    distance : array_like, shape (n_pairs,)
    label : array_like, shape (n_pairs,)
        1 / True for same, 0 / False for different; or grades, higher meaning more alike
        (the concordance over every two pairs of different grades).

    Returns
    -------
    float
        1: every same pair is closer than every different pair; 0.5: chance.
    """
    distance, grade = _check(distance, label)
    return _concordance(distance, grade, np.ones_like(distance))


def roc_curve(distance: Any, same: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ROC curve of "distance at most a threshold means same".

    Parameters
    ----------
    distance : array_like, shape (n_pairs,)
    same : array_like, shape (n_pairs,), bool

    Returns
    -------
    false_positive_rate, true_positive_rate, threshold : numpy.ndarray, shape (k + 1,)
        From (0, 0) at threshold -inf to (1, 1); one point per distinct distance, so tied
        pairs make one diagonal step and the trapezoid area equals `auc`.
    """
    distance, grade = _check(distance, same)
    same = grade > grade.min()
    values, inverse = np.unique(distance, return_inverse=True)
    pos = np.bincount(inverse, weights=same.astype(float), minlength=values.size)
    neg = np.bincount(inverse, weights=(~same).astype(float), minlength=values.size)
    tpr = np.concatenate([[0.0], np.cumsum(pos) / pos.sum()])
    fpr = np.concatenate([[0.0], np.cumsum(neg) / neg.sum()])
    return fpr, tpr, np.concatenate([[-np.inf], values])


def bootstrap_auc(
    distance: Any,
    label: Any,
    first: Any,
    second: Any,
    groups: Any = None,
    unit: str = "grasp",
    n_boot: int = 2000,
    level: float = 0.95,
    seed: int = 0,
    reference: Any = None,
) -> dict[str, Any]:
    """Percentile bootstrap interval of `auc`, resampling grasps (or groups, or pairs).

    Parameters
    ----------
    distance, label : array_like, shape (n_pairs,)
    first, second : array_like of int, shape (n_pairs,)
        The two grasps of each pair, as indices ``0 .. n_grasps - 1``.
    groups : array_like, shape (n_grasps,), optional
        Each grasp's group (e.g. its cluster); needed for ``unit="group"``.
    unit : {"grasp", "group", "pair"}
        What a replicate draws with replacement. ``"grasp"`` (default) keeps the dependence of
        pairs sharing a grasp; ``"group"`` is wider still; ``"pair"`` treats pairs as
        independent (too narrow when grasps repeat, given for comparison).
    n_boot : int
    level : float
        Coverage of the interval, e.g. 0.95.
    seed : int
        Seed of `numpy.random.default_rng`; the same seed gives the same interval.
    reference : array_like, shape (n_pairs,), optional
        Another distance on the same pairs: the difference of the two AUCs is then
        bootstrapped on the same replicates (a paired comparison).

    Returns
    -------
    dict
        ``auc`` (on all pairs), ``low``, ``high``, ``std``, ``unit``, ``n_boot``, ``level``,
        ``seed``, ``n_valid`` (replicates holding both classes); with ``reference``, also
        ``difference``: ``value`` (AUC minus the reference's), ``low``, ``high`` and
        ``below_zero`` (the fraction of replicates where it is negative).
    """
    distance, grade = _check(distance, label)
    first = np.asarray(first, dtype=np.int64).ravel()
    second = np.asarray(second, dtype=np.int64).ravel()
    if first.shape != distance.shape or second.shape != distance.shape:
        raise EvaluationError("first and second must give the two grasps of every pair.")
    if unit not in BOOTSTRAP_UNITS:
        raise EvaluationError(f"bootstrap unit {unit!r} is unknown; use one of {BOOTSTRAP_UNITS}.")
    if not 0 < level < 1:
        raise EvaluationError(f"level must be in (0, 1), e.g. 0.95; got {level!r}.")
    n_grasps = int(max(first.max(), second.max())) + 1
    rng = np.random.default_rng(seed)
    if unit == "group":
        if groups is None:
            raise EvaluationError('unit="group" needs the group of every grasp (groups=...).')
        _, group_index = np.unique(np.asarray(groups).ravel(), return_inverse=True)
        if group_index.size != n_grasps:
            raise EvaluationError(
                f"groups names {group_index.size} grasps but the pairs use {n_grasps}."
            )
        n_groups = int(group_index.max()) + 1
    if reference is not None:
        reference = np.asarray(reference, dtype=np.float64).ravel()
        if reference.shape != distance.shape:
            raise EvaluationError("reference must give one distance per pair.")
    samples, differences = [], []
    for _ in range(n_boot):
        if unit == "pair":
            drawn = rng.integers(0, distance.size, distance.size)
            weight = np.bincount(drawn, minlength=distance.size)
        else:
            if unit == "grasp":
                count = np.bincount(rng.integers(0, n_grasps, n_grasps), minlength=n_grasps)
            else:
                drawn = np.bincount(rng.integers(0, n_groups, n_groups), minlength=n_groups)
                count = drawn[group_index]
            weight = count[first] * count[second]
        value = _concordance(distance, grade, weight.astype(np.float64))
        if np.isfinite(value):
            samples.append(value)
            if reference is not None:
                base = _concordance(reference, grade, weight.astype(np.float64))
                differences.append(value - base)
    samples = np.asarray(samples)
    tail = (1.0 - level) / 2.0
    low, high = np.quantile(samples, [tail, 1.0 - tail]) if samples.size else (float("nan"),) * 2
    result = {
        "auc": _concordance(distance, grade, np.ones_like(distance)),
        "low": float(low),
        "high": float(high),
        "std": float(samples.std()) if samples.size else float("nan"),
        "unit": unit,
        "n_boot": int(n_boot),
        "level": float(level),
        "seed": int(seed),
        "n_valid": int(samples.size),
    }
    if reference is not None and differences:
        differences = np.asarray(differences)
        d_low, d_high = np.quantile(differences, [tail, 1.0 - tail])
        ones = np.ones_like(distance)
        result["difference"] = {
            "value": result["auc"] - _concordance(reference, grade, ones),
            "low": float(d_low),
            "high": float(d_high),
            "below_zero": float(np.mean(differences < 0)),
        }
    return result
