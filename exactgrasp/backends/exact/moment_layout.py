"""The tables the volume's derivatives read in the kernel (`tables.MomentTables`), built once
per intersector: which row each hand face adds to (its link, or with moments per face the face
itself), the whole edges' shares, their sums per vertex and per part (``_moment_sums.pxd`` for
what they are), and with moments per face the object's edges' shares in its own frame
(``_object_moments.pxd``) and one marker row per part; for the vertex derivatives, the same
with one marker row per hand vertex too (`vertex_markers`).
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.tables import MomentTables

__all__ = ["empty_moment_tables", "moment_layout", "moment_tables", "vertex_markers"]


def _edge_shares(V, E, ET, unit, f, h):
    """The moments (e, 12) of each edge's inside share (fractions ``f``, ``h``; see the
    module) on its faces t1 (6) and t2 (6)."""
    u, v = V[E[:, 0]], V[E[:, 1]]
    w = np.cross(u, v)
    s = 2.0 * f[:, None] * u + h[:, None] * (v - u)
    out = np.empty((len(E), 12))
    for side, sign in ((0, 1.0), (1, -1.0)):
        n = unit[ET[:, side]]
        c = sign * np.einsum("ij,ij->i", n, w)
        out[:, 6 * side : 6 * side + 3] = n * (c * f / 2.0)[:, None]
        out[:, 6 * side + 3 : 6 * side + 6] = np.cross(s, n) * (c / 6.0)[:, None]
    return out


def _grouped(keys: np.ndarray, values: np.ndarray, n_links: int, n_groups: int):
    """Sums of ``values`` (k, 6) by ``keys`` = group * n_links + link: (CSR start per group
    (n_groups + 1,), link per entry, sums per entry)."""
    uniq, inv = np.unique(keys, return_inverse=True)
    sums = np.zeros((len(uniq), 6))
    np.add.at(sums, inv.reshape(-1), values)
    start = np.zeros(n_groups + 1, np.int64)
    np.cumsum(np.bincount(uniq // n_links, minlength=n_groups), out=start[1:])
    return start, np.ascontiguousarray(uniq % n_links, dtype=np.int64), sums


def moment_tables(
    mesh, hand, face_link: np.ndarray, n_links: int, object_mesh=None, markers: bool = False
) -> MomentTables:
    """The hand's `tables.MomentTables`; also writes each face's link into
    ``hand.face_records[:, 18]`` (what the traced segments carry).

    Parameters
    ----------
    mesh : tables.MeshTables
        The hand's mesh as the kernel numbers it.
    hand : tables.HandTables
    face_link : numpy.ndarray, shape (m,) int64
        The link of each face of ``mesh``.
    n_links : int
    object_mesh : tables.MeshTables, optional
        The object's mesh (local coordinates, unmoved): one row per object face after the
        links' (``_object_moments.pxd``); None for none.
    markers : bool
        One marker row per part after those (`tables.MomentTables.part_from`).
    """
    V, E, ET = mesh.vertices, mesh.edges, mesh.edge_faces
    unit = hand.planes[:, :3]
    ones = np.ones(len(E))
    shares = _edge_shares(V, E, ET, unit, ones, ones)
    links = np.ascontiguousarray(face_link[ET])
    # Each edge's shares, on its lower vertex (E holds u < v) and that vertex's part.
    low = np.concatenate([E[:, 0], E[:, 0]])
    link = np.concatenate([links[:, 0], links[:, 1]])
    vals = np.concatenate([shares[:, :6], shares[:, 6:]])
    n = len(V)
    vstart, vlink, vsums = _grouped(low * n_links + link, vals, n_links, n)
    single = (vstart[1:] - vstart[:-1]) == 1
    vertex_link = np.full(n, -1, np.int64)
    vertex_moments = np.zeros((n, 6))
    none = vstart[1:] == vstart[:-1]
    vertex_link[none] = 0  # no edge to a higher-numbered vertex: adds zeros
    vertex_link[single] = vlink[vstart[:-1][single]]
    vertex_moments[single] = vsums[vstart[:-1][single]]
    nparts = len(hand.parts) - 1
    part_of = np.searchsorted(hand.parts[:, 1], low, side="right") - 1
    pstart, plink, psums = _grouped(part_of * n_links + link, vals, n_links, nparts)
    hand.face_records[:, 18] = face_link
    object_from, object_links, object_shares, object_unit = _object_tables(object_mesh, n_links)
    rows = n_links + len(object_unit)
    return MomentTables(
        np.ascontiguousarray(face_link, dtype=np.int64),
        links.astype(np.int64),
        np.ascontiguousarray(shares),
        vertex_link,
        vertex_moments,
        pstart,
        plink,
        np.ascontiguousarray(psums),
        np.array([object_from], np.int64),
        np.array([rows + (nparts if markers else 0)], np.int64),
        np.array([rows if markers else -1], np.int64),
        object_links,
        object_shares,
        object_unit,
    )


def _object_tables(object_mesh, row0: int):
    """The object's part of `tables.MomentTables` (its rows from ``row0``): (`object_from`,
    `object_edge_links`, `object_edge_moments`, `object_normals`), or none without
    ``object_mesh``."""
    if object_mesh is None:
        return -1, np.zeros((0, 2), np.int64), np.zeros((0, 12)), np.zeros((0, 3))
    V, F = object_mesh.vertices, object_mesh.faces
    E, ET = object_mesh.edges, object_mesh.edge_faces
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    norm = np.sqrt(np.einsum("ij,ij->i", N, N))
    unit = np.divide(N, norm[:, None], out=np.zeros_like(N), where=norm[:, None] > 0)
    ones = np.ones(len(E))
    shares = _edge_shares(V, E, ET, unit, ones, ones)
    return row0, (row0 + ET).astype(np.int64), shares, unit


def vertex_markers(tables: MomentTables, mesh, hand) -> MomentTables:
    """``tables`` (with moments per face and part markers) with one marker row per hand
    vertex as well, after the parts': a vertex inside the object, of a part classified
    vertex by vertex, lists its marker (row ``part_from + parts + vertex``) instead of adding
    its whole edges' shares to their faces' rows. What a marker stands for is the entries of
    `tables.MomentTables.part_start` from ``parts + vertex`` on: its whole edges' shares by
    face, as a part's are (`moment_entries.dense` and `face_gradients.vertex_tables` read the
    vertices' markers as more parts). The rows of a pose then hold only the crossed faces'
    pieces and corrections; the volume and the kernel's arithmetic are the same, the faces'
    moments the same sums taken in another order.

    Parameters
    ----------
    tables : tables.MomentTables
        `moment_tables` with ``markers`` (`moment_layout` with ``object_src``).
    mesh, hand
        As `moment_tables`.
    """
    E, n = mesh.edges, len(mesh.vertices)
    nparts = len(hand.parts) - 1
    rows = int(tables.part_from[0])
    faces = int(tables.object_from[0])  # the hand's faces' rows come first
    low = np.concatenate([E[:, 0], E[:, 0]])
    face = tables.edge_links.T.reshape(-1)
    vals = np.concatenate([tables.edge_moments[:, :6], tables.edge_moments[:, 6:]])
    # Each share in its lower vertex's group, after the parts' groups (each share in its
    # lower vertex's part's, `moment_tables`).
    vstart, vlink, vsums = _grouped(low * faces + face, vals, faces, n)
    start = np.concatenate([tables.part_start, tables.part_start[-1] + vstart[1:]])
    link = np.concatenate([tables.part_link, vlink])
    sums = np.concatenate([tables.part_moments, vsums])
    return tables._replace(
        vertex_link=np.arange(rows + nparts, rows + nparts + n, dtype=np.int64),
        vertex_moments=np.zeros((n, 6)),
        part_start=start,
        part_link=link,
        part_moments=np.ascontiguousarray(sums),
        row_count=np.array([rows + nparts + n], np.int64),
    )


def moment_layout(
    mesh, hand, hand_src: np.ndarray, n_links: int, object_src=None, object_mesh=None
):
    """An intersector's moments: one row per link, or with ``object_src`` one row per face of
    the hand's union, then one per face of the object's.

    Parameters
    ----------
    mesh, hand
        As `moment_tables`.
    hand_src : numpy.ndarray, shape (m, 2) int64
        The (link, input face) of each face of ``mesh`` (`moments.face_sources`, kernel order).
    n_links : int
    object_src : numpy.ndarray, shape (m_o, 2) int64, optional
        The (body, input face) of each object face: moments per face.
    object_mesh : tables.MeshTables, optional
        The object's mesh, with ``object_src``.

    Returns
    -------
    sources : (hand_src, object_src) or None
    rows : int
        The moments' rows per pose.
    tables : tables.MomentTables
    per_vertex : tables.MomentTables or None
        With ``object_src``, ``tables`` with a marker per hand vertex too (`vertex_markers`).
    """
    if object_src is None:
        return None, n_links, moment_tables(mesh, hand, hand_src[:, 0], n_links), None
    m = len(hand_src)
    tables = moment_tables(mesh, hand, np.arange(m, dtype=np.int64), m, object_mesh, True)
    sources = (hand_src, object_src)
    return sources, m + len(object_src), tables, vertex_markers(tables, mesh, hand)


def empty_moment_tables() -> MomentTables:
    """`tables.MomentTables` with no rows: volumes only."""
    return MomentTables(
        np.zeros(0, np.int64),
        np.zeros((0, 2), np.int64),
        np.zeros((0, 12)),
        np.zeros(0, np.int64),
        np.zeros((0, 6)),
        np.zeros(1, np.int64),
        np.zeros(0, np.int64),
        np.zeros((0, 6)),
        np.array([-1], np.int64),
        np.zeros(1, np.int64),
        np.array([-1], np.int64),
        np.zeros((0, 2), np.int64),
        np.zeros((0, 12)),
        np.zeros((0, 3)),
    )
