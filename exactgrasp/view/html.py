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


def plotly_go():
    """``plotly.graph_objects``, or a `MissingDependencyError` naming the ``view`` extra."""
    return require("plotly.graph_objects", "the interactive grasp view", "plotly", "view")


def figure(scene: Scene) -> Any:
    """The plotly figure of a scene.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    plotly.graph_objects.Figure
        One ``Mesh3d`` per hand link and one for the object (named as in
        `Scene.trace_names`), one ``Scatter3d`` per frame axis and one per path.
    """
    go = plotly_go()
    traces = []
    for mesh in scene.meshes:
        v, f = mesh.vertices, mesh.faces
        traces.append(
            go.Mesh3d(
                x=v[:, 0],
                y=v[:, 1],
                z=v[:, 2],
                i=f[:, 0],
                j=f[:, 1],
                k=f[:, 2],
                name=mesh.name,
                color=mesh.color,
                opacity=0.55 if mesh.role == "object" else 1.0,
                flatshading=True,
                lighting={"ambient": 0.55, "diffuse": 0.8, "specular": 0.15},
                showlegend=True,
                legendgroup=mesh.role,
                legendgrouptitle_text="hand links" if mesh.role == "hand" else "object",
                hovertemplate=f"{mesh.name}<extra></extra>",
            )
        )
    for axis in scene.axes:
        ends = np.stack([np.zeros(3), axis.tip])
        traces.append(
            go.Scatter3d(
                x=ends[:, 0],
                y=ends[:, 1],
                z=ends[:, 2],
                mode="lines+text",
                text=["", axis.label],
                textposition="middle right",
                textfont={"color": axis.color, "size": 16},
                line={"color": axis.color, "width": 7},
                name=axis.name,
                legendgroup="frame",
                legendgrouptitle_text="canonical frame",
                hovertemplate=f"{axis.name}<extra></extra>",
            )
        )
    for k, path in enumerate(scene.paths):
        colors = {"color": path.times, "colorscale": COLORSCALE, "cmin": 0.0, "cmax": scene.t_max}
        traces.append(
            go.Scatter3d(
                x=path.points[:, 0],
                y=path.points[:, 1],
                z=path.points[:, 2],
                mode="lines+markers",
                line={**colors, "width": 5},
                marker={
                    **colors,
                    "size": np.where(path.at_step, STEP_MARKER, 0.0),
                    "showscale": k == 0,
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
                legendgroup="paths",
                legendgrouptitle_text="sampled paths (object centre)",
                customdata=path.times,
                hovertemplate=f"{path.name}<br>t = %{{customdata:.3f}}<extra></extra>",
            )
        )
    fig = go.Figure(traces)
    titles = {
        "x": "x (canonical)",
        "y": "y (canonical, up)",
        "z": "z (canonical, out of the palm)",
    }
    fig.update_layout(
        title={"text": scene.title, "font": {"size": 14}},
        scene={
            "aspectmode": "data",
            **{f"{a}axis": {"title": {"text": t}} for a, t in titles.items()},
            "camera": {"eye": {"x": 1.6, "y": -1.5, "z": 1.0}},
            "domain": {"x": [0.0, 1.0], "y": [0.12, 1.0]},
        },
        legend={"groupclick": "toggleitem", "itemsizing": "constant"},
        margin={"l": 0, "r": 0, "t": 50, "b": 0},
        paper_bgcolor="white",
    )
    return fig


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
