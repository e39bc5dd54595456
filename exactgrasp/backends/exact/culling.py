"""Whole-pose culling of the exact backend: which poses have volume exactly 0 without running
the kernel (every shell of both meshes outside the other, their surfaces apart).

See "Culling rules" in ``docs/exact-backend.md``: culling never changes a bit of a result. The
BVH queries are `geometry.bvh.MeshPair`'s, built only where `worth_building` says so.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from exactgrasp.backends import defaults
from exactgrasp.backends.exact.classify import surfaces_cross
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


def shells_outside(
    X: np.ndarray, shells: tuple[np.ndarray, int], grid: CellGrid, V: np.ndarray, F: np.ndarray
) -> bool:
    """Whether every shell of a mesh lies outside another closed mesh, their surfaces apart.

    Parameters
    ----------
    X : numpy.ndarray, shape (n, 3)
        The mesh's vertices in the other mesh's frame.
    shells : (numpy.ndarray (n,) int64, int)
        Shell of each vertex and the number of shells (`shell_labels`).
    grid : tables.CellGrid
        The other mesh's cell grid.
    V, F : numpy.ndarray
        The other mesh, for a winding number where no vertex of a shell has a known status.
    """
    lo, h, n, status = grid.corner, grid.cell, grid.shape, grid.status
    ijk = np.floor((X - lo) * (1.0 / h)).astype(np.int64)
    off = np.any((ijk < 0) | (ijk >= n), axis=1)
    i, j, k = np.clip(ijk, 0, n - 1).T
    st = np.where(off, 0, status[(i * n[1] + j) * n[2] + k])
    label, count = shells
    if np.any(st == 1):
        return False
    known = np.zeros(count, bool)
    known[label[st == 0]] = True
    for shell in np.flatnonzero(~known):
        x = np.ascontiguousarray(X[np.argmax(label == shell)])
        if round(winding_number(x, V, F)) & 1:
            return False
    return True


def crossing_poses(
    poses: np.ndarray,
    hand_mesh: MeshTables,
    hand_grid: CellGrid,
    object_mesh: MeshTables,
    object_grid: CellGrid,
    shells: tuple[tuple[np.ndarray, int], tuple[np.ndarray, int]],
) -> np.ndarray:
    """Which poses (k, 4, 4; local coordinates) certainly have crossing surfaces (the kernel's
    cheap test, `classify.surfaces_cross`): the broad phase is never asked about them. Returns
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
    crossing: np.ndarray | None = None,
) -> np.ndarray:
    """Which poses (k, 4, 4; local coordinates) have volume exactly 0 for certain.

    A pose is culled when the BVH pair ``cull`` (`geometry.bvh.MeshPair`) finds the surfaces
    farther apart than its gap and every shell of each mesh (``shells``: hand's, object's, as
    from `shell_labels`) lies outside the other (`shells_outside`). Surfaces apart, each shell
    lies wholly inside or wholly outside the other mesh, so one vertex of known status decides
    it; a shell with none gets a winding number. ``crossing`` is `crossing_poses` of the poses
    when the caller has it. Returns a bool mask (k,).
    """
    out = np.zeros(len(poses), bool)
    AV, AF = hand_mesh.vertices, hand_mesh.faces
    BV, BF = object_mesh.vertices, object_mesh.faces
    # The BVH query costs more than the kernel where the surfaces plainly cross; ask it only
    # about the other poses.
    if crossing is None:
        crossing = crossing_poses(poses, hand_mesh, hand_grid, object_mesh, object_grid, shells)
    # Only poses whose volume is exactly 0 are culled: a shell inside the other mesh is left to
    # the kernel, so culling cannot change a single bit of any result.
    for i in np.flatnonzero(~crossing):
        p = poses[i]
        if not cull.far(p):
            continue
        R, t = p[:3, :3], p[:3, 3]
        moved_object = BV @ R.T + t
        hand_in_object = (AV - t) @ R
        out[i] = shells_outside(moved_object, shells[1], hand_grid, AV, AF) and shells_outside(
            hand_in_object, shells[0], object_grid, BV, BF
        )
    return out
