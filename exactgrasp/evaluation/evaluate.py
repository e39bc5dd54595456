"""`evaluate`: descriptor distances and baselines against labelled pairs, as AUCs with CIs."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.backends.base import Backend
from exactgrasp.backends.defaults import DEFAULT_BACKEND
from exactgrasp.backends.registry import as_backend
from exactgrasp.descriptor import Descriptor, compute_descriptor
from exactgrasp.errors import EvaluationError
from exactgrasp.evaluation.baselines import BASELINES, baseline_matrix
from exactgrasp.evaluation.distances import configuration_values, distance_matrix
from exactgrasp.evaluation.names import DEFAULT_DISTANCES
from exactgrasp.evaluation.pairs import LabelledPairs
from exactgrasp.evaluation.roc import bootstrap_auc, roc_curve, weighted_auc
from exactgrasp.evaluation.symmetry import as_symmetries
from exactgrasp.grasp import Grasp
from exactgrasp.paths.presets import as_sampler
from exactgrasp.report.cache import DescriptorCache

__all__ = ["DEFAULT_DISTANCES", "Evaluation", "EvaluationResult", "evaluate", "evaluate_matrix"]

#: The descriptor distances `evaluate` reports unless told otherwise.


@dataclass
class Evaluation:
    """One distance's numbers on the pairs.

    Attributes
    ----------
    name : str
    auc, low, high, std : float
        AUC (concordance for graded labels) and its bootstrap interval.
    interval : dict
        How the interval was made (`exactgrasp.evaluation.roc.bootstrap_auc`).
    n_same, n_different : int
        Pairs with the highest label and the others.
    curve : tuple of numpy.ndarray
        ``(false_positive_rate, true_positive_rate)`` for "highest label" against the rest.
    groups : dict of str to dict
        Per group: ``auc``, ``n_same``, ``n_different`` (NaN AUC where a class is missing).
    """

    name: str
    auc: float
    low: float
    high: float
    std: float
    interval: dict[str, Any]
    n_same: int
    n_different: int
    curve: tuple[np.ndarray, np.ndarray]
    groups: dict[str, dict[str, Any]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready numbers (the curve as lists)."""
        return {
            "name": self.name,
            "auc": self.auc,
            "low": self.low,
            "high": self.high,
            "std": self.std,
            "interval": self.interval,
            "n_same": self.n_same,
            "n_different": self.n_different,
            "curve": {"fpr": self.curve[0].tolist(), "tpr": self.curve[1].tolist()},
            "groups": self.groups,
        }


@dataclass
class EvaluationResult:
    """Every distance's `Evaluation`, with the matrices they came from.

    Attributes
    ----------
    evaluations : dict of str to Evaluation
        Descriptor distances first (``"l2"``, ``"l2 min mirror-x"``, ...), then baselines
        (``"baseline: joints"``, ...).
    matrices : dict of str to numpy.ndarray, shape (n_grasps, n_grasps)
    pairs : LabelledPairs
    settings : dict
        Sampler, backend, symmetries, bootstrap settings.
    """

    evaluations: dict[str, Evaluation]
    matrices: dict[str, np.ndarray]
    pairs: LabelledPairs
    settings: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: settings and every evaluation."""
        return {
            "settings": self.settings,
            "n_grasps": len(self.pairs.names),
            "n_pairs": len(self.pairs),
            "evaluations": {k: v.to_dict() for k, v in self.evaluations.items()},
        }


def _groups(matrix: np.ndarray, pairs: LabelledPairs) -> dict[str, dict[str, Any]]:
    d = matrix[pairs.first, pairs.second]
    top = pairs.label == pairs.label.max()
    if pairs.pair_group is not None:
        member = {g: np.array([p == g for p in pairs.pair_group]) for g in set(pairs.pair_group)}
    elif pairs.grasp_group is not None:
        gg = np.asarray(pairs.grasp_group)
        member = {
            g: (gg[pairs.first] == g) | (gg[pairs.second] == g) for g in set(pairs.grasp_group)
        }
    else:
        return {}
    out = {}
    for g in sorted(member):
        keep = member[g]
        same, different = int(np.sum(top & keep)), int(np.sum(~top & keep))
        value = float("nan")
        if same and different:
            value = weighted_auc(d[keep], top[keep])
        out[g] = {"auc": value, "n_same": same, "n_different": different}
    return out


def evaluate_matrix(
    matrix: np.ndarray, pairs: LabelledPairs, name: str = "distance", **bootstrap: Any
) -> Evaluation:
    """Evaluate one distance matrix on labelled pairs.

    Parameters
    ----------
    matrix : numpy.ndarray, shape (n_grasps, n_grasps)
        Distances between the grasps ``pairs.names`` (smaller = more alike).
    pairs : LabelledPairs
    name : str
    **bootstrap
        ``n_boot``, ``seed``, ``unit``, ``level``: the interval's settings, as for
        `exactgrasp.evaluation.roc.bootstrap_auc` (and its defaults).

    Returns
    -------
    Evaluation
    """
    matrix = np.asarray(matrix, dtype=np.float64)
    n = len(pairs.names)
    if matrix.shape != (n, n):
        raise EvaluationError(
            f"distance matrix {name!r} has shape {matrix.shape}; the pairs name {n} grasps."
        )
    d = matrix[pairs.first, pairs.second]
    ci = bootstrap_auc(d, pairs.label, pairs.first, pairs.second, pairs.grasp_group, **bootstrap)
    top = pairs.label == pairs.label.max()
    fpr, tpr, _ = roc_curve(d, top)
    return Evaluation(
        name=name,
        auc=ci["auc"],
        low=ci["low"],
        high=ci["high"],
        std=ci["std"],
        interval={k: ci[k] for k in ("unit", "n_boot", "level", "seed", "n_valid")},
        n_same=int(top.sum()),
        n_different=int((~top).sum()),
        curve=(fpr, tpr),
        groups=_groups(matrix, pairs),
    )


def symmetry_cache(cache: DescriptorCache | None, grasp, backend, sampler):
    """The ``cached(name, compute)`` of `configuration_values` beside a grasp's cached
    descriptor: the values through each symmetry kept as ``.npy`` files (None without a
    cache)."""
    if cache is None:
        return None
    base = cache.path(grasp, backend, sampler)

    def cached(name: str, compute):
        file = base.with_name(f"{base.stem}.{name}.npy")
        if file.exists():
            return np.load(file)
        values = compute()
        np.save(file, values)
        return values

    return cached


def evaluate(
    items: Sequence[Grasp | Descriptor],
    pairs: LabelledPairs,
    distances: Sequence[str] = DEFAULT_DISTANCES,
    baselines: Sequence[str] | None = None,
    backend: str | Backend = DEFAULT_BACKEND,
    sampler: Any = None,
    symmetries: Any = None,
    cache_dir: str | os.PathLike | None = None,
    n_boot: int = 2000,
    seed: int = 0,
    unit: str = "grasp",
    level: float = 0.95,
) -> EvaluationResult:
    """AUC with a bootstrap interval of descriptor distances (and baselines) on labelled pairs.

    Parameters
    ----------
    items : sequence of Grasp or of Descriptor, length n_grasps
        In the order of ``pairs.names``. Grasps are described with ``backend`` and
        ``sampler``; descriptors are used as they are (no baselines, no symmetries).
    pairs : LabelledPairs
        From `exactgrasp.evaluation.pairs_from_groups` or `exactgrasp.evaluation.read_pairs`.
    distances : sequence of str
        Descriptor distances (`exactgrasp.evaluation.distances.DISTANCES`; ``"escape:0.05"``
        for another threshold).
    baselines : sequence of str, optional
        Of `exactgrasp.evaluation.baselines.BASELINES`; default: all for grasps of one hand
        and one object, ``position`` and ``contacts`` otherwise; none for descriptors.
    backend : str or Backend
        A registered name (library defaults) or a configured instance, e.g.
        ``VoxelBackend(object_resolution=30)``.
    sampler : PathSampler or str or dict, optional
        Anything `exactgrasp.paths.as_sampler` takes (default: the balanced preset).
    symmetries : str or sequence, optional
        Hand symmetries (`exactgrasp.evaluation.symmetry.SYMMETRIES` names); each distance is
        then also reported as its minimum over these starting configurations.
    cache_dir : path-like, optional
        Folder of cached descriptors (and their symmetric values).
    n_boot, seed, unit, level
        Bootstrap settings (`exactgrasp.evaluation.roc.bootstrap_auc`).

    Returns
    -------
    EvaluationResult
    """
    items = list(items)
    if len(items) != len(pairs.names):
        raise EvaluationError(
            f"{len(items)} grasps or descriptors given, but the pairs name {len(pairs.names)}."
        )
    # What the settings record: nothing for a name (the defaults), an instance's parameters.
    params = {} if isinstance(backend, str) else dict(backend.params)
    named_symmetries = as_symmetries(symmetries)
    is_grasp = [isinstance(x, Grasp) for x in items]
    if all(is_grasp):
        sampler = as_sampler(sampler)
        instance = as_backend(backend)
        cache = DescriptorCache(Path(cache_dir)) if cache_dir is not None else None
        stacks = []
        for g in items:
            d = (
                cache.descriptor(g, sampler, backend)
                if cache is not None
                else compute_descriptor(g, sampler, backend=instance, progress=False)
            )
            cached = symmetry_cache(cache, g, instance, sampler)
            stacks.append(configuration_values(g, d, sampler, instance, named_symmetries, cached))
        times = sampler.times
    elif not any(is_grasp):
        if any(not isinstance(x, Descriptor) for x in items):
            raise EvaluationError("items must all be Grasp objects or all Descriptor objects.")
        if named_symmetries:
            raise EvaluationError(
                "symmetries need the grasps (their values along the mirrored paths are "
                "computed); pass Grasp objects, or leave symmetries out."
            )
        first = items[0].sampler
        if first is None:
            raise EvaluationError("descriptors carry no sampler in their metadata.")
        stacks = [x.values[None] for x in items]
        times = first.times
        baselines = ()
    else:
        raise EvaluationError("items must all be Grasp objects or all Descriptor objects.")

    if baselines is None:
        grasps = items
        one_hand = len({tuple(sorted(g.hand.joint_names)) for g in grasps}) == 1
        one_object = len({g.object.hash for g in grasps}) == 1
        baselines = [
            b for b in BASELINES if (b != "joints" or one_hand) and (b != "pose" or one_object)
        ]
    matrices: dict[str, np.ndarray] = {}
    for spec in distances:
        matrices[spec] = distance_matrix(stacks, spec, times, use_configurations=False)
        if named_symmetries:
            label = f"{spec} min {'+'.join(n for n, _ in named_symmetries)}"
            matrices[label] = distance_matrix(stacks, spec, times, use_configurations=True)
    for b in baselines:
        matrices[f"baseline: {b}"] = baseline_matrix(items, b)
    evaluations = {
        name: evaluate_matrix(m, pairs, name, n_boot=n_boot, seed=seed, unit=unit, level=level)
        for name, m in matrices.items()
    }
    settings = {
        "backend": (
            (backend if isinstance(backend, str) else backend.name)
            if all(is_grasp)
            else "(descriptors given)"
        ),
        "backend_params": params,
        "sampler": (
            as_sampler(sampler).params if all(is_grasp) else items[0].metadata.get("sampler")
        ),
        "symmetries": [n for n, _ in named_symmetries],
        "bootstrap": {"n_boot": n_boot, "seed": seed, "unit": unit, "level": level},
    }
    return EvaluationResult(evaluations, matrices, pairs, settings)
