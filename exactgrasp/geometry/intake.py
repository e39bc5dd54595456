"""Reading meshes and points into the library: units, file loading, sample points.

What `exactgrasp.geometry.solid.Solid` uses to take meshes in. trimesh loads on first read:
the command line takes `UNITS` from here for its help.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from exactgrasp.errors import Fix, MeshError

if TYPE_CHECKING:
    import trimesh

__all__ = [
    "MAX_PLAUSIBLE_SIZE_M",
    "ORIENTATIONS",
    "REPAIR",
    "UNITS",
    "load_points",
    "load_trimesh",
    "unit_scale",
]

#: Length of one unit in metres.
UNITS: dict[str, float] = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    "in": 0.0254,
}

#: A grasped object or a hand longer than this (in metres) was almost surely read in the
#: wrong unit (millimetres read as metres is a factor 1000).
MAX_PLAUSIBLE_SIZE_M = 5.0

ORIENTATIONS = ("flip", "refuse")

#: Whether a mesh is repaired (closed and oriented by trimesh and pymeshfix, with a warning)
#: when nobody says: the one default of every ``repair`` option (solids, hands, hand models,
#: grasp files' ``object_repair`` and ``hand.repair``, `exactgrasp.overlap`).
REPAIR = False


def unit_scale(units: str) -> float:
    """Metres per unit.

    Parameters
    ----------
    units : {"m", "cm", "mm", "inch"}

    Returns
    -------
    float
    """
    try:
        return UNITS[units]
    except KeyError:
        raise MeshError(
            Fix("units", units), f" is not known; use one of {sorted(set(UNITS) - {'in'})}."
        ) from None


def load_trimesh(path: Path) -> trimesh.Trimesh:
    import trimesh

    if not path.exists():
        raise MeshError(
            f"{path}: no such file; check the path (relative paths are resolved "
            f"from {Path.cwd()})."
        )
    if path.is_file() and path.stat().st_size == 0:
        _refuse_empty(path)
    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:
        raise MeshError(
            f"{path}: trimesh could not read it ({type(exc).__name__}: {exc}); "
            "use a mesh format trimesh reads (STL, OBJ, PLY, OFF, GLB)."
        ) from exc
    if not isinstance(loaded, trimesh.Trimesh):
        raise MeshError(f"{path}: holds no triangle mesh (read as {type(loaded).__name__}).")
    if len(loaded.faces) == 0:
        _refuse_points_only(path)
    return loaded


def _refuse_empty(path: Path) -> None:
    """Refuse a file that holds nothing (no bytes, or a header and no triangles)."""
    raise MeshError(
        f"{path}: holds no triangles and no points ({path.stat().st_size:,} bytes): an empty "
        "or cut-short file; a solid needs a closed triangle surface. Export the mesh again "
        "(STL, OBJ, PLY, OFF or GLB) and check that the file is complete."
    )


def _refuse_points_only(path: Path) -> None:
    """Refuse a file with no faces, naming its points when it holds a point cloud (trimesh's
    ``force="mesh"`` reads one as an empty mesh)."""
    import trimesh

    try:
        points = len(getattr(trimesh.load(path, process=False), "vertices", ()))
    except Exception:  # the message then says what is known: no faces
        points = 0
    if not points:
        _refuse_empty(path)
    raise MeshError(
        f"{path}: holds a point cloud of {points:,} points and no faces; a solid needs a "
        "closed triangle surface. Give the object's mesh file instead; surface samples like "
        'these go with it as `surface_samples` (the grasp file\'s "object_surface_samples").'
    )


def load_points(source: Any, units: str = "m", name: str = "surface_samples") -> np.ndarray:
    """Read surface sample points from a file (PLY, XYZ, ...) or an array.

    Parameters
    ----------
    source : path or array_like, shape (k, 3)
    units : str
        Unit of the points; they are returned in metres.
    name : str
        Used in messages.

    Returns
    -------
    numpy.ndarray, shape (k, 3), float64, metres
    """
    if isinstance(source, str | os.PathLike):
        path = Path(source)
        if not path.exists():
            raise MeshError(f"{name}: {path}: no such file; check the path.")
        import trimesh

        loaded = trimesh.load(path, process=False)
        points = np.asarray(getattr(loaded, "vertices", loaded), dtype=np.float64)
        name = str(path)
    else:
        points = np.asarray(source, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0:
        raise MeshError(f"{name}: expected (k, 3) points with k >= 1, got shape {points.shape}.")
    if not np.all(np.isfinite(points)):
        raise MeshError(f"{name}: points contain NaN or infinite coordinates; remove them.")
    return points * unit_scale(units)
