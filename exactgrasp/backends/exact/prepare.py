"""Once-per-grasp tables of the exact backend: the local frame they are built in (the centre
of the hand's bounds, `bounds_centre`), mesh topology, the hand's face, edge and part terms with
their error bounds, and the object's pose-independent terms.

See "Method, once per grasp" and "The volume's bound" in ``docs/exact-backend.md``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from exactgrasp.backends.exact._entries import face_terms
from exactgrasp.backends.exact.grids import cell_reps, morton_order, part_order
from exactgrasp.backends.exact.tables import (
    CHUNK,
    COTREE_BLOCK,
    COTREE_CHUNK,
    FACE_ACROSS,
    FACE_CORNERS,
    FACE_D,
    FACE_EDGES,
    FACE_ERR_COEF,
    FACE_LINKS_COLUMNS,
    FACE_OWNS,
    FACE_RECORD_COLUMNS,
    FACE_VERTICES,
    FILTER_COLUMNS,
    FILTER_NORMAL,
    FILTER_OFFSET,
    FILTER_SIDE_COLUMNS,
    FILTER_SIDE_OFFSET,
    FILTER_SIDES,
    PLANE_COLUMNS,
    CellGrid,
    HandTables,
    MeshTables,
    ObjectTables,
)
from exactgrasp.backends.exact.tolerances import (
    FACE_D_ERR,
    FACE_D_ERR_NONE,
    KAPPA_MAX,
    LENGTH_FLOOR,
    PLANE_ERR,
    PLANE_ERR_NONE,
    RADIUS_PAD,
    ROUNDING_PAD,
    TERM_ERR,
    U_EXTENDED,
    U,
)
from exactgrasp.errors import BackendError, Fix, MeshError

if TYPE_CHECKING:
    from exactgrasp.backends.exact.reference import Mesh

_REPAIR_HINT = (
    "the exact backend needs closed, consistently oriented surfaces; load the mesh with ",
    Fix("repair", True),
    " (or fix it in a mesh editor) and try again.",
)


def bounds_centre(meshes: list[Mesh]) -> np.ndarray:
    """Centre of the bounding box of all vertices of the meshes, shape (3,)."""
    if not meshes:
        raise BackendError("no hand link meshes given; pass at least one (V, F) pair.")
    lo = np.min([np.min(V, axis=0) for V, _ in meshes], axis=0)
    hi = np.max([np.max(V, axis=0) for V, _ in meshes], axis=0)
    return 0.5 * (lo + hi)


def shifted(meshes: list[Mesh], origin: np.ndarray) -> list[Mesh]:
    """The meshes with ``origin`` subtracted from their vertices (new arrays)."""
    return [(np.asarray(V, dtype=np.float64) - origin, F) for V, F in meshes]


def prepare_mesh(V: np.ndarray, F: np.ndarray) -> MeshTables:
    """Edge topology of a closed, oriented mesh (V (n, 3), F (m, 3)), as the kernels read it.

    Raises `MeshError` when some edge does not have exactly two faces, one each way.
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
        raise MeshError("mesh is not a closed, oriented 2-manifold after merging; ", *_REPAIR_HINT)
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
    return MeshTables(V, F, E, ET, TE, TO, adj_start, other[order].copy(), eid[order].copy())


def face_conditioning(V: np.ndarray, F: np.ndarray, N: np.ndarray) -> tuple:
    """Per face, ``|b - a| |c - a|`` and the conditioning ``kappa = |b - a| |c - a| / |N|``
    (infinite where the computed normal N is zero): the direction error of a unit normal
    from a cross product is about ``7 U kappa`` (see `tolerances.PLANE_ERR`).

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
    """What each face's rounded ``D`` can cost its terms, ``|dD| area / 3`` (`FACE_D_ERR`),
    divided by the coordinate bound, from its ``|b - a| |c - a|`` and conditioning
    (`face_conditioning`); shape (m,)."""
    return np.where(kappa <= KAPPA_MAX, FACE_D_ERR, FACE_D_ERR_NONE) * U * l1l2


def face_edge_terms(V: np.ndarray, F: np.ndarray, E: np.ndarray, ET: np.ndarray, tiny: float):
    """The hand's per-face and per-edge terms, with error bounds.

    ``D_t`` and the edge weights ``W_e`` are computed in extended precision (``longdouble``;
    80-bit on x86-64) once, so the fixed hand's weights carry almost no rounding.

    Parameters
    ----------
    V, F : numpy.ndarray
        The hand mesh in local coordinates, shapes (n, 3) and (m, 3).
    E, ET : numpy.ndarray
        Its edges and their faces (`prepare_mesh`).
    tiny : float
        Faces with ``|N|² <= tiny`` get ``D = 0`` (as `_sums.face_terms`).

    Returns
    -------
    AD, AN, AP, AW, WL
        `tables.HandTables` ``D``, ``normals``, ``planes`` and ``edge_weights`` (the error
        bound: rounding to double, the extended-precision evaluation, a third of each face's
        ``D`` cost), and ``W_e`` in extended precision (e,) for the parts' sums.
    """
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
    # `_search.plane_err_coef` for every face.
    coef = np.where(kappa <= KAPPA_MAX, PLANE_ERR * U * (1.0 + kappa), PLANE_ERR_NONE)
    g = max(float(np.sqrt((V**2).sum(1)).max()) * ROUNDING_PAD, LENGTH_FLOOR)
    dcost = face_d_coefs(l1l2, kappa) * g
    AP = np.ascontiguousarray(
        np.column_stack([unit, np.einsum("ij,ij->i", unit, V[F[:, 0]]), coef, dcost])
    )
    WL = np.einsum("ij,ij->i", DL[ET[:, 0]] - DL[ET[:, 1]], np.cross(L[E[:, 0]], L[E[:, 1]])) / 6
    W = WL.astype(np.float64)
    dn = np.abs(AD[ET[:, 0]]).sum(1) + np.abs(AD[ET[:, 1]]).sum(1)
    uv = np.abs(V[E[:, 0]]).max(1) * np.abs(V[E[:, 1]]).max(1)
    err = U * np.abs(W) + TERM_ERR * U_EXTENDED * dn * uv + (dcost[ET[:, 0]] + dcost[ET[:, 1]]) / 3
    return AD, AN, AP, np.ascontiguousarray(np.column_stack([W, err])), WL


def part_sums(epart: np.ndarray, AW: np.ndarray, WL: np.ndarray, nparts: int) -> np.ndarray:
    """Per hand part, the summed weight of its own edges (extended precision, rounded once)
    and a bound on its error: shape (parts, 2). ``epart`` is each edge's part (-1 between
    parts), ``AW`` and ``WL`` as from `face_edge_terms`."""
    own = epart >= 0
    total = np.zeros(nparts, np.longdouble)
    np.add.at(total, epart[own], WL[own])
    absw = np.bincount(epart[own], weights=np.abs(AW[own, 0]), minlength=nparts)
    count = np.bincount(epart[own], minlength=nparts)
    wsum = total.astype(np.float64)
    err = np.bincount(epart[own], weights=AW[own, 1], minlength=nparts).astype(np.float64)
    err += U * np.abs(wsum) + 2.0 * count * U_EXTENDED * absw
    return np.ascontiguousarray(np.column_stack([wsum, err]))


def part_edges(mesh: MeshTables, reps: np.ndarray, AW: np.ndarray, WL: np.ndarray) -> tuple:
    """The hand's edges by part (`tables.HandTables.parts` ``reps``; ``AW``, ``WL`` from
    `face_edge_terms`).

    Returns
    -------
    (mesh, epart, wsum, split)
        The mesh with each vertex's adjacency reordered so that its edges to other parts come
        first; the part of each edge (e,), -1 where its ends lie in two parts; the summed weight
        of each part's own edges and its error bound (parts, 2, `part_sums`); and where each
        vertex's entries to other parts end (n,).
    """
    V, E, adj_start, adj_edge = mesh.vertices, mesh.edges, mesh.adj_start, mesh.adj_edge
    nparts = len(reps) - 1
    part = np.searchsorted(reps[:-1, 1], np.arange(len(V)), side="right") - 1
    same = part[E[:, 0]] == part[E[:, 1]]
    epart = np.where(same, part[E[:, 0]], -1).astype(np.int64)
    wsum = part_sums(epart, AW, WL, nparts)
    owner = np.repeat(np.arange(len(V)), np.diff(adj_start))
    order = np.lexsort((same[adj_edge], owner))
    split = adj_start[:-1] + np.bincount(owner[~same[adj_edge]], minlength=len(V))
    mesh = mesh._replace(
        adj_vertex=np.ascontiguousarray(mesh.adj_vertex[order]),
        adj_edge=np.ascontiguousarray(adj_edge[order]),
    )
    return mesh, epart, wsum, split.astype(np.int64)


def segment_runs(V: np.ndarray, E: np.ndarray, size: int) -> np.ndarray:
    """Bounding spheres of the runs of `size` consecutive segments E (k, 2) of vertices V (the
    last run may be shorter): shape (runs, 4), centre and radius; the radius is widened by
    `RADIUS_PAD` of the mesh's scale to cover rounding."""
    runs = -(-len(E) // size)
    if runs == 0:
        return np.zeros((0, 4))
    pad = np.concatenate([E, np.repeat(E[-1:], runs * size - len(E), axis=0)])
    T = V[pad].reshape(runs, size * 2, 3)
    centre = 0.5 * (T.max(1) + T.min(1))
    radius = np.linalg.norm(T - centre[:, None], axis=2).max(1)
    radius += RADIUS_PAD * max(1.0, float(np.abs(V).max()))
    return np.ascontiguousarray(np.column_stack([centre, radius]))


def cotree_edges(mesh: MeshTables) -> np.ndarray:
    """The edges of a mesh that a spanning forest of its dual graph (faces joined across their
    edges) leaves out, the forest keeping the longest edges: about one edge per vertex, the
    shortest ones.

    A closed curve on the mesh that visits each face at most once, moving from face to face
    across edges (a plane's section of the mesh inside one face of the other mesh), is a cycle
    of the dual graph, so it crosses one of these edges (`_seeds.cotree_seeds`). Shape (k,),
    int64, edge indices."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import minimum_spanning_tree

    V, E, ET, m = mesh.vertices, mesh.edges, mesh.edge_faces, len(mesh.faces)
    length = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    # Weights in [1, 2], smallest for the longest edges (a weight of 0 would mean no edge).
    weight = 2.0 - length / max(float(length.max(initial=0.0)), LENGTH_FLOOR)
    a, b = ET.min(1), ET.max(1)
    key = a * m + b
    uniq, first = np.unique(key, return_index=True)
    tree = minimum_spanning_tree(
        coo_matrix((weight[first], (a[first], b[first])), shape=(m, m))
    ).tocoo()
    row, col = tree.row.astype(np.int64), tree.col.astype(np.int64)
    picked = np.isin(uniq, np.minimum(row, col) * m + np.maximum(row, col))
    in_tree = np.zeros(len(E), bool)
    in_tree[first[picked]] = True
    # Two faces sharing several edges keep one in the forest; the others are co-tree edges.
    return np.flatnonzero(~in_tree).astype(np.int64)


def face_filters(V: np.ndarray, F: np.ndarray, N: np.ndarray, coef: np.ndarray) -> tuple:
    """What the seeds' filters read per face (`tables.HandTables.filters`, ``filter_err``): its
    unit normal and plane offset, and per corner k the unit normal of edge k -> k + 1 within
    the face's plane, pointing into the face (``N × (c_{k+1} - c_k)`` normalised, N the face's
    normal), and its offset, all in single precision (`tolerances.FILTER_ERR` covers that); a
    point x of the face's plane lies in the face where every ``normal · x - offset >= 0``.
    Zeros for a face without a normal (such faces are never filtered out). ``coef`` (m,) is
    each face's `_search.plane_err_coef`, rounded up to single precision.

    Returns (filters (m, 16) float32, filter_err (m,) float32)."""
    out = np.zeros((len(F), FILTER_COLUMNS))
    norm = np.linalg.norm(N, axis=1)
    unit = np.divide(N, norm[:, None], out=np.zeros_like(N), where=norm[:, None] > 0)
    out[:, FILTER_NORMAL : FILTER_NORMAL + 3] = unit
    out[:, FILTER_OFFSET] = np.einsum("ij,ij->i", unit, V[F[:, 0]])
    for k in range(3):
        a, b = V[F[:, k]], V[F[:, (k + 1) % 3]]
        side = np.cross(N, b - a)
        norm = np.linalg.norm(side, axis=1)
        side = np.divide(side, norm[:, None], out=np.zeros_like(side), where=norm[:, None] > 0)
        column = FILTER_SIDES + FILTER_SIDE_COLUMNS * k
        out[:, column : column + 3] = side
        out[:, column + FILTER_SIDE_OFFSET] = np.einsum("ij,ij->i", side, a)
    err = coef.astype(np.float32)
    err[err < coef] = np.nextafter(err, np.float32(np.inf))[err < coef]
    return np.ascontiguousarray(out.astype(np.float32)), np.ascontiguousarray(err)


def hand_tables(mesh: MeshTables, grid: CellGrid, tiny: float) -> tuple[MeshTables, HandTables]:
    """The fixed hand's tables, its vertices numbered part by part (`grids.part_order`, cell by
    cell in `grid`); faces with ``|N|² <= tiny`` get ``D = 0``.

    Returns the mesh with its vertices renumbered and its adjacency reordered by part
    (`part_edges`), and its `tables.HandTables`.
    """
    order, part = part_order(mesh.vertices, mesh.faces, grid.cell)
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order))
    mesh = prepare_mesh(
        np.ascontiguousarray(mesh.vertices[order]), np.ascontiguousarray(rank[mesh.faces])
    )
    AV, AF = mesh.vertices, mesh.faces
    AD, AN, AP, AW, WL = face_edge_terms(AV, AF, mesh.edges, mesh.edge_faces, tiny)
    T = AV[AF]
    ABB = np.ascontiguousarray(np.hstack([T.min(1), T.max(1)]))
    reps = cell_reps(AV, grid.cell, part)
    mesh, epart, wsum, split = part_edges(mesh, reps, AW, WL)
    cotree = cotree_edges(mesh)
    # Runs of nearby co-tree edges, the short ones (within a cell) first: a run's sphere then
    # stays small.
    ends = AV[mesh.edges[cotree]]
    long = np.abs(ends[:, 1] - ends[:, 0]).max(1) > grid.cell
    order = morton_order(ends.mean(1))
    cotree = cotree[order[np.argsort(long[order], kind="stable")]]
    filters, filter_err = face_filters(AV, AF, AN, AP[:, FACE_ERR_COEF])
    records = np.zeros((len(AF), FACE_RECORD_COLUMNS))
    records[:, :PLANE_COLUMNS] = AP
    records[:, FACE_CORNERS : FACE_CORNERS + 9] = AV[AF].reshape(-1, 9)
    records[:, FACE_D : FACE_D + 3] = AD
    ET = mesh.edge_faces[mesh.face_edges]
    across = np.where(ET[:, :, 0] == np.arange(len(AF))[:, None], ET[:, :, 1], ET[:, :, 0])
    links = np.zeros((len(AF), FACE_LINKS_COLUMNS), np.int32)
    links[:, FACE_VERTICES : FACE_VERTICES + 3] = AF
    links[:, FACE_EDGES : FACE_EDGES + 3] = mesh.face_edges
    links[:, FACE_ACROSS : FACE_ACROSS + 3] = across
    links[:, FACE_OWNS : FACE_OWNS + 3] = mesh.face_owns
    tables = HandTables(
        D=AD,
        normals=AN,
        boxes=ABB,
        planes=AP,
        parts=reps,
        edge_weights=AW,
        edge_part=epart,
        part_weights=wsum,
        adj_split=split,
        d_cost=np.empty(0),
        filters=filters,
        filter_err=filter_err,
        face_records=records,
        face_links=links,
        cotree=np.ascontiguousarray(cotree),
        cotree_runs=segment_runs(AV, mesh.edges[cotree], COTREE_CHUNK),
        cotree_blocks=segment_runs(AV, mesh.edges[cotree], COTREE_CHUNK * COTREE_BLOCK),
    )
    return mesh, tables


def object_tables(mesh: MeshTables) -> ObjectTables:
    """The object's pose-independent tables (`tables.ObjectTables`), in its own frame."""
    BV, BF, BE = mesh.vertices, mesh.faces, mesh.edges
    # What each face's rounded D can cost (rigid motions keep it).
    BN = np.cross(BV[BF[:, 1]] - BV[BF[:, 0]], BV[BF[:, 2]] - BV[BF[:, 0]])
    l1l2, kappa = face_conditioning(BV, BF, BN)
    # `_search.plane_err_coef` for every face, as for the hand's.
    coef = np.where(kappa <= KAPPA_MAX, PLANE_ERR * U * (1.0 + kappa), PLANE_ERR_NONE)
    order = morton_order(BV[BE].mean(1))
    filters, filter_err = face_filters(BV, BF, BN, coef)
    return ObjectTables(
        edge_order=np.ascontiguousarray(order),
        edge_runs=segment_runs(BV, BE[order], CHUNK),
        filters=filters,
        filter_err=filter_err,
        d_cost=np.ascontiguousarray(face_d_coefs(l1l2, kappa)),
        # The object is one part, never classified whole.
        parts=np.array([[-1, 0], [-1, len(BV)]], np.int64),
        whole=np.zeros(1, np.bool_),
        adj_split=np.ascontiguousarray(mesh.adj_start[1:]),
        edge_weights=np.empty((0, 2)),
        edge_part=np.empty(0, np.int64),
        part_weights=np.empty((0, 2)),
    )
