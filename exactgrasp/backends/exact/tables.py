"""Geometry set-up of the exact backend: manifold3d solids, mesh topology and cell grids."""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.kernels import raster_triangles
from exactgrasp.errors import MeshError

# The manifold3d adapter is `exactgrasp.geometry.manifold`; its names are re-exported here.
from exactgrasp.geometry.manifold import mesh_arrays as mesh_arrays
from exactgrasp.geometry.manifold import to_manifold as to_manifold
from exactgrasp.geometry.manifold import union_solids as union  # noqa: F401
from exactgrasp.geometry.winding import winding_number

_REPAIR_HINT = (
    "the exact backend needs closed, consistently oriented surfaces; load the mesh with "
    "repair=True (or fix it in a mesh editor) and try again."
)


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


def face_conditioning(V: np.ndarray, F: np.ndarray, N: np.ndarray) -> tuple:
    """Per face, ``|b - a| |c - a|`` and the conditioning ``kappa = |b - a| |c - a| / |N|``
    (infinite where the computed normal N is zero): the direction error of a unit normal
    from a cross product is about ``7 U kappa`` (see `_exact_kernels.PLANE_ERR`).

    Parameters
    ----------
    V, F : numpy.ndarray
        The mesh, shapes (n, 3) and (m, 3).
    N : numpy.ndarray, shape (m, 3)
        The faces' computed (unnormalised) normals ``(b - a) × (c - a)``.

    Returns
    -------
    (l1l2 (m,), kappa (m,)) : tuple of numpy.ndarray
    """
    a = V[F[:, 0]]
    l1l2 = np.linalg.norm(V[F[:, 1]] - a, axis=1) * np.linalg.norm(V[F[:, 2]] - a, axis=1)
    norm = np.linalg.norm(N, axis=1)
    kappa = np.divide(l1l2, norm, out=np.full(len(F), np.inf), where=norm > 0)
    return l1l2, kappa


def face_d_coefs(l1l2: np.ndarray, kappa: np.ndarray) -> np.ndarray:
    """`_exact_kernels.face_d_coef` for every face: what a face's rounded ``D`` can cost its
    terms, divided by the coordinate bound; shape (m,)."""
    from exactgrasp.backends.exact.kernels import FACE_D_ERR, FACE_D_ERR_NONE, KAPPA_MAX, U

    return np.where(kappa <= KAPPA_MAX, FACE_D_ERR, FACE_D_ERR_NONE) * U * l1l2


def hand_tables(V: np.ndarray, F: np.ndarray, E: np.ndarray, ET: np.ndarray, tiny: float):
    """The hand's per-face and per-edge terms, with error bounds (see `_exact_pose`).

    ``D_t`` and the edge weights ``W_e`` are computed in extended precision (``longdouble``;
    80-bit on x86-64) once, so the fixed hand's weights carry almost no rounding.

    Parameters
    ----------
    V, F : numpy.ndarray
        The hand mesh in local coordinates, shapes (n, 3) and (m, 3).
    E, ET : numpy.ndarray
        Its edges and their faces (`prepare_mesh`).
    tiny : float
        Faces with ``|N|² <= tiny`` get ``D = 0`` (as `_exact_kernels.face_terms`).

    Returns
    -------
    AD : (m, 3) ``D_t`` rounded to double.
    AN : (m, 3) the normals ``(b - a) × (c - a)`` in double (as the kernels compute them).
    AP : (m, 6) unit normal, plane offset, `_exact_kernels.plane_err_coef` of the face's
        conditioning, and what its rounded ``D`` can cost (absolute, `face_d_coef` times the
        hand's coordinate bound).
    AW : (e, 2) ``W_e`` and a bound on its error (rounding to double, the extended-precision
        evaluation, a third of each face's ``D`` cost).
    WL : (e,) ``W_e`` in extended precision (for the parts' sums).
    """
    from exactgrasp.backends.exact.kernels import (
        KAPPA_MAX,
        PLANE_ERR,
        PLANE_ERR_NONE,
        TERM_ERR,
        U,
        face_terms,
    )

    m = len(F)
    AD = np.zeros((m, 3))
    AN = np.zeros((m, 3))
    face_terms(V, F, tiny, AD, AN)
    L = V.astype(np.longdouble)
    a = L[F[:, 0]]
    NL = np.cross(L[F[:, 1]] - a, L[F[:, 2]] - a)
    nn = np.einsum("ij,ij->i", NL, NL)
    good = nn > tiny
    s = np.zeros(m, np.longdouble)
    s[good] = np.einsum("ij,ij->i", NL[good], a[good]) / nn[good]
    DL = s[:, None] * NL
    AD = np.ascontiguousarray(DL.astype(np.float64))
    norm = np.linalg.norm(AN, axis=1)
    unit = np.divide(AN, norm[:, None], out=np.zeros_like(AN), where=norm[:, None] > 0)
    l1l2, kappa = face_conditioning(V, F, AN)
    coef = np.where(kappa <= KAPPA_MAX, PLANE_ERR * U * (1.0 + kappa), PLANE_ERR_NONE)
    g = max(float(np.sqrt((V**2).sum(1)).max()) * (1.0 + 1e-12), 1e-300)
    dcost = face_d_coefs(l1l2, kappa) * g
    AP = np.ascontiguousarray(
        np.column_stack([unit, np.einsum("ij,ij->i", unit, V[F[:, 0]]), coef, dcost])
    )
    WL = np.einsum("ij,ij->i", DL[ET[:, 0]] - DL[ET[:, 1]], np.cross(L[E[:, 0]], L[E[:, 1]])) / 6
    W = WL.astype(np.float64)
    uL = float(np.finfo(np.longdouble).eps) / 2
    dn = np.abs(AD[ET[:, 0]]).sum(1) + np.abs(AD[ET[:, 1]]).sum(1)
    uv = np.abs(V[E[:, 0]]).max(1) * np.abs(V[E[:, 1]]).max(1)
    err = U * np.abs(W) + TERM_ERR * uL * dn * uv + (dcost[ET[:, 0]] + dcost[ET[:, 1]]) / 3
    return AD, AN, AP, np.ascontiguousarray(np.column_stack([W, err])), WL


def part_sums(epart: np.ndarray, AW: np.ndarray, WL: np.ndarray, nparts: int) -> np.ndarray:
    """Per hand part, the summed weight of its own edges (extended precision, rounded once)
    and a bound on its error: shape (parts, 2). ``epart`` is each edge's part (-1 between
    parts), ``AW`` and ``WL`` as from `hand_tables`."""
    from exactgrasp.backends.exact.kernels import U

    own = epart >= 0
    total = np.zeros(nparts, np.longdouble)
    np.add.at(total, epart[own], WL[own])
    absw = np.bincount(epart[own], weights=np.abs(AW[own, 0]), minlength=nparts)
    count = np.bincount(epart[own], minlength=nparts)
    uL = float(np.finfo(np.longdouble).eps) / 2
    wsum = total.astype(np.float64)
    err = np.bincount(epart[own], weights=AW[own, 1], minlength=nparts).astype(np.float64)
    err += U * np.abs(wsum) + 2.0 * count * uL * absw
    return np.ascontiguousarray(np.column_stack([wsum, err]))
