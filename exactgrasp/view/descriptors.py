"""Descriptors as pictures: each descriptor an image of paths (rows) by steps (columns).

`path_order` sorts a sampler's paths the way a reader looks for them: translations, then
rotations, then both, each by direction (elevation, then azimuth) and rotation amount, so that
neighbouring rows are neighbouring directions. `plot_descriptors` draws a grid of descriptors
(one row per grasp, one column per backend) on one colour scale with its unit;
`write_descriptor_figure` writes it as a PNG (the figure of ``exactgrasp demo``).

"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.paths.sampler import PathSampler

__all__ = [
    "KIND_ORDER",
    "VALUE_LABEL",
    "path_order",
    "plot_descriptors",
    "write_descriptor_figure",
]

#: The order of the kinds of paths, top to bottom.
KIND_ORDER = ("translation", "rotation", "both")
#: What a descriptor value is, with its unit.
VALUE_LABEL = "volume(hand ∩ object) / volume(hand)"


def _angles(vectors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Elevation (asin z) and azimuth (atan2(y, x)) of unit vectors, rounded so that equal
    directions sort together."""
    elevation = np.round(np.arcsin(np.clip(vectors[:, 2], -1.0, 1.0)), 9)
    azimuth = np.round(np.arctan2(vectors[:, 1], vectors[:, 0]), 9)
    return elevation, azimuth


def path_order(sampler: PathSampler) -> np.ndarray:
    """The sampler's path indices, by kind (`KIND_ORDER`), then translation direction, then
    rotation axis (each by elevation, then azimuth), then rotation amount.

    Returns
    -------
    numpy.ndarray, shape (n_paths,), int
    """
    table = sampler.paths
    rank = np.array([KIND_ORDER.index(kind) for kind in table.kind])
    d_elev, d_azim = _angles(table.direction)
    a_elev, a_azim = _angles(table.axis)
    # np.lexsort sorts by the last key first.
    return np.lexsort((table.amount, a_azim, a_elev, d_azim, d_elev, rank))


def plot_descriptors(
    descriptors: Mapping[tuple[str, str], Any], size_per_panel: tuple[float, float] = (3.2, 3.0)
):
    """A matplotlib figure of descriptors, one panel each, on one colour scale.

    Parameters
    ----------
    descriptors : mapping of (row label, column label) to Descriptor
        E.g. ``{(grasp name, backend name): descriptor}``; every descriptor of one sampler.
        Rows and columns keep the mapping's order; a missing pair leaves its panel empty.
    size_per_panel : (float, float)
        Inches.

    Returns
    -------
    matplotlib.figure.Figure
        Panels: paths (rows, in `path_order`, kinds separated by white lines and named on the
        left) by steps (columns, path time t); the colour bar is shared and gives the unit
        (`VALUE_LABEL`), from 0 to the largest value of all.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(dict.fromkeys(r for r, _ in descriptors))
    columns = list(dict.fromkeys(c for _, c in descriptors))
    first = next(iter(descriptors.values()))
    sampler = first.sampler
    order = path_order(sampler)
    kinds = sampler.paths.kind[order]
    top = max(float(d.values.max()) for d in descriptors.values()) or 1.0
    width, height = size_per_panel
    fig, axes = plt.subplots(
        len(rows),
        len(columns),
        figsize=(width * len(columns) + 1.6, height * len(rows) + 0.6),
        squeeze=False,
        sharex=True,
        sharey=True,
        layout="constrained",
    )
    times = sampler.times
    image = None
    for i, row in enumerate(rows):
        for j, column in enumerate(columns):
            ax = axes[i, j]
            d = descriptors.get((row, column))
            if d is None:
                ax.set_axis_off()
                continue
            image = ax.imshow(
                d.values[order],
                aspect="auto",
                interpolation="nearest",
                cmap="viridis",
                vmin=0.0,
                vmax=top,
                extent=(-0.5, len(times) - 0.5, len(order) - 0.5, -0.5),
            )
            for k in range(1, len(kinds)):
                if kinds[k] != kinds[k - 1]:
                    ax.axhline(k - 0.5, color="white", linewidth=1.2)
            ax.set_title(f"{row}: {column}", fontsize=9)
            if i == len(rows) - 1:
                ax.set_xlabel("step (path time t)")
                ticks = np.unique(np.linspace(0, len(times) - 1, min(len(times), 5)).round())
                ax.set_xticks(ticks, [f"{times[int(t)]:.2g}" for t in ticks])
            if j == 0:
                groups = [k for k in KIND_ORDER if k in set(kinds)]
                centres = [float(np.mean(np.flatnonzero(kinds == k))) for k in groups]
                # One line each: the bands of the few translations and rotations are thin.
                ax.set_yticks(centres, [f"{k} ({np.sum(kinds == k)})" for k in groups])
                ax.set_ylabel("paths, by kind and direction", fontsize=8)
                ax.tick_params(axis="y", labelsize=6)
    if image is not None:
        fig.colorbar(image, ax=axes, label=VALUE_LABEL, shrink=0.9)
    return fig


def write_descriptor_figure(
    descriptors: Mapping[tuple[str, str], Any], path: str | os.PathLike, dpi: int = 120
) -> Path:
    """`plot_descriptors` written as a PNG file; returns its path."""
    import matplotlib.pyplot as plt

    fig = plot_descriptors(descriptors)
    path = Path(path)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
