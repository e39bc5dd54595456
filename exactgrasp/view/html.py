"""A `Scene` as one self-contained interactive HTML page (plotly, its script embedded).

The page needs no network when opened: plotly.js is written into it. Rotate with the left
mouse button, pan with the right, zoom with the wheel; a click on a legend entry hides it.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.errors import require
from exactgrasp.view.scene import Scene

COLORSCALE = "Viridis"
#: Marker size (px) at the sampler's step times; the curve between them has none.
STEP_MARKER = 3.5
#: Opacity of the object's ghosted copies along a path.
GHOST_OPACITY = 0.18
#: Where the camera looks from, relative to the scene's box: far enough that the box, its
#: axis titles included, fits the page (plotly's default, 1.25 each, cuts the x title).
CAMERA_EYE = {"x": 2.0, "y": -1.9, "z": 1.25}
#: The legend's words for each kind of path (one entry per kind drawn).
KIND_LABELS = {"translation": "translations", "rotation": "rotations", "both": "both"}


def _legend(go: Any, scene: Scene) -> list:
    """One empty trace per legend entry: the hand, the object, its ghosts, the frame, and the
    drawn paths of each kind (with their count)."""
    from exactgrasp.view.scene import AXES, HAND_COLOR, OBJECT_COLOR

    n_links = sum(m.role == "hand" for m in scene.meshes)
    entries = [
        ("hand", f"hand ({n_links} links)", HAND_COLOR),
        ("object", "object", OBJECT_COLOR),
    ]
    if scene.ghosts:
        path = scene.ghosts[0].name.rpartition(" on ")[2]
        entries.append(("ghost", f"object along {path} ({len(scene.ghosts)} copies)", "#f4c19c"))
    entries.append(("frame", "canonical frame axes", AXES[2][2]))
    for kind, label in KIND_LABELS.items():
        count = sum(p.kind == kind for p in scene.paths)
        if count:
            noun = "path" if count == 1 else "paths"
            entries.append((f"paths {kind}", f"{count} {noun}: {label}", "#31688e"))
    return [
        go.Scatter3d(
            x=[None],
            y=[None],
            z=[None],
            mode="markers",
            marker={"color": colour, "size": 9, "symbol": "square"},
            name=label,
            legendgroup=group,
            showlegend=True,
            hoverinfo="skip",
        )
        for group, label, colour in entries
    ]


def plotly_go():
    """``plotly.graph_objects``, or a `MissingDependencyError` naming the ``view`` extra."""
    return require("plotly.graph_objects", "the interactive grasp view", "plotly", "view")


def _mesh_trace(go, mesh, *, opacity: float, group: str, lighting: dict | None = None):
    """A ``Mesh3d`` trace of one mesh of the scene (a link, the object or a ghost)."""
    v, f = mesh.vertices, mesh.faces
    options = {} if lighting is None else {"lighting": lighting}
    return go.Mesh3d(
        x=v[:, 0],
        y=v[:, 1],
        z=v[:, 2],
        i=f[:, 0],
        j=f[:, 1],
        k=f[:, 2],
        name=mesh.name,
        color=mesh.color,
        opacity=opacity,
        flatshading=True,
        showlegend=False,
        legendgroup=group,
        hovertemplate=f"{mesh.name}<extra></extra>",
        **options,
    )


def figure(scene: Scene) -> Any:
    """The plotly figure of a scene.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    plotly.graph_objects.Figure
        One ``Mesh3d`` per hand link, one for the object and one per ghost (named as in
        `Scene.trace_names` and `MeshPart.name`), one ``Scatter3d`` per frame axis and one
        per path. The legend has one entry per group (the hand, the object, its ghosts, the
        frame, each kind of path; empty legend-only traces), and a click on it hides the
        group.
    """
    go = plotly_go()
    traces = [
        _mesh_trace(
            go,
            mesh,
            opacity=0.55 if mesh.role == "object" else 1.0,
            group=mesh.role,
            lighting={"ambient": 0.55, "diffuse": 0.8, "specular": 0.15},
        )
        for mesh in scene.meshes
    ]
    traces += [
        _mesh_trace(go, ghost, opacity=GHOST_OPACITY, group="ghost") for ghost in scene.ghosts
    ]
    traces += [_axis_trace(go, axis) for axis in scene.axes]
    traces += [
        _path_trace(go, scene, path, with_scale=k == 0) for k, path in enumerate(scene.paths)
    ]
    traces.extend(_legend(go, scene))
    fig = go.Figure(traces)
    fig.update_layout(**_layout(scene))
    return fig


def _axis_trace(go, axis):
    """A ``Scatter3d`` trace of one axis of the canonical frame: a line and its label."""
    ends = np.stack([np.zeros(3), axis.tip])
    return go.Scatter3d(
        x=ends[:, 0],
        y=ends[:, 1],
        z=ends[:, 2],
        mode="lines+text",
        text=["", axis.label],
        textposition="middle right",
        textfont={"color": axis.color, "size": 16},
        line={"color": axis.color, "width": 7},
        name=axis.name,
        showlegend=False,
        legendgroup="frame",
        hovertemplate=f"{axis.name}<extra></extra>",
    )


def _path_trace(go, scene: Scene, path, *, with_scale: bool):
    """A ``Scatter3d`` trace of one path: the object's centre coloured by time, markers at
    the sampler's steps; ``with_scale`` draws the time colour bar (once per figure)."""
    colors = {"color": path.times, "colorscale": COLORSCALE, "cmin": 0.0, "cmax": scene.t_max}
    return go.Scatter3d(
        x=path.points[:, 0],
        y=path.points[:, 1],
        z=path.points[:, 2],
        mode="lines+markers",
        line={**colors, "width": 5},
        marker={
            **colors,
            "size": np.where(path.at_step, STEP_MARKER, 0.0),
            "showscale": with_scale,
            "colorbar": {
                "title": {"text": "time t along the path", "side": "top"},
                "orientation": "h",
                "len": 0.45,
                "thickness": 14,
                "x": 0.45,
                "y": 0.02,
                "yanchor": "bottom",
            },
        },
        name=path.name,
        showlegend=False,
        legendgroup=f"paths {path.kind}",
        customdata=np.column_stack([path.times, path.points * scene.mm_per_unit]),
        hovertemplate=(
            f"{path.name}<br>t = %{{customdata[0]:.3f}}<br>centre (mm): "
            "%{customdata[1]:.1f}, %{customdata[2]:.1f}, %{customdata[3]:.1f}"
            "<extra></extra>"
        ),
    )


def _layout(scene: Scene) -> dict[str, Any]:
    """The figure's layout: title with the unit, axis titles, camera, legend."""
    mm = f"unit = {scene.mm_per_unit:.3g} mm"
    titles = {"x": f"x ({mm})", "y": f"y, up ({mm})", "z": f"z, out of the palm ({mm})"}
    units = f"canonical frame: 1 unit = {scene.mm_per_unit:.3g} mm (half the palm frame's depth)"
    return dict(
        title={"text": f"{scene.title}<br><sup>{units}</sup>", "font": {"size": 14}},
        scene={
            "aspectmode": "data",
            **{f"{a}axis": {"title": {"text": t}} for a, t in titles.items()},
            "camera": {"eye": CAMERA_EYE},
            "domain": {"x": [0.0, 1.0], "y": [0.16, 0.97]},
        },
        legend={"groupclick": "togglegroup", "itemsizing": "constant"},
        margin={"l": 0, "r": 0, "t": 50, "b": 0},
        paper_bgcolor="white",
    )


def write_html(scene: Scene, path: str | os.PathLike) -> Path:
    """Write the scene as one HTML file with plotly.js embedded (no network needed to view).

    Parameters
    ----------
    scene : Scene
    path : path-like

    Returns
    -------
    pathlib.Path
        The file written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure(scene).write_html(
        path,
        include_plotlyjs=True,
        full_html=True,
        config={"displaylogo": False, "responsive": True},
    )
    return path
