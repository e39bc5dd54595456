"""Whole-pose culling of the exact backend: which poses have volume exactly 0 without running
the kernel (every shell of both meshes outside the other, their surfaces apart).

See "Culling rules" in ``docs/exact-backend.md``: culling never changes a bit of a result. The
BVH queries are `geometry.bvh.MeshPair`'s, built only where `worth_building` says so.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from exactgrasp.backends import defaults
from exactgrasp.backends.exact._entries import surfaces_cross
from exactgrasp.backends.exact.tables import CellGrid, MeshTables
from exactgrasp.geometry.winding import winding_number


def shell_labels(V: np.ndarray, E: np.ndarray) -> tuple[np.ndarray, int]:
    """Connected shell of each vertex of a mesh with edges E (e, 2): (labels (n,) int64,
    number of shells)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(V)
    graph = coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    return labels.astype(np.int64), int(count)


def bounding_sphere(V: np.ndarray) -> tuple[np.ndarray, float]:
    """A sphere holding every vertex of V (n, 3): the centre of their bounding box (3,) and
    the largest distance to it."""
    centre = 0.5 * (V.min(axis=0) + V.max(axis=0))
    return centre, float(np.sqrt(((V - centre) ** 2).sum(axis=1).max()))


def bounds_apart(
    poses: np.ndarray,
    box: tuple[np.ndarray, np.ndarray],
    sphere: tuple[np.ndarray, float],
    gap: float,
) -> np.ndarray:
    """Which poses move a sphere farther than ``gap`` from a box: the solids they hold are
    then apart, and their intersection's volume exactly 0.

    Parameters
    ----------
    poses : numpy.ndarray, shape (k, 4, 4)
        Rigid motions of the sphere's mesh, in the box's frame.
    box : (numpy.ndarray (3,), numpy.ndarray (3,))
        Lower and upper corners of the fixed mesh's bounding box.
    sphere : (numpy.ndarray (3,), float)
        `bounding_sphere` of the moving mesh, in its own frame.
    gap : float
        Covers the rounding of the moved centre and of the distance (`tolerances.CULL_GAP`
        times the coordinates' scale).

    Returns
    -------
    numpy.ndarray, shape (k,), bool
    """
    lower, upper = box
    centre, radius = sphere
    moved = poses[:, :3, :3] @ centre + poses[:, :3, 3]
    outside = np.maximum(np.maximum(lower - moved, moved - upper), 0.0)
    return np.sqrt((outside**2).sum(axis=1)) > radius + gap


def shell_samples(shells: tuple[np.ndarray, int], per_shell: int = 8) -> np.ndarray:
    """Indices of up to ``per_shell`` vertices of each shell, spread over its vertices, shell
    by shell: where two surfaces are apart, each vertex of a shell tells where the whole
    shell lies, so `culled_poses` moves and looks up these instead of every vertex.

    Parameters
    ----------
    shells : (numpy.ndarray (n,) int64, int)
        Shell of each vertex and the number of shells (`shell_labels`).
    per_shell : int

    Returns
    -------
    numpy.ndarray, shape (k,), int64
    """
    label, _ = shells
    order = np.argsort(label, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(label[order]) != 0])
    ends = np.r_[starts[1:], len(order)]
    picks = [
        order[np.linspace(a, b - 1, min(per_shell, b - a)).astype(np.int64)]
        for a, b in zip(starts, ends, strict=True)
    ]
    return np.concatenate(picks)


def shells_outside(
    X: np.ndarray, shells: tuple[np.ndarray, int], grid: CellGrid, V: np.ndarray, F: np.ndarray
) -> np.ndarray:
    """Whether every shell of a mesh lies outside another closed mesh, their surfaces apart,
    at each of several poses.

    Parameters
    ----------
    X : numpy.ndarray, shape (k, n, 3)
        Vertices of the mesh in the other mesh's frame, at each of k poses: all of them, or at
        least one of each shell (`shell_samples`).
    shells : (numpy.ndarray (n,) int64, int)
        Shell of each of those vertices and the number of shells (`shell_labels`).
    grid : tables.CellGrid
        The other mesh's cell grid.
    V, F : numpy.ndarray
        The other mesh, for a winding number where no vertex of a shell has a known status.

    Returns
    -------
    numpy.ndarray, shape (k,), bool
    """
    lo, h, n, status = grid.corner, grid.cell, grid.shape, grid.status
    ijk = np.floor((X - lo) * (1.0 / h)).astype(np.int64)
    off = np.any((ijk < 0) | (ijk >= n), axis=2)
    ijk = np.clip(ijk, 0, n - 1)
    st = np.where(off, 0, status[(ijk[..., 0] * n[1] + ijk[..., 1]) * n[2] + ijk[..., 2]])
    label, count = shells
    out = ~np.any(st == 1, axis=1)
    known = np.zeros((len(X), count), bool)
    pose, vertex = np.nonzero(st == 0)
    known[pose, label[vertex]] = True
    first = np.argmax(label[None, :] == np.arange(count)[:, None], axis=1)
    for k in np.flatnonzero(out & ~known.all(axis=1)):
        for shell in np.flatnonzero(~known[k]):
            if round(winding_number(np.ascontiguousarray(X[k, first[shell]]), V, F)) & 1:
                out[k] = False
                break
    return out


def crossing_poses(
    poses: np.ndarray,
    hand_mesh: MeshTables,
    hand_grid: CellGrid,
    object_mesh: MeshTables,
    object_grid: CellGrid,
    shells: tuple[tuple[np.ndarray, int], tuple[np.ndarray, int]],
) -> np.ndarray:
    """Which poses (k, 4, 4; local coordinates) certainly have crossing surfaces (the kernel's
    cheap test, `_entries.surfaces_cross`): the broad phase is never asked about them. Returns
    a bool mask (k,)."""
    return surfaces_cross(
        poses, hand_mesh.vertices, *shells[0], hand_grid, object_mesh.vertices, *shells[1],
        object_grid,
    )  # fmt: skip


def worth_building(open_poses: int, triangles: int) -> bool:
    """Whether BVHs over ``triangles`` triangles (both meshes) are worth building for
    ``open_poses`` poses that `crossing_poses` leaves open: at least one such pose, and at
    least ``triangles / defaults.EXACT_CULL_TRIANGLES_PER_POSE`` of them."""
    return open_poses > 0 and open_poses * defaults.EXACT_CULL_TRIANGLES_PER_POSE >= triangles


def culled_poses(
    poses: np.ndarray,
    cull: Any,
    hand_mesh: MeshTables,
    hand_grid: CellGrid,
    object_mesh: MeshTables,
    object_grid: CellGrid,
    shells: tuple[tuple[np.ndarray, int], tuple[np.ndarray, int]],
    samples: tuple[np.ndarray, np.ndarray],
    crossing: np.ndarray | None = None,
) -> np.ndarray:
    """Which poses (k, 4, 4; local coordinates) have volume exactly 0 for certain.

    A pose is culled when the BVH pair ``cull`` (`geometry.bvh.MeshPair`) finds the surfaces
    farther apart than its gap and every shell of each mesh (``shells``: hand's, object's, as
    from `shell_labels`) lies outside the other (`shells_outside`). Surfaces apart, each shell
    lies wholly inside or wholly outside the other mesh, so one vertex of known status decides
    it; a shell with none gets a winding number. ``samples`` are the vertices looked up, hand's
    and object's (`shell_samples` of ``shells``). ``crossing`` is `crossing_poses` of the poses
    when the caller has it. Returns a bool mask (k,).
    """
    out = np.zeros(len(poses), bool)
    AV, AF = hand_mesh.vertices, hand_mesh.faces
    BV, BF = object_mesh.vertices, object_mesh.faces
    hand_pick, object_pick = samples
    hand_shells = (shells[0][0][hand_pick], shells[0][1])
    object_shells = (shells[1][0][object_pick], shells[1][1])
    # The BVH query costs more than the kernel where the surfaces plainly cross; ask it only
    # about the other poses.
    if crossing is None:
        crossing = crossing_poses(poses, hand_mesh, hand_grid, object_mesh, object_grid, shells)
    # Only poses whose volume is exactly 0 are culled: a shell inside the other mesh is left to
    # the kernel, so culling cannot change a single bit of any result.
    candidates = np.flatnonzero(~crossing)
    far = candidates[[cull.far(poses[i]) for i in candidates]]
    if len(far):
        R, t = poses[far, :3, :3], poses[far, :3, 3]
        moved_object = np.einsum("kij,mj->kmi", R, BV[object_pick]) + t[:, None, :]
        hand_in_object = np.einsum("kji,kmj->kmi", R, AV[hand_pick][None] - t[:, None, :])
        out[far] = shells_outside(moved_object, object_shells, hand_grid, AV, AF) & (
            shells_outside(hand_in_object, hand_shells, object_grid, BV, BF)
        )
    return out
