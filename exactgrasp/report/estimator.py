"""How far the paper's voxel estimator is from the exact volume: pose by pose, along the paths,
against resolution and surface weight, and what each costs.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from exactgrasp.compare import RELATIVE_FLOOR
from exactgrasp.paths.sampler import PathSampler
from exactgrasp.report.cache import DescriptorCache
from exactgrasp.report.config import ValidationConfig
from exactgrasp.report.data import Case

#: Exact values below this (fraction of the hand volume) count as no overlap at all: a voxel
#: value above zero there is a false positive.
ZERO = 1e-9


def error_summary(estimate: np.ndarray, exact: np.ndarray) -> dict[str, float]:
    """Pose-by-pose errors of an estimate against exact values (descriptor units).

    Parameters
    ----------
    estimate, exact : numpy.ndarray, same shape
        Intersection volume / hand volume at the same poses.

    Returns
    -------
    dict
        Relative errors over the poses whose exact value exceeds `RELATIVE_FLOOR`
        (``median_abs_rel``, ``p95_abs_rel``, ``max_abs_rel``, ``mean_signed_rel``,
        ``median_signed_rel``, ``fraction_over``: share of those poses over-estimated);
        ``mean_signed_error`` over all poses; at the poses where the exact value is zero,
        ``false_positive_poses`` (estimate > 0), their share ``false_positive_rate`` and
        ``false_positive_max``; ``false_negative_poses`` (exact > floor, estimate 0);
        ``correlation`` (Pearson); ``n_poses``, ``n_compared``, ``n_zero``.
    """
    estimate, exact = np.ravel(estimate), np.ravel(exact)
    compared = exact > RELATIVE_FLOOR
    rel = (estimate[compared] - exact[compared]) / exact[compared]
    zero = exact < ZERO
    fp = zero & (estimate > 0)
    if estimate.std() > 0 and exact.std() > 0:
        correlation = float(np.corrcoef(estimate, exact)[0, 1])
    else:
        correlation = float("nan")
    has = rel.size > 0
    return {
        "median_abs_rel": float(np.median(np.abs(rel))) if has else float("nan"),
        "p95_abs_rel": float(np.percentile(np.abs(rel), 95)) if has else float("nan"),
        "max_abs_rel": float(np.abs(rel).max()) if has else float("nan"),
        "mean_signed_rel": float(rel.mean()) if has else float("nan"),
        "median_signed_rel": float(np.median(rel)) if has else float("nan"),
        "fraction_over": float(np.mean(rel > 0)) if has else float("nan"),
        "mean_signed_error": float((estimate - exact).mean()),
        "mean_exact": float(exact.mean()),
        "false_positive_poses": int(fp.sum()),
        "false_positive_rate": float(fp.sum() / max(zero.sum(), 1)),
        "false_positive_max": float(estimate[fp].max()) if fp.any() else 0.0,
        "false_negative_poses": int(np.sum(compared & (estimate == 0))),
        "correlation": correlation,
        "n_poses": int(exact.size),
        "n_compared": int(compared.sum()),
        "n_zero": int(zero.sum()),
    }


def _grouped(estimate: np.ndarray, exact: np.ndarray, groups: np.ndarray, labels) -> dict:
    """`error_summary` per group label, as lists in label order."""
    rows = [error_summary(estimate[groups == g], exact[groups == g]) for g in labels]
    keys = (
        "median_abs_rel",
        "p95_abs_rel",
        "median_signed_rel",
        "mean_signed_error",
        "false_positive_rate",
        "n_compared",
        "n_zero",
    )
    return {key: [row[key] for row in rows] for key in keys}


def _seconds(descriptors: Sequence[Any]) -> float:
    return float(np.mean([d.metadata.get("seconds", np.nan) for d in descriptors]))


def estimator_report(
    cases: Sequence[Case],
    cache: DescriptorCache,
    config: ValidationConfig,
    resolution_cases: Sequence[Case],
    log: Callable[[str], None] = print,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Voxel against exact on the real grasps.

    Parameters
    ----------
    cases : sequence of Case
        The grasps of the main comparison.
    cache : DescriptorCache
    config : ValidationConfig
    resolution_cases : sequence of Case
        The grasps of the resolution sweep.
    log : callable

    Returns
    -------
    summary : dict
        JSON-ready numbers (see ``docs/validation.md``).
    arrays : dict
        Per-pose values for the figures: ``voxel``, ``exact``, ``area`` (n_cases, n_paths,
        n_steps), ``times``, ``kind`` (per path), ``resolution`` (grid of medians), ...
    """
    sampler = config.main_sampler()
    voxel_params = config.voxel_params()
    log(f"estimator: {len(cases)} grasps x {sampler.n_poses} poses, voxel and exact")
    exact_params = config.backend_params("exact")
    exact = [cache.descriptor(c.grasp, sampler, "exact", **exact_params) for c in cases]
    voxel = [cache.descriptor(c.grasp, sampler, "voxel", **voxel_params) for c in cases]
    log("estimator: surface weight 'area'")
    area = [
        cache.descriptor(c.grasp, sampler, "voxel", **config.voxel_params(surface_weight="area"))
        for c in cases
    ]
    ex = np.stack([d.values for d in exact])
    vx = np.stack([d.values for d in voxel])
    ar = np.stack([d.values for d in area])

    n_cases = len(cases)
    steps = np.broadcast_to(np.arange(sampler.n_steps), ex.shape)
    kinds = np.broadcast_to(sampler.paths.kind[None, :, None], ex.shape)
    magnitude_edges = np.array([RELATIVE_FLOOR, 1e-3, 1e-2, 1e-1, np.inf])
    magnitude = np.digitize(ex, magnitude_edges)

    summary: dict[str, Any] = {
        "sampler": sampler.params,
        "voxel_params": voxel_params,
        "n_grasps": n_cases,
        "overall": error_summary(vx, ex),
        "by_step": {
            "t": sampler.times.tolist(),
            **_grouped(vx, ex, steps, range(sampler.n_steps)),
        },
        "by_kind": {
            "kind": ["both", "translation", "rotation"],
            **_grouped(vx, ex, kinds, ["both", "translation", "rotation"]),
        },
        "by_magnitude": {
            "lower": magnitude_edges[:-1].tolist(),
            **_grouped(vx, ex, magnitude, range(1, len(magnitude_edges))),
        },
        "by_grasp": {
            c.name: {"object": c.object, **error_summary(v.values, e.values)}
            for c, v, e in zip(cases, voxel, exact, strict=True)
        },
        "by_object": {},
        "surface_weight": {
            "paper": error_summary(vx, ex),
            "area": error_summary(ar, ex),
        },
        "seconds_per_descriptor": {
            "exact": _seconds(exact),
            "voxel": _seconds(voxel),
            "voxel_area": _seconds(area),
        },
    }
    summary["surface_weight"]["paper"]["seconds_per_descriptor"] = _seconds(voxel)
    summary["surface_weight"]["area"]["seconds_per_descriptor"] = _seconds(area)
    objects = sorted({c.object for c in cases})
    for obj in objects:
        picks = [i for i, c in enumerate(cases) if c.object == obj]
        summary["by_object"][obj] = {"n_grasps": len(picks), **error_summary(vx[picks], ex[picks])}

    resolution, res_grid = _resolution_sweep(resolution_cases, cache, config, sampler, log)
    summary["resolution"] = resolution
    arrays = {
        "voxel": vx,
        "exact": ex,
        "area": ar,
        "names": [c.name for c in cases],
        "objects": [c.object for c in cases],
        "times": sampler.times,
        "kind": sampler.paths.kind,
        "resolution_grid": res_grid,
        "exact_descriptors": exact,
        "voxel_descriptors": voxel,
    }
    return summary, arrays


def _resolution_sweep(
    cases: Sequence[Case],
    cache: DescriptorCache,
    config: ValidationConfig,
    sampler: PathSampler,
    log: Callable[[str], None],
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Voxel errors for every (object, hand) resolution pair, against the same exact values."""
    log(
        f"estimator: resolution sweep, {len(cases)} grasps x "
        f"{len(config.object_resolutions)} x {len(config.hand_resolutions)} resolutions"
    )
    params = config.backend_params("exact")
    exact = np.stack([cache.descriptor(c.grasp, sampler, "exact", **params).values for c in cases])
    shape = (len(config.object_resolutions), len(config.hand_resolutions))
    grid = {
        key: np.full(shape, np.nan)
        for key in (
            "median_abs_rel",
            "p95_abs_rel",
            "mean_signed_rel",
            "false_positive_rate",
            "seconds",
        )
    }
    rows = {}
    for i, obj_res in enumerate(config.object_resolutions):
        for j, hand_res in enumerate(config.hand_resolutions):
            params = config.voxel_params(object_resolution=obj_res, hand_resolution=hand_res)
            ds = [cache.descriptor(c.grasp, sampler, "voxel", **params) for c in cases]
            row = error_summary(np.stack([d.values for d in ds]), exact)
            row["seconds_per_descriptor"] = _seconds(ds)
            rows[f"object{obj_res}_hand{hand_res}"] = {
                "object_resolution": obj_res,
                "hand_resolution": hand_res,
                **row,
            }
            for key in grid:
                grid[key][i, j] = row["seconds_per_descriptor" if key == "seconds" else key]
    grid["object_resolutions"] = list(config.object_resolutions)
    grid["hand_resolutions"] = list(config.hand_resolutions)
    return {"grasps": [c.name for c in cases], "configs": rows}, grid
