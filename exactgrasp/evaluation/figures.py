"""The report's figures (matplotlib, Agg): one function per PNG, each returning its path."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from exactgrasp.evaluation.write import finish_roc
from exactgrasp.report.figures import BACKEND_COLOURS, save_figure


def roc_figure(clusters: dict, default: str, path: Path) -> Path:
    """ROC curves on the cereal-box clusters: the default, L2 and the baselines (voxel)."""
    fig, ax = plt.subplots(figsize=(5.5, 5))
    voxel = clusters["backends"]["voxel"]["distances"]
    for name in dict.fromkeys(["l2", default]):
        e = voxel[name]
        ax.plot(e["curve"]["fpr"], e["curve"]["tpr"], lw=1.8, label=f"{name}: {e['auc']:.3f}")
    for name, e in clusters["baselines"].items():
        ax.plot(
            e["curve"]["fpr"], e["curve"]["tpr"], "--", lw=1.1, label=f"{name}: {e['auc']:.3f}"
        )
    return finish_roc(
        fig,
        ax,
        path,
        f"cereal box, {clusters['n_pairs']} pairs ({clusters['n_same']} same)",
        x_label="different-cluster pairs called same",
        y_label="same-cluster pairs called same",
    )


def auc_bars(clusters: dict, path: Path, title: str = "") -> Path:
    """AUC with its interval for every distance (both backends) and baseline."""
    names = list(clusters["backends"]["voxel"]["distances"])
    fig, ax = plt.subplots(figsize=(7, 0.32 * (len(names) + 5) + 1))
    y = np.arange(len(names))
    for backend, offset in (("voxel", -0.18), ("exact", 0.18)):
        if backend not in clusters["backends"]:
            continue
        rows = clusters["backends"][backend]["distances"]
        a = np.array([rows[n]["auc"] for n in names])
        lo = np.array([rows[n]["low"] for n in names])
        hi = np.array([rows[n]["high"] for n in names])
        ax.errorbar(
            a, y + offset, xerr=[a - lo, hi - a], fmt="o", ms=4, capsize=2,
            color=BACKEND_COLOURS[backend], label=backend,
        )  # fmt: skip
    base = list(clusters["baselines"])
    yb = len(names) + np.arange(len(base)) + 0.5
    a = np.array([clusters["baselines"][n]["auc"] for n in base])
    lo = np.array([clusters["baselines"][n]["low"] for n in base])
    hi = np.array([clusters["baselines"][n]["high"] for n in base])
    ax.errorbar(a, yb, xerr=[a - lo, hi - a], fmt="s", ms=4, capsize=2, color="k",
                label="baseline")  # fmt: skip
    ax.set_yticks(np.r_[y, yb], [*names, *(f"baseline: {b}" for b in base)], fontsize=8)
    ax.axvline(0.9, color="grey", ls=":", lw=0.8)
    ax.invert_yaxis()
    ax.set_xlabel("AUC on the cereal-box clusters (95% interval, grasps resampled)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8, loc="lower left")
    return save_figure(fig, path)


def sampling_figure(sampling: dict, path: Path) -> Path:
    """AUC (with interval) and noise separation against poses per grasp, per backend.

    Poses (paths x steps), not seconds, on the x axis: the seconds measured on shared cores
    carry one-off costs (grids, tables) and are labelled beside the points instead.
    """
    rows = [r for r in sampling["rows"] if r["n_steps"] == 9]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for backend in ("voxel", "exact"):
        mine = sorted((r for r in rows if r["backend"] == backend), key=lambda r: r["n_paths"])
        if not mine:
            continue
        t = np.array([r["n_poses"] for r in mine])
        a = np.array([r["auc"]["auc"] for r in mine])
        lo = np.array([r["auc"]["low"] for r in mine])
        hi = np.array([r["auc"]["high"] for r in mine])
        axes[0].errorbar(t, a, yerr=[a - lo, hi - a], fmt="o-", capsize=2,
                         color=BACKEND_COLOURS[backend], label=backend)  # fmt: skip
        for r, x, y in zip(mine, t, a, strict=True):
            axes[0].annotate(f"{r['seconds_per_grasp']:.2g} s", (x, y), fontsize=7,
                             xytext=(3, 3), textcoords="offset points")  # fmt: skip
        noisy = [r for r in mine if "noise" in r]
        for key in noisy[0]["noise"]["levels"] if noisy else {}:
            ratio = [r["noise"]["levels"][key][sampling["distance"]]["ratio_of_medians"]
                     for r in noisy]  # fmt: skip
            axes[1].plot([r["n_poses"] for r in noisy], ratio, "o-", label=key)
    axes[0].set_xscale("log")
    axes[0].set_xlabel("poses per grasp (paths x 9 steps); labels: seconds per grasp")
    axes[0].set_ylabel(f"cluster AUC, {sampling['distance']}")
    axes[0].legend(fontsize=8)
    axes[1].set_xscale("log")
    axes[1].set_xlabel("poses per grasp (voxel)")
    axes[1].set_ylabel("noise test: median between / median within")
    axes[1].legend(fontsize=8)
    return save_figure(fig, path)


def steps_figure(sampling: dict, path: Path) -> Path:
    """Cluster AUC against steps per path (balanced preset's paths, voxel)."""
    rows = sorted(
        (r for r in sampling["rows"] if r["label"].startswith("balanced")),
        key=lambda r: r["n_steps"],
    )
    rows = [r for r in rows if r["backend"] == "voxel"]
    fig, ax = plt.subplots(figsize=(5, 3.6))
    s = np.array([r["n_steps"] for r in rows])
    a = np.array([r["auc"]["auc"] for r in rows])
    lo = np.array([r["auc"]["low"] for r in rows])
    hi = np.array([r["auc"]["high"] for r in rows])
    ax.errorbar(s, a, yerr=[a - lo, hi - a], fmt="o-", capsize=2, color=BACKEND_COLOURS["voxel"])
    ax.set_xlabel("steps per path (474 paths)")
    ax.set_ylabel(f"cluster AUC, {sampling['distance']}")
    return save_figure(fig, path)


def hands_figure(hands: dict[str, Any], path: Path) -> Path:
    """Across-hand AUC (with interval) for each normalisation, one row of points per group."""
    groups = list(hands["groups"])
    names = list(hands["groups"][groups[0]]["normalisations"])
    fig, ax = plt.subplots(figsize=(6.5, 0.5 * len(names) * len(groups) / 2 + 1.5))
    width = 0.8 / len(groups)
    for k, group in enumerate(groups):
        rows = [hands["groups"][group]["normalisations"][n]["same_placement_across_hands"]
                for n in names]  # fmt: skip
        a = np.array([r["auc"] for r in rows])
        lo = np.array([r["low"] for r in rows])
        hi = np.array([r["high"] for r in rows])
        y = np.arange(len(names)) + (k - (len(groups) - 1) / 2) * width
        ax.errorbar(a, y, xerr=[a - lo, hi - a], fmt="o", ms=4, capsize=2, label=group)
    ax.set_yticks(np.arange(len(names)), names)
    ax.axvline(0.5, color="grey", ls=":", lw=0.8)
    ax.set_xlabel("AUC: same placement across hands against different placements in one hand")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.invert_yaxis()
    return save_figure(fig, path)
