"""The geometry of a grasp picture: posed hand links, the object, the frame axes, sampled paths.

Everything is in the hand's canonical frame (see `exactgrasp.hands.frame`), where the sampler's
paths live: one unit is half the palm-to-fingertip depth, the distance a translation path
travels by ``t = 1``. The renderers (`exactgrasp.view.html`, `exactgrasp.view.png`) only draw
what `build_scene` returns.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

from exactgrasp.errors import Fix, SamplerError
from exactgrasp.geometry.se3 import exp_se3
from exactgrasp.grasp.grasp import Grasp
from exactgrasp.paths.presets import as_sampler
from exactgrasp.paths.sampler import PathSampler

#: Trace name of the object (hand links keep their own names).
OBJECT_NAME = "object"
HAND_COLOR = "#8c9bb0"
OBJECT_COLOR = "#e8833a"
#: (trace name, label, colour) of the canonical axes x, y, z.
AXES = (("x axis", "x", "#d62728"), ("y axis", "y", "#2ca02c"), ("z axis", "z", "#1f5fd6"))
#: Points per unit time on the drawn path curves (the paths are exact, not interpolated).
CURVE_DENSITY = 32
#: Ghosted copies of the object drawn along a path that rotates it (at these fractions of the
#: last step time), and how many such paths get them.
GHOST_FRACTIONS = (1 / 3, 2 / 3, 1.0)
GHOST_PATHS = 1


@dataclass(frozen=True)
class MeshPart:
    """A closed triangle mesh to draw.

    Attributes
    ----------
    name : str
        Trace name: the link name, ``"object"``, or ``"object at t=0.55 on path 12"``.
    role : {"hand", "object", "ghost"}
        A ghost is a copy of the object moved along a path (drawn faint).
    vertices : numpy.ndarray, shape (n, 3)
        Canonical coordinates.
    faces : numpy.ndarray, shape (m, 3), int64
    color : str
        ``#rrggbb``.
    """

    name: str
    role: str
    vertices: np.ndarray
    faces: np.ndarray
    color: str


@dataclass(frozen=True)
class AxisPart:
    """One axis of the canonical frame: a segment from the origin, one unit long.

    Attributes
    ----------
    name : str
        Trace name (``"x axis"``).
    label : str
        Text at the tip (``"x"``).
    tip : numpy.ndarray, shape (3,)
        Canonical coordinates of the tip; the segment starts at the origin.
    color : str
    """

    name: str
    label: str
    tip: np.ndarray
    color: str


@dataclass(frozen=True)
class PathPart:
    """The object's centre along one sampled path.

    Attributes
    ----------
    name : str
        Trace name, ``"path <index> (<kind>)"``.
    index : int
        Index into the sampler's paths.
    kind : {"both", "translation", "rotation"}
    times : numpy.ndarray, shape (k,)
        Path times from 0 (the grasp) to the sampler's last step time.
    points : numpy.ndarray, shape (k, 3)
        Canonical position of the object's centre at each time.
    at_step : numpy.ndarray, shape (k,), bool
        True at the sampler's step times (the poses a descriptor is computed at).
    """

    name: str
    index: int
    kind: str
    times: np.ndarray
    points: np.ndarray
    at_step: np.ndarray


@dataclass(frozen=True)
class Scene:
    """Everything a grasp picture shows.

    Attributes
    ----------
    title : str
    meshes : list of MeshPart
        The hand links, then the object.
    axes : list of AxisPart
        x, y, z of the canonical frame.
    paths : list of PathPart
    t_max : float
        The sampler's last step time (the top of the colour scale).
    n_sampler_paths : int
        How many paths the sampler has (``len(paths)`` of them are drawn).
    mm_per_unit : float
        Millimetres per canonical unit (half the palm frame's depth), for axis titles.
    ghosts : list of MeshPart
        Copies of the object along the drawn path that rotates it most (role ``"ghost"``).
    """

    title: str
    meshes: list[MeshPart]
    axes: list[AxisPart]
    paths: list[PathPart]
    t_max: float
    n_sampler_paths: int
    mm_per_unit: float = 1000.0
    ghosts: list[MeshPart] = field(default_factory=list)

    @property
    def trace_names(self) -> list[str]:
        """Names of every drawn element, meshes, axes then paths."""
        return (
            [m.name for m in self.meshes]
            + [a.name for a in self.axes]
            + [p.name for p in self.paths]
        )

    def bounds(self) -> np.ndarray:
        """Axis-aligned box around every drawn point, shape (2, 3), canonical units."""
        points = [m.vertices for m in [*self.meshes, *self.ghosts]]
        points += [p.points for p in self.paths]
        points += [np.zeros((1, 3))] + [a.tip[None] for a in self.axes]
        stacked = np.concatenate(points)
        return np.array([stacked.min(axis=0), stacked.max(axis=0)])


def as_grasp(grasp: Grasp | str | os.PathLike, on_limit: str = "error") -> Grasp:
    """A `Grasp`, or the grasp read from a grasp JSON file.

    Parameters
    ----------
    grasp : Grasp or path-like
    on_limit : {"error", "clip"}
        For a file: joint values outside the limits raise or are clipped.

    Returns
    -------
    Grasp
    """
    if isinstance(grasp, Grasp):
        return grasp
    if isinstance(grasp, str | os.PathLike):
        return Grasp.from_file(grasp, on_limit=on_limit)
    raise TypeError(f"grasp must be a Grasp or a grasp file path, got {type(grasp).__name__}.")


def resolve_sampler(
    sampler: Any = None,
    steps: int | None = None,
    name: str = "sampler",
    steps_name: str = "steps",
) -> PathSampler:
    """The sampler to draw, from what `exactgrasp.paths.presets.as_sampler` accepts.

    Parameters
    ----------
    sampler : None or PathSampler or str or dict
        As `as_sampler` (a preset, parameters, their JSON text or a ``.json`` file).
    steps : int, optional
        Poses per path, replacing the sampler's ``n_steps``.
    name, steps_name : str
        How the arguments are called, for messages (``"--sampler"``, ``"--steps"`` on the
        command line).

    Returns
    -------
    PathSampler
    """
    try:
        return as_sampler(sampler, n_steps=steps)
    except TypeError as exc:
        raise SamplerError(f"{name}: {exc}") from exc
    except SamplerError as exc:
        # A message about the sampler names it already; any other is about it.
        prefix = () if exc.subject == "sampler" else (f"{name}: ",)
        raise exc.respelled(partial(_steps_terms, steps_name), *prefix) from exc


def _steps_terms(steps_name: str, fix: Fix) -> str:
    """A sampler's fix, ``n_steps`` called ``steps_name``."""
    return (fix.replace(parameter=steps_name) if fix.parameter == "n_steps" else fix).in_python()


def choose_paths(sampler: PathSampler, n_paths: int, name: str = "n_paths") -> np.ndarray:
    """Indices of ``n_paths`` paths spread evenly over the sampler's path order.

    The order runs over the directions' spiral, so the pick spreads over the sphere of
    directions and over the three kinds of path (both, translation only, rotation only).

    Parameters
    ----------
    sampler : PathSampler
    n_paths : int
        1 .. ``sampler.n_paths``.
    name : str
        How the argument is called, for messages (``"--paths"`` on the command line).

    Returns
    -------
    numpy.ndarray, shape (n_paths,), int
    """
    if isinstance(n_paths, bool) or not isinstance(n_paths, int | np.integer) or n_paths < 1:
        raise SamplerError(f"{name} must be a positive number of paths to draw, got {n_paths!r}.")
    if n_paths > sampler.n_paths:
        raise SamplerError(
            f"{name}={n_paths} is more than the sampler's {sampler.n_paths} paths; draw at most "
            f"{sampler.n_paths}."
        )
    return np.linspace(0, sampler.n_paths - 1, int(n_paths)).round().astype(np.int64)


def path_parts(sampler: PathSampler, indices: np.ndarray, centre: np.ndarray) -> list[PathPart]:
    """The object's centre along the chosen paths, from t = 0 to the last step time.

    A path's pose ``exp(t * twist)`` moves a canonical point ``x`` to ``R x + p``; the curve
    is evaluated at `CURVE_DENSITY` times per unit time plus the sampler's step times.

    Parameters
    ----------
    sampler : PathSampler
    indices : numpy.ndarray, shape (k,), int
    centre : numpy.ndarray, shape (3,)
        The object's centre at the grasp, canonical coordinates.

    Returns
    -------
    list of PathPart
    """
    t_max = float(sampler.times.max())
    dense = np.linspace(0.0, t_max, max(2, int(np.ceil(CURVE_DENSITY * t_max)) + 1))
    times = np.unique(np.concatenate([dense, sampler.times]))
    at_step = np.isin(times, sampler.times)
    table = sampler.paths
    parts = []
    for index in indices:
        poses = exp_se3(
            table.omega[index] * times[:, None], table.direction[index] * times[:, None]
        )
        points = poses[:, :3, :3] @ centre + poses[:, :3, 3]
        kind = str(table.kind[index])
        parts.append(
            PathPart(f"path {int(index)} ({kind})", int(index), kind, times, points, at_step)
        )
    return parts


def build_scene(
    grasp: Grasp | str | os.PathLike,
    sampler: Any = None,
    n_paths: int = 24,
    steps: int | None = None,
    title: str | None = None,
) -> Scene:
    """The geometry of a grasp picture, in the canonical frame.

    Parameters
    ----------
    grasp : Grasp or path-like
        A grasp, or a grasp JSON file.
    sampler : None or PathSampler or str or dict
        See `resolve_sampler`; None is the ``"balanced"`` preset.
    n_paths : int
        How many of the sampler's paths to draw, spread evenly (see `choose_paths`).
    steps : int, optional
        Poses per path, replacing the sampler's ``n_steps``.
    title : str, optional
        Defaults to the grasp's name and what is drawn.

    Returns
    -------
    Scene
    """
    grasp = as_grasp(grasp)
    sampler = resolve_sampler(sampler, steps)
    indices = choose_paths(sampler, n_paths)
    meshes = [
        MeshPart(name, "hand", vertices, faces, HAND_COLOR)
        for name, (vertices, faces) in zip(
            grasp.hand.link_names, grasp.canonical_hand_links(), strict=True
        )
    ]
    # One body holds every shell of the object (see Grasp.canonical_object_bodies).
    vertices, faces = grasp.canonical_object_bodies()[0]
    meshes.append(MeshPart(OBJECT_NAME, "object", vertices, faces, OBJECT_COLOR))
    to_canonical = grasp.frame.matrix @ grasp.object_pose
    centre = to_canonical[:3, :3] @ grasp.object.centroid + to_canonical[:3, 3]
    axes = [AxisPart(n, label, np.eye(3)[k], color) for k, (n, label, color) in enumerate(AXES)]
    if title is None:
        title = (
            f"{grasp.name or 'grasp'}: {len(indices)} of {sampler.n_paths} sampled paths of the "
            f"object's centre, {sampler.n_steps} steps each (canonical frame)"
        )
    return Scene(
        title=title,
        meshes=meshes,
        axes=axes,
        paths=path_parts(sampler, indices, centre),
        t_max=float(sampler.times.max()),
        n_sampler_paths=sampler.n_paths,
        mm_per_unit=1000.0 / grasp.frame.scale,
        ghosts=ghost_parts(sampler, indices, vertices, faces),
    )


def ghost_parts(
    sampler: PathSampler, indices: np.ndarray, vertices: np.ndarray, faces: np.ndarray
) -> list[MeshPart]:
    """Copies of the object along the `GHOST_PATHS` drawn paths that rotate it most, at
    `GHOST_FRACTIONS` of the last step time: the paths' centres alone do not show rotation.

    Parameters
    ----------
    sampler : PathSampler
    indices : numpy.ndarray, shape (k,), int
        The drawn paths.
    vertices : numpy.ndarray, shape (n, 3)
        The object at the grasp, canonical coordinates.
    faces : numpy.ndarray, shape (m, 3), int

    Returns
    -------
    list of MeshPart
        Role ``"ghost"``; none when no drawn path rotates the object.
    """
    table = sampler.paths
    amounts = np.abs(table.amount[indices])
    chosen = [int(indices[k]) for k in np.argsort(-amounts, kind="stable")[:GHOST_PATHS]]
    t_max = float(sampler.times.max())
    ghosts = []
    for index in chosen:
        if table.amount[index] == 0.0:
            continue
        for fraction in GHOST_FRACTIONS:
            t = fraction * t_max
            pose = exp_se3(table.omega[index] * t, table.direction[index] * t)
            moved = vertices @ pose[:3, :3].T + pose[:3, 3]
            name = f"object at t={t:.2f} on path {index}"
            ghosts.append(MeshPart(name, "ghost", moved, faces, OBJECT_COLOR))
    return ghosts
