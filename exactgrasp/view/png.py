"""A `Scene` as a static PNG picture (matplotlib, mplot3d, no display needed).

For reports and documentation. matplotlib sorts whole meshes, not triangles across meshes,
by depth, so overlaps can look slightly off; the HTML page is the faithful view.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from exactgrasp.errors import require
from exactgrasp.view.scene import Scene

COLORMAP = "viridis"


def write_png(
    scene: Scene,
    path: str | os.PathLike,
    size: tuple[float, float] = (9.0, 7.5),
    dpi: int = 110,
    view: tuple[float, float] = (22.0, -52.0),
) -> Path:
    """Draw the scene into a PNG file.

    Parameters
    ----------
    scene : Scene
    path : path-like
    size : (float, float)
        Figure width and height, inches.
    dpi : int
        Pixels per inch.
    view : (float, float)
        Camera elevation and azimuth, degrees.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    require("matplotlib", "the PNG grasp picture", extra="view")
    # A bare Figure renders through Agg without pyplot, so no display or global state is used.
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LightSource, Normalize
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    fig = Figure(figsize=size, dpi=dpi)
    ax = fig.add_subplot(projection="3d")
    # Draw in the order added (meshes, then paths and axes on top): mplot3d's depth sort is
    # per collection and would hide the paths inside the object.
    ax.computed_zorder = False
    light = LightSource(azdeg=225, altdeg=45)
    for mesh in scene.meshes:
        triangles = mesh.vertices[mesh.faces]
        is_object = mesh.role == "object"
        ax.add_collection3d(
            Poly3DCollection(
                triangles,
                facecolors=mesh.color,
                linewidths=0.0,
                alpha=0.5 if is_object else 1.0,
                shade=True,
                lightsource=light,
            )
        )
    for ghost in scene.ghosts:
        ax.add_collection3d(
            Poly3DCollection(
                ghost.vertices[ghost.faces], facecolors=ghost.color, linewidths=0.0, alpha=0.12
            )
        )
    cmap, norm = COLORMAP, Normalize(0.0, scene.t_max)
    for part in scene.paths:
        segments = np.stack([part.points[:-1], part.points[1:]], axis=1)
        middle = 0.5 * (part.times[:-1] + part.times[1:])
        ax.add_collection3d(
            Line3DCollection(segments, array=middle, cmap=cmap, norm=norm, linewidths=2.0)
        )
        steps = part.points[part.at_step]
        ax.scatter(
            *steps.T, c=part.times[part.at_step], cmap=cmap, norm=norm, s=6, depthshade=False
        )
    for axis in scene.axes:
        ax.plot(*np.stack([np.zeros(3), axis.tip]).T, color=axis.color, linewidth=2.5)
        ax.text(*(axis.tip * 1.08), axis.label, color=axis.color, fontsize=13, weight="bold")

    lo, hi = scene.bounds()
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo).max() * 1.02
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    ax.view_init(elev=view[0], azim=view[1])
    ax.set_xlabel("x")
    ax.set_ylabel("y (up)")
    ax.set_zlabel("z (out of the palm)")
    mm = f"canonical units: 1 unit = {scene.mm_per_unit:.3g} mm"
    ghosts = f"; faint: the object along {scene.ghosts[0].name.rpartition(' on ')[2]}"
    ax.set_title(f"{scene.title}\n{mm}{ghosts if scene.ghosts else ''}", fontsize=10)
    mappable = ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(mappable, ax=ax, shrink=0.6, pad=0.08, label="time t along the path")

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    return path
