"""Geometry set-up of the exact backend: manifold3d solids, mesh topology and cell grids."""

from __future__ import annotations

import numpy as np

from exactgrasp.backends._exact_kernels import raster_triangles, winding_number
from exactgrasp.errors import MeshError

_REPAIR_HINT = (
    "the exact backend needs closed, consistently oriented surfaces; load the mesh with "
    "repair=True (or fix it in a mesh editor) and try again."
)


def to_manifold(V: np.ndarray, F: np.ndarray, what: str):
    """A manifold3d solid from a (V, F) pair, or a `MeshError` naming `what`.

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3), float64
        Vertex coordinates.
    F : numpy.ndarray, shape (m, 3), int
        Outward-oriented triangles.
    what : str
        Name of the mesh for the error message (``"hand link 3"``).
    """
    import manifold3d as m3

    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise MeshError(
            f"{what}: expected vertices (n, 3) and faces (m, 3), got "
            f"{V.shape} and {F.shape}; pass a non-empty triangle mesh."
        )
    if not np.all(np.isfinite(V)):
        raise MeshError(f"{what}: vertex coordinates contain NaN or infinity; {_REPAIR_HINT}")
    if F.min() < 0 or F.max() >= len(V):
        raise MeshError(f"{what}: face indices out of range; {_REPAIR_HINT}")
    solid = m3.Manifold(
        m3.Mesh64(vert_properties=V, tri_verts=np.ascontiguousarray(F, dtype=np.uint64))
    )
    status = solid.status()
    if status != m3.Error.NoError or solid.is_empty():
        raise MeshError(f"{what} is not a closed manifold surface ({status.name}); {_REPAIR_HINT}")
    if solid.volume() <= 0:
        raise MeshError(f"{what} has non-positive volume (faces inward?); {_REPAIR_HINT}")
    return solid


def union(solids: list):
    """Union of manifold3d solids (overlaps counted once)."""
    import manifold3d as m3

    if len(solids) == 1:
        return solids[0]
    return m3.Manifold.batch_boolean(solids, m3.OpType.Add)


def mesh_arrays(solid) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) float64 and faces (m, 3) int64 of a manifold3d solid."""
    mesh = solid.to_mesh64()
    V = np.ascontiguousarray(np.asarray(mesh.vert_properties)[:, :3], dtype=np.float64)
    F = np.ascontiguousarray(np.asarray(mesh.tri_verts), dtype=np.int64)
    return V, F


def prepare_mesh(V: np.ndarray, F: np.ndarray) -> tuple:
    """Edge topology of a closed, oriented mesh, as the tuple the kernels read.

    Returns
    -------
    tuple
        ``(V, F, E, ET, TE, TO, adj_start, adj_vert, adj_edge)``; see `_exact_pose`.
    """
    m = len(F)
    src = F.reshape(-1)
    dst = F[:, [1, 2, 0]].reshape(-1)
    face = np.repeat(np.arange(m), 3)
    lo, hi = np.minimum(src, dst), np.maximum(src, dst)
    key = lo * (len(V) + 1) + hi
    uniq, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    forward = src < dst
    if np.any(counts != 2) or np.bincount(inv, weights=forward, minlength=len(uniq)).min() != 1:
        raise MeshError(f"mesh is not a closed, oriented 2-manifold after merging; {_REPAIR_HINT}")
    ne = len(uniq)
    E = np.empty((ne, 2), np.int64)
    E[inv, 0] = lo
    E[inv, 1] = hi
    ET = np.empty((ne, 2), np.int64)
    ET[inv[forward], 0] = face[forward]
    ET[inv[~forward], 1] = face[~forward]
    TE = inv.reshape(m, 3).astype(np.int64)
    TO = forward.reshape(m, 3)
    # Vertex adjacency in CSR form, one entry per (vertex, incident edge).
    ends = np.concatenate([E[:, 0], E[:, 1]])
    other = np.concatenate([E[:, 1], E[:, 0]])
    eid = np.concatenate([np.arange(ne), np.arange(ne)])
    order = np.argsort(ends, kind="stable")
    adj_start = np.zeros(len(V) + 1, np.int64)
    np.cumsum(np.bincount(ends, minlength=len(V)), out=adj_start[1:])
    return (V, F, E, ET, TE, TO, adj_start, other[order].copy(), eid[order].copy())


def grid_frame(V: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Origin (3,) and cell counts (3,) of the grid `build_grid` lays over vertices V (n, 3)
    with cubic cells of edge ``cell``: one cell of padding on every side."""
    lo = V.min(0) - cell
    return lo, np.ceil((V.max(0) + cell - lo) / cell).astype(np.int64) + 1


def vertex_cells(V: np.ndarray, cell: float) -> np.ndarray:
    """Flat index of the `build_grid` cell holding each vertex of V (n, 3): shape (n,), int64.
    (`_exact_kernels.cell_index` multiplies by 1 / cell instead, so a vertex within rounding of
    a cell boundary may get the neighbouring cell there; both cells, grown by the grid's
    margin, hold it.)"""
    lo, n = grid_frame(V, cell)
    ijk = np.clip(np.floor((V - lo) / cell).astype(np.int64), 0, n - 1)
    return (ijk[:, 0] * n[1] + ijk[:, 1]) * n[2] + ijk[:, 2]


def cell_order(V: np.ndarray, F: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """The same mesh with its vertices renumbered in the order of their `build_grid` cells
    (stable), so that each cell's vertices are consecutive: (V (n, 3), F (m, 3))."""
    order = np.argsort(vertex_cells(V, cell), kind="stable")
    rank = np.empty(len(V), np.int64)
    rank[order] = np.arange(len(V))
    return np.ascontiguousarray(V[order]), np.ascontiguousarray(rank[F])


def build_grid(V: np.ndarray, F: np.ndarray, cell: float) -> tuple:
    """A cubic-cell grid over a closed mesh, one cell of padding on every side.

    Parameters
    ----------
    V, F : numpy.ndarray
        The mesh, shapes (n, 3) and (m, 3).
    cell : float
        Edge length of a cell, in the mesh's units.

    Returns
    -------
    tuple
        ``(lo, h, n, status, cell_start, cell_tris, table)``: origin (3,), cell size, counts
        (3,), status per flat cell (1 inside, 0 outside, -1 touched by the surface), the faces
        touching each cell in CSR form, and the summed-volume table ((n + 1) cells per axis,
        flat) of the surface cells (see `_exact_kernels.surface_cells_in`).
    """
    from scipy import ndimage

    lo, n = grid_frame(V, cell)
    margin = 1e-9 * cell
    cells, tris = raster_triangles(V, F, lo, float(cell), n, margin)
    ncell = int(np.prod(n))
    cell_start = np.zeros(ncell + 1, np.int64)
    np.cumsum(np.bincount(cells, minlength=ncell), out=cell_start[1:])
    surface = np.zeros(ncell, bool)
    surface[cells] = True
    labels, nlab = ndimage.label(~surface.reshape(tuple(n)))
    status = np.full(ncell, -1, np.int64)
    flat = labels.reshape(-1)
    outside = set(
        np.unique(
            np.concatenate(
                [
                    labels[0].ravel(),
                    labels[-1].ravel(),
                    labels[:, 0].ravel(),
                    labels[:, -1].ravel(),
                    labels[:, :, 0].ravel(),
                    labels[:, :, -1].ravel(),
                ]
            )
        ).tolist()
    ) - {0}
    for lab in range(1, nlab + 1):
        idx = np.flatnonzero(flat == lab)
        if lab in outside:
            inside = 0
        else:
            i, j, k = np.unravel_index(idx[0], tuple(n))
            centre = lo + (np.array([i, j, k]) + 0.5) * cell
            inside = round(winding_number(centre, V, F)) & 1
        status[idx] = inside
    # Summed-volume table of the surface cells: how many a box of cells holds, in 8 reads.
    table = np.zeros(tuple(n + 1), np.int64)
    table[1:, 1:, 1:] = surface.reshape(tuple(n)).cumsum(0).cumsum(1).cumsum(2)
    return (lo, float(cell), n, status, cell_start, tris, table.reshape(-1))
