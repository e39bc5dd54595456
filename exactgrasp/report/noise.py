"""The paper's noise tests (section IV-A), run with each backend.

Object-pose noise: copies of six grasps on six objects, each with the object moved and turned
a little; the claim is that distances between copies of one grasp (within-object) are smaller
than distances between copies of different grasps (between-object). Joint noise: the spray
bottle grasp with every joint moved by 1..5 % of its range.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from itertools import combinations
from typing import Any

import numpy as np

from exactgrasp.descriptor import distance, pairwise_distances
from exactgrasp.grasp import Grasp
from exactgrasp.grasp.noise import object_pose_noise
from exactgrasp.report.cache import DescriptorCache
from exactgrasp.report.config import ValidationConfig
from exactgrasp.report.data import Case


def roc_auc(within: np.ndarray, between: np.ndarray) -> float:
    """Probability that a between-object distance exceeds a within-object one (ties count 1/2).

    The Mann-Whitney U statistic over ``len(within) * len(between)``: the area under the ROC
    curve of "distance above a threshold means different objects".

    Parameters
    ----------
    within, between : array_like, 1-D

    Returns
    -------
    float
        In [0, 1]; 1 when every between-object distance exceeds every within-object one.
    """
    within = np.sort(np.ravel(within))
    between = np.ravel(between)
    if within.size == 0 or between.size == 0:
        return float("nan")
    below = np.searchsorted(within, between, side="left")
    at_or_below = np.searchsorted(within, between, side="right")
    wins = below + 0.5 * (at_or_below - below)
    return float(wins.sum() / (within.size * between.size))


def separation(within: np.ndarray, between: np.ndarray) -> dict[str, float]:
    """The summary numbers of one within/between comparison.

    Returns
    -------
    dict
        ``max_within``, ``min_between``, ``gap`` (min between - max within; negative when the
        two overlap), ``overlap_within`` (within distances at or above the smallest between
        one), ``overlap_between`` (between distances at or below the largest within one),
        ``auc``, means and medians, ``ratio_of_medians``, counts.
    """
    within, between = np.ravel(within), np.ravel(between)
    max_within, min_between = float(within.max()), float(between.min())
    return {
        "max_within": max_within,
        "min_between": min_between,
        "gap": min_between - max_within,
        "overlap_within": int(np.sum(within >= min_between)),
        "overlap_between": int(np.sum(between <= max_within)),
        "auc": roc_auc(within, between),
        "mean_within": float(within.mean()),
        "mean_between": float(between.mean()),
        "median_within": float(np.median(within)),
        "median_between": float(np.median(between)),
        "ratio_of_medians": float(np.median(between) / max(np.median(within), 1e-300)),
        "n_within": int(within.size),
        "n_between": int(between.size),
    }


def noisy_copies(cases: Sequence[Case], config: ValidationConfig) -> dict[str, list[list[Grasp]]]:
    """Perturbed copies of each grasp: ``copies[level_key][grasp_index][copy]``.

    Seeded per (grasp, level, copy), so every backend and preset sees the same copies.
    """
    copies: dict[str, list[list[Grasp]]] = {}
    for li, (eps, delta) in enumerate(config.noise_levels):
        key = level_key(eps, delta)
        copies[key] = []
        for gi, case in enumerate(cases):
            row = []
            for ci in range(config.noise_copies):
                rng = np.random.default_rng([config.seed, gi, li, ci])
                pose = object_pose_noise(case.grasp, eps, delta, rng)
                name = f"{case.name}#pose{key}-{ci}"
                row.append(Grasp(case.grasp.hand, case.grasp.object, pose, name=name))
            copies[key].append(row)
    return copies


def level_key(eps: float, delta: float) -> str:
    """``"eps0.0125_delta64"``."""
    return f"eps{eps:g}_delta{delta:g}"


def _split(matrix: np.ndarray, n_grasps: int, n_copies: int) -> tuple[np.ndarray, np.ndarray]:
    """Within- and between-grasp distances of a matrix ordered grasp-major."""
    label = np.repeat(np.arange(n_grasps), n_copies)
    i, j = np.triu_indices(len(label), k=1)
    same = label[i] == label[j]
    return matrix[i[same], j[same]], matrix[i[~same], j[~same]]


def _per_grasp(matrix: np.ndarray, cases: Sequence[Case], n_copies: int) -> dict[str, Any]:
    """Per-grasp within spreads and per-pair between spreads (the paper's Fig. 5)."""
    blocks = [slice(g * n_copies, (g + 1) * n_copies) for g in range(len(cases))]
    within, between = {}, {}
    for g, case in enumerate(cases):
        sub = matrix[blocks[g], blocks[g]][np.triu_indices(n_copies, k=1)]
        within[case.name] = {
            "mean": float(sub.mean()),
            "std": float(sub.std()),
            "max": float(sub.max()),
        }
    for a, b in combinations(range(len(cases)), 2):
        sub = matrix[blocks[a], blocks[b]].ravel()
        between[f"{cases[a].name} | {cases[b].name}"] = {
            "mean": float(sub.mean()),
            "std": float(sub.std()),
            "min": float(sub.min()),
        }
    return {"within": within, "between": between}


def object_noise_test(
    cases: Sequence[Case],
    cache: DescriptorCache,
    config: ValidationConfig,
    backends: Sequence[str],
    log: Callable[[str], None] = print,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The object-pose noise test for every preset and backend.

    Returns
    -------
    summary : dict
        ``[sampler]["backends"][backend][kind][level]`` -> `separation` numbers plus
        ``per_grasp``; ``[sampler]["n_paths"]``, ``["n_poses"]``.
    arrays : dict
        ``[sampler][backend][kind][level]`` -> ``(within, between, matrix)``.
    """
    copies = noisy_copies(cases, config)
    summary: dict[str, Any] = {
        "grasps": [c.name for c in cases],
        "objects": [c.object for c in cases],
        "levels": [level_key(e, d) for e, d in config.noise_levels],
        "copies": config.noise_copies,
        "samplers": list(config.noise_samplers),
    }
    arrays: dict[str, Any] = {}
    for label in config.noise_samplers:
        sampler = config.sampler(label)
        summary[label] = {"n_paths": sampler.n_paths, "n_poses": sampler.n_poses, "backends": {}}
        arrays[label] = {}
        for backend in backends:
            if backend == "exact" and not config.runs_exact(label):
                continue
            params = config.backend_params(backend)
            log(f"noise: object pose, {label} sampler ({sampler.n_paths} paths), {backend}")
            result, arr = {}, {}
            kinds = ("l2", "l2_diff") if label == config.noise_samplers[0] else ("l2",)
            for key, per_grasp in copies.items():
                flat = [g for row in per_grasp for g in row]
                ds = [cache.descriptor(g, sampler, backend, **params) for g in flat]
                for kind in kinds:
                    matrix = pairwise_distances(ds, kind=kind)
                    within, between = _split(matrix, len(cases), config.noise_copies)
                    entry = separation(within, between)
                    entry["per_grasp"] = _per_grasp(matrix, cases, config.noise_copies)
                    result.setdefault(kind, {})[key] = entry
                    arr.setdefault(kind, {})[key] = (within, between, matrix)
            summary[label]["backends"][backend] = result
            arrays[label][backend] = arr
    return summary, arrays


def joint_noise_test(
    case: Case,
    cache: DescriptorCache,
    config: ValidationConfig,
    backends: Sequence[str],
    log: Callable[[str], None] = print,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Joint noise on one grasp: L2 distance of each perturbed grasp to the unperturbed one.

    Returns
    -------
    summary : dict
        ``["backends"][backend]["levels"][level]`` -> mean, median, max, std of the distances
        (and their number); ``["backends"][backend]["draws"]``.
    arrays : dict
        ``[backend][level]`` -> distances.
    """
    sampler = config.sampler(config.joint_sampler)
    summary: dict[str, Any] = {
        "grasp": case.name,
        "sampler": config.joint_sampler,
        "levels": list(config.joint_levels),
        "backends": {},
    }
    arrays: dict[str, Any] = {}
    for backend in backends:
        params = config.backend_params(backend)
        draws = config.joint_draws
        if backend == "exact" and config.exact_joint_draws is not None:
            draws = config.exact_joint_draws
        log(f"noise: joints, {backend}, {len(config.joint_levels)} levels x {draws} draws")
        base = cache.descriptor(case.grasp, sampler, backend, **params)
        summary["backends"][backend] = {"draws": draws, "levels": {}}
        arrays[backend] = {}
        for li, level in enumerate(config.joint_levels):
            values = []
            for k in range(draws):
                rng = np.random.default_rng([config.seed, 1000 + li, k])
                hand = case.grasp.hand.perturb_joints(level, rng)
                grasp = Grasp(
                    hand,
                    case.grasp.object,
                    case.grasp.object_pose,
                    name=f"{case.name}#joints{level:g}-{k}",
                )
                d = cache.descriptor(grasp, sampler, backend, **params)
                values.append(distance(base, d, kind="l2"))
            values = np.array(values)
            arrays[backend][f"{level:g}"] = values
            summary["backends"][backend]["levels"][f"{level:g}"] = {
                "mean": float(values.mean()),
                "median": float(np.median(values)),
                "max": float(values.max()),
                "std": float(values.std()),
                "n": int(values.size),
            }
    return summary, arrays
