"""Small mesh operations shared by hands, backends and reports (manifold3d, double precision)."""

from __future__ import annotations

from collections.abc import Sequence

import manifold3d
import numpy as np

from exactgrasp.errors import MeshError

MeshArrays = tuple[np.ndarray, np.ndarray]


def to_manifold(
    vertices: np.ndarray, faces: np.ndarray, name: str = "mesh"
) -> manifold3d.Manifold:
    """A manifold3d solid from arrays, in double precision (``Mesh64``).

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float
    faces : numpy.ndarray, shape (m, 3), int
    name : str
        Used in the error message.

    Returns
    -------
    manifold3d.Manifold
    """
    mesh = manifold3d.Mesh64(
        vert_properties=np.array(vertices, dtype=np.float64, order="C"),
        tri_verts=np.array(faces, dtype=np.uint64, order="C"),
    )
    solid = manifold3d.Manifold(mesh)
    status = solid.status()
    if status != manifold3d.Error.NoError:
        raise MeshError(
            f"{name}: manifold3d refuses it as a solid ({status.name}); it must be a closed, "
            "consistently oriented surface: pass repair=True when loading it."
        )
    return solid


def union(parts: Sequence[MeshArrays], name: str = "hand") -> manifold3d.Manifold:
    """Union of closed parts that may overlap.

    Parameters
    ----------
    parts : sequence of (vertices (n, 3), faces (m, 3))

    Returns
    -------
    manifold3d.Manifold
    """
    solids = [to_manifold(v, f, f"{name} part {i}") for i, (v, f) in enumerate(parts)]
    if len(solids) == 1:
        return solids[0]
    return manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add)


def union_volume(parts: Sequence[MeshArrays], name: str = "hand") -> float:
    """Volume of the union of closed parts (overlaps counted once), in cubed input units."""
    return float(union(parts, name).volume())


def manifold_arrays(solid: manifold3d.Manifold) -> MeshArrays:
    """Vertices (n, 3) float64 and faces (m, 3) int64 of a manifold3d solid."""
    mesh = solid.to_mesh64()
    vertices = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    return np.ascontiguousarray(vertices), np.asarray(mesh.tri_verts, dtype=np.int64)
