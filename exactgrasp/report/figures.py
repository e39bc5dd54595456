"""The report's PNG figures (matplotlib, Agg). Each function writes one file and returns it.

matplotlib is imported at the top: this is the one report module that loads it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator

from exactgrasp.compare import RELATIVE_FLOOR
from exactgrasp.report.estimator import ZERO

BACKEND_COLOURS = {"voxel": "tab:orange", "exact": "tab:blue"}


def save_figure(fig, path: Path) -> Path:
    """Write a matplotlib figure to the PNG file ``path`` (its folder made), close it, and
    return ``path``: one resolution and trim for every figure of the reports."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def _box_edges(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The 12 edges of an axis-aligned box: (12, 2, 3)."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    corners = lo + corners * (hi - lo)
    pairs = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
    return np.array([[corners[a], corners[b]] for a, b in pairs])


def figure1(sampler, path: Path, n_paths: int = 8) -> Path:
    """Sampled paths of a T-shaped object, coloured by time (the paper's Fig. 1).

    The T is the union of two boxes, drawn as its box edges at every pose of a few paths
    spread over the sampler's path list; the line through the poses follows the T's centre.
    """
    from matplotlib.colors import Normalize

    bar = _box_edges(np.array([-0.45, -0.08, 0.12]), np.array([0.45, 0.08, 0.28]))
    stem = _box_edges(np.array([-0.08, -0.08, -0.4]), np.array([0.08, 0.08, 0.12]))
    edges = np.concatenate([bar, stem])
    poses = sampler.poses()
    picks = np.unique(np.linspace(0, sampler.n_paths - 1, n_paths).round().astype(int))
    times = np.concatenate([[0.0], sampler.times])
    cmap, norm = plt.get_cmap("viridis"), Normalize(0.0, float(times.max()))
    fig = plt.figure(figsize=(7.5, 6.5))
    ax = fig.add_subplot(projection="3d")
    for p in picks:
        path_poses = np.concatenate([np.eye(4)[None], poses[p]])
        centre = path_poses[:, :3, 3]
        ax.plot(*centre.T, color="0.5", lw=0.8)
        for pose, t in zip(path_poses, times, strict=True):
            moved = edges @ pose[:3, :3].T + pose[:3, 3]
            for a, b in moved:
                ax.plot(*np.stack([a, b]).T, color=cmap(norm(t)), lw=0.9, alpha=0.85)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z (out of the palm)")
    ax.set_box_aspect((1, 1, 1))
    mappable = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(mappable, ax=ax, shrink=0.6, label="time t along the path")
    ax.set_title(f"{len(picks)} of {sampler.n_paths} sampled paths of a T-shaped object")
    return save_figure(fig, path)


def estimator_scatter(arrays: dict[str, Any], path: Path) -> Path:
    """Voxel against exact per pose, and relative error against the exact value."""
    vx, ex = arrays["voxel"].ravel(), arrays["exact"].ravel()
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), constrained_layout=True)
    ax = axes[0]
    floor = RELATIVE_FLOOR / 10
    pos = ex >= ZERO
    ax.scatter(
        np.maximum(ex[pos], floor),
        np.maximum(vx[pos], floor),
        s=2,
        alpha=0.25,
        color="tab:orange",
        rasterized=True,
        label="poses with overlap",
    )
    fp = ~pos & (vx > 0)
    ax.scatter(
        np.full(fp.sum(), floor),
        vx[fp],
        s=6,
        marker="|",
        color="tab:red",
        label=f"exact = 0, voxel > 0 ({fp.sum()} poses)",
    )
    top = max(float(ex.max()), float(vx.max()), 1e-3) * 1.5
    ax.plot([floor, top], [floor, top], color="k", lw=0.8, label="voxel = exact")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("exact intersection / hand volume")
    ax.set_ylabel("voxel estimate / hand volume")
    ax.set_title("per pose (values below 1e-5 drawn at 1e-5)")
    ax.legend(loc="upper left", fontsize=8)
    ax = axes[1]
    ok = ex > RELATIVE_FLOOR
    rel = (vx[ok] - ex[ok]) / ex[ok]
    ax.scatter(ex[ok], rel, s=2, alpha=0.25, color="tab:orange", rasterized=True)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=0.1)
    ax.set_xlabel("exact intersection / hand volume")
    ax.set_ylabel("(voxel - exact) / exact")
    ax.set_title(f"relative error where exact > {RELATIVE_FLOOR:g}")
    return save_figure(fig, path)


def error_by_step(summary: dict[str, Any], arrays: dict[str, Any], path: Path) -> Path:
    """Relative error distribution per step along the paths, and false positives per step."""
    vx, ex = arrays["voxel"], arrays["exact"]
    times = np.asarray(arrays["times"])
    data = []
    for k in range(len(times)):
        e, v = ex[:, :, k].ravel(), vx[:, :, k].ravel()
        ok = e > RELATIVE_FLOOR
        data.append((v[ok] - e[ok]) / e[ok] if ok.any() else np.array([np.nan]))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    ax = axes[0]
    ax.boxplot(data, positions=np.arange(len(times)), showfliers=False, widths=0.6)
    ax.plot(
        np.arange(len(times)),
        summary["by_step"]["median_signed_rel"],
        "o-",
        color="tab:orange",
        label="median signed",
    )
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(np.arange(len(times)), [f"{t:.2f}" for t in times])
    ax.set_xlabel("time t along the path")
    ax.set_ylabel("(voxel - exact) / exact")
    ax.set_title("relative error per step (boxes: quartiles, whiskers 1.5 IQR)")
    ax.legend()
    ax = axes[1]
    by = summary["by_step"]
    ax.bar(np.arange(len(times)), by["false_positive_rate"], color="tab:red", alpha=0.7)
    ax.set_xticks(np.arange(len(times)), [f"{t:.2f}" for t in times])
    ax.set_xlabel("time t along the path")
    ax.set_ylabel("share of zero-overlap poses with voxel > 0")
    ax.set_title("false positives per step")
    return save_figure(fig, path)


def error_histogram(arrays: dict[str, Any], path: Path) -> Path:
    """Histogram of signed relative errors, both surface weights."""
    ex = arrays["exact"].ravel()
    ok = ex > RELATIVE_FLOOR
    fig, ax = plt.subplots(figsize=(7.5, 4.5), constrained_layout=True)
    bins = np.linspace(-1.0, 2.0, 121)
    for key, label, colour in (
        ("voxel", "surface weight 'paper'", "tab:orange"),
        ("area", "surface weight 'area'", "tab:green"),
    ):
        v = arrays[key].ravel()[ok]
        rel = np.clip((v - ex[ok]) / ex[ok], bins[0], bins[-1])
        ax.hist(rel, bins=bins, histtype="step", lw=1.5, color=colour, label=label)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_yscale("log")
    ax.set_xlabel("(voxel - exact) / exact   (clipped to [-1, 2])")
    ax.set_ylabel("poses")
    ax.set_title(f"relative error, poses where exact > {RELATIVE_FLOOR:g}")
    ax.legend()
    return save_figure(fig, path)


def resolution_grid(grid: dict[str, Any], path: Path) -> Path:
    """Heat maps over (object, hand) resolution: median |rel|, mean signed rel, seconds."""
    keys = (
        ("median_abs_rel", "median |relative error|"),
        ("mean_signed_rel", "mean signed relative error"),
        ("false_positive_rate", "false-positive rate"),
        ("seconds", "seconds per descriptor"),
    )
    fig, axes = plt.subplots(1, len(keys), figsize=(5.2 * len(keys), 4.0), constrained_layout=True)
    for ax, (key, title) in zip(axes, keys, strict=True):
        values = grid[key]
        image = ax.imshow(values, cmap="magma_r", origin="lower")
        for (i, j), value in np.ndenumerate(values):
            ax.text(
                j,
                i,
                f"{value:.3g}",
                ha="center",
                va="center",
                fontsize=9,
                color="w" if value > np.nanmean(values) else "k",
            )
        ax.set_xticks(range(len(grid["hand_resolutions"])), grid["hand_resolutions"])
        ax.set_yticks(range(len(grid["object_resolutions"])), grid["object_resolutions"])
        ax.set_xlabel("hand resolution")
        ax.set_ylabel("object resolution")
        ax.set_title(title, fontsize=10)
        fig.colorbar(image, ax=ax, shrink=0.8)
    return save_figure(fig, path)


def distance_matrices(matrices: dict[str, np.ndarray], path: Path) -> Path:
    """L2 distance matrices from both backends, and pairwise distances voxel vs exact."""
    fig, axes = plt.subplots(1, 4, figsize=(19, 4.4), constrained_layout=True)
    vmax = max(matrices["l2_voxel"].max(), matrices["l2_exact"].max())
    for ax, key in zip(axes[:2], ("l2_exact", "l2_voxel"), strict=True):
        image = ax.imshow(matrices[key], cmap="viridis", vmin=0, vmax=vmax)
        ax.set_title(f"L2 distances, {key.split('_')[-1]}")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_xlabel("grasp")
        ax.set_ylabel("grasp")
        fig.colorbar(image, ax=ax, shrink=0.8)
    n = matrices["l2_voxel"].shape[0]
    upper = np.triu_indices(n, k=1)
    for ax, kind in zip(axes[2:], ("l2", "l2_diff"), strict=True):
        e, v = matrices[f"{kind}_exact"][upper], matrices[f"{kind}_voxel"][upper]
        ax.scatter(e, v, s=4, alpha=0.5)
        top = max(e.max(), v.max()) * 1.05
        ax.plot([0, top], [0, top], color="k", lw=0.8)
        ax.set_xlabel(f"{kind} distance, exact")
        ax.set_ylabel(f"{kind} distance, voxel")
        ax.set_title(f"pairs of grasps, {kind}")
    return save_figure(fig, path)


def within_between(noise: dict[str, Any], preset: str, kind: str, path: Path) -> Path:
    """Within- vs between-object distance histograms per backend and level (Fig. 4)."""
    backends = list(noise[preset])
    levels = list(noise[preset][backends[0]][kind])
    fig, axes = plt.subplots(
        len(backends), len(levels), squeeze=False, figsize=(5.5 * len(levels), 3.6 * len(backends))
    )
    for r, backend in enumerate(backends):
        for c, level in enumerate(levels):
            within, between, _ = noise[preset][backend][kind][level]
            ax = axes[r, c]
            top = max(within.max(), between.max())
            bins = np.linspace(0, top * 1.02, 40)
            ax.hist(within, bins=bins, alpha=0.6, color="tab:blue", label="within object")
            ax.hist(between, bins=bins, alpha=0.6, color="tab:red", label="between objects")
            ax.set_title(f"{backend}, {level}", fontsize=10)
            ax.set_xlabel(f"{kind} distance")
            ax.set_ylabel("pairs")
            ax.legend(fontsize=8)
    return save_figure(fig, path)


def per_grasp_spread(summary: dict[str, Any], path: Path) -> Path:
    """Per-grasp within spreads and per-pair between spreads, mean ± std (Fig. 5)."""
    main = summary["samplers"][0]
    backends = list(summary[main]["backends"])
    fig, axes = plt.subplots(
        len(backends), 2, figsize=(15, 3.8 * len(backends)), squeeze=False, constrained_layout=True
    )
    for r, backend in enumerate(backends):
        levels = summary[main]["backends"][backend]["l2"]
        for c, part in enumerate(("within", "between")):
            ax = axes[r, c]
            for li, (level, entry) in enumerate(levels.items()):
                rows = entry["per_grasp"][part]
                x = np.arange(len(rows)) + 0.15 * li
                ax.errorbar(
                    x,
                    [v["mean"] for v in rows.values()],
                    yerr=[v["std"] for v in rows.values()],
                    fmt="o",
                    capsize=3,
                    label=level,
                )
            first = next(iter(levels.values()))
            for value in (first["max_within"], first["min_between"]):
                ax.axhline(value, color="0.6", lw=1)
            labels = [k.replace(" | ", "\n") for k in rows]
            ax.set_xticks(np.arange(len(rows)), labels, rotation=90, fontsize=6)
            ax.set_ylabel("L2 distance")
            ax.set_title(
                f"{backend}, {main} sampler: {part}-object (grey: max within, min between, "
                "small noise)",
                fontsize=9,
            )
            ax.legend(fontsize=8)
    return save_figure(fig, path)


def joint_noise(arrays: dict[str, Any], reference: dict[str, float], path: Path) -> Path:
    """L2 distance to the unperturbed grasp per joint-noise level and backend (Fig. 3)."""
    backends = list(arrays)
    fig, axes = plt.subplots(
        1, len(backends), figsize=(6 * len(backends), 4.2), squeeze=False, constrained_layout=True
    )
    for ax, backend in zip(axes[0], backends, strict=True):
        levels = list(arrays[backend])
        ax.boxplot([arrays[backend][k] for k in levels], showfliers=False)
        # Every draw as a point: with few draws a box alone would hide how few there are.
        rng = np.random.default_rng(0)
        for i, k in enumerate(levels, start=1):
            values = arrays[backend][k]
            ax.plot(i + rng.uniform(-0.12, 0.12, len(values)), values, ".", color="0.3", ms=4)
        ax.set_xticks(np.arange(1, len(levels) + 1), [f"{float(k) * 100:g} %" for k in levels])
        if backend in reference:
            ax.axhline(
                reference[backend], color="tab:red", lw=1, label="smallest between-object distance"
            )
            ax.legend(fontsize=8)
        ax.set_xlabel("joint noise (fraction of each joint's range)")
        ax.set_ylabel("L2 distance to the unperturbed grasp")
        ax.set_title(f"spray-bottle grasp, {backend}")
    return save_figure(fig, path)


def presets(noise: dict[str, Any], preset_names: list[str], path: Path) -> Path:
    """Within vs between per preset and backend, plus L2 of differences (Fig. 6)."""
    columns = [(p, "l2") for p in preset_names] + [(preset_names[0], "l2_diff")]
    backends = list(dict.fromkeys(b for p in preset_names for b in noise.get(p, {})))
    fig, axes = plt.subplots(
        len(backends),
        len(columns),
        squeeze=False,
        constrained_layout=True,
        figsize=(4.6 * len(columns), 3.4 * len(backends)),
    )
    shades = {"within": ("tab:blue", "navy"), "between": ("tab:red", "darkred")}
    for r, backend in enumerate(backends):
        for c, (preset, kind) in enumerate(columns):
            ax = axes[r, c]
            entry = noise.get(preset, {}).get(backend, {}).get(kind)
            if not entry:
                ax.set_axis_off()
                ax.set_title(f"{backend}, {preset}: not run", fontsize=9)
                continue
            top = max(max(w.max(), b.max()) for w, b, _ in entry.values())
            bins = np.linspace(0, top * 1.02, 40)
            for li, (level, (within, between, _)) in enumerate(entry.items()):
                for part, values in (("within", within), ("between", between)):
                    ax.hist(
                        values,
                        bins=bins,
                        histtype="step",
                        lw=1.3,
                        color=shades[part][li % 2],
                        label=f"{part} {level}",
                    )
            ax.set_title(f"{backend}, {preset}, {kind}", fontsize=9)
            ax.set_xlabel("distance")
            ax.legend(fontsize=6)
    return save_figure(fig, path)
