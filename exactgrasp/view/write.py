"""`show`: write the picture of a grasp, an interactive HTML page and optionally a PNG."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, NamedTuple

from exactgrasp.grasp.grasp import Grasp
from exactgrasp.view.html import plotly_go, write_html
from exactgrasp.view.png import write_png
from exactgrasp.view.scene import Scene, build_scene


class Shown(NamedTuple):
    """What `show` wrote.

    Attributes
    ----------
    html : pathlib.Path or None
        The HTML page (None when ``path=None``).
    png : pathlib.Path or None
        The PNG picture (None unless ``png`` was given).
    scene : Scene
        The geometry drawn.
    """

    html: Path | None
    png: Path | None
    scene: Scene


def show(
    grasp: Grasp | str | os.PathLike,
    sampler: Any = None,
    n_paths: int = 24,
    path: str | os.PathLike | None = "grasp.html",
    png: str | os.PathLike | None = None,
    steps: int | None = None,
    title: str | None = None,
    open_browser: bool = False,
) -> Shown:
    """Picture a grasp: the hand links, the object, the canonical axes and sampled paths.

    Everything is drawn in the hand's canonical frame. The paths are the sampler's rigid
    motions of the object, drawn as the object's centre moving from the grasp (t = 0) to the
    last step time, coloured by time.

    Parameters
    ----------
    grasp : Grasp or path-like
        A grasp, or a grasp JSON file.
    sampler : None or PathSampler or str or dict
        None (the ``"balanced"`` preset), a `PathSampler`, a preset name, a dict of
        `PathSampler.params`, its JSON text, or a JSON file holding it.
    n_paths : int
        How many of the sampler's paths to draw, spread evenly over them (1 .. its number of
        paths).
    path : path-like or None
        The self-contained HTML page to write (needs plotly); None writes none.
    png : path-like, optional
        Also write a static PNG picture (matplotlib).
    steps : int, optional
        Poses per path, replacing the sampler's ``n_steps``.
    title : str, optional
        Defaults to the grasp's name and what is drawn.
    open_browser : bool
        Open the HTML page in the default web browser.

    Returns
    -------
    Shown
        ``(html, png, scene)``: the files written and the geometry drawn.

    Raises
    ------
    SamplerError
        An unknown sampler or bad ``n_paths``/``steps``; the message names the argument.
    MissingDependencyError
        An HTML page was asked for and plotly is not installed.
    """
    if path is not None:
        plotly_go()
    scene = build_scene(grasp, sampler, n_paths=n_paths, steps=steps, title=title)
    html = write_html(scene, path) if path is not None else None
    picture = write_png(scene, png) if png is not None else None
    if open_browser and html is not None:
        import webbrowser

        webbrowser.open(html.resolve().as_uri())
    return Shown(html, picture, scene)
