"""The volume's derivatives in the kernel (numba): the moments ``(∫ n dA, ∫ x × n dA)`` of each
link's boundary inside the moved object, summed from what the volume's pass leaves behind.

The hand's boundary inside the object is, face by face, a polygon bounded by pieces of the
face's edges inside the object and by the segments where it crosses the object's surface: the
same pieces the volume's terms are made of (`sums`). For a planar piece boundary with unit
normal ``n``, the fan from the point of the plane nearest the origin gives per directed piece
``p → q``, with ``c = n · (p × q)``:

``∫ n dA += n c / 2`` and ``∫ x × n dA += ((p + q) × n) c / 6``.

Along an edge ``u → v`` the pieces inside are parameter intervals ``[a, b]``; with
``f = Σ (b - a)`` and ``h = Σ (b² - a²)`` the edge's share of face ``t1`` (which runs
``u → v``) is ``n1 (n1 · w) f / 2`` and ``((2 f u + h (v - u)) × n1)(n1 · w) / 6``,
``w = u × v``, and face ``t2`` (which runs ``v → u``) takes the same with ``n2`` and the
opposite sign. That share is ``f`` times the whole edge's (``f = h = 1``, precomputed) plus
``(0, (h - f)(v - u) × F / 3)``, ``F = n1 (n1 · w) / 2`` the whole edge's first three: a
crossed edge reads its whole share and its ends, not its faces. So the derivatives need only
the statuses, the crossings and the traced segments of the volume's pass (see `moments` for
what the moments give).
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.tables import (
    EDGE_MOMENTS_T1,
    EDGE_MOMENTS_T2,
    MOMENT_COLUMNS,
    PART_FIRST_VERTEX,
    SEGMENT_LINK,
    SEGMENT_NORMAL,
    SEGMENT_P,
    SEGMENT_Q,
    MomentTables,
)
from exactgrasp.compiling import inner

__all__ = ["hand_moments", "moment_tables"]


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
    mesh, hand, face_link: np.ndarray, n_links: int, object_from: int = -1
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
    object_from : int
        The row from which the moments hold one row per object face (`object_moments`), or
        -1 for none.
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
    )


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
    )


@inner(nogil=True, error_model="numpy")
def segment_moments(segs, ncross, G):
    """Stage "segments" of `hand_moments`: the traced segments' pieces, each on its hand face
    (boundary ``p → q``; its normal and link came with it), added to ``G`` (L, 6).

    Parameters
    ----------
    segs : numpy.ndarray, shape (>= ncross, 11)
        The pose's crossing segments (hand face, p, q, unit normal, link),
        `tables.Workspace.segments`; length units.
    ncross : int
    G : numpy.ndarray, shape (L, 6)
    """
    for k in range(ncross):
        p, q, n = SEGMENT_P, SEGMENT_Q, SEGMENT_NORMAL
        px, py, pz = segs[k, p], segs[k, p + 1], segs[k, p + 2]
        qx, qy, qz = segs[k, q], segs[k, q + 1], segs[k, q + 2]
        nx, ny, nz = segs[k, n], segs[k, n + 1], segs[k, n + 2]
        lk = int(segs[k, SEGMENT_LINK])
        c = nx * (py * qz - pz * qy) + ny * (pz * qx - px * qz) + nz * (px * qy - py * qx)
        sx, sy, sz = px + qx, py + qy, pz + qz
        a = c / 2.0
        b = c / 6.0  # one division a segment, not three
        G[lk, 0] += nx * a
        G[lk, 1] += ny * a
        G[lk, 2] += nz * a
        G[lk, 3] += (sy * nz - sz * ny) * b
        G[lk, 4] += (sz * nx - sx * nz) * b
        G[lk, 5] += (sx * ny - sy * nx) * b


@inner(nogil=True, error_model="numpy")
def whole_edge_moments(hand_mesh, hand, mom, S, uniform, G):
    """Stage "whole edges" of `hand_moments`: the whole edges from every inside vertex to
    higher-numbered ones, crossed or not (`crossed_edge_moments` corrects the crossed ones; an
    uncrossed one from an inside vertex ends inside, as `sums.edge_sum` checks), added to
    ``G`` (L, 6): one sum per link for a part classified whole (``uniform``) and inside, one
    row per inside vertex of the other parts (edge by edge at a seam between links).
    Arguments as in `hand_moments`.
    """
    adj_start, adj_vert, adj_edge = hand_mesh.adj_start, hand_mesh.adj_vertex, hand_mesh.adj_edge
    reps = hand.parts
    elink, emom = mom.edge_links, mom.edge_moments
    vlink, vmom = mom.vertex_link, mom.vertex_moments
    pstart, plink, pmom = mom.part_start, mom.part_link, mom.part_moments
    for p in range(reps.shape[0] - 1):
        if uniform[p]:
            if S[reps[p, PART_FIRST_VERTEX]] == 1:
                for j in range(pstart[p], pstart[p + 1]):
                    lk = plink[j]
                    for d in range(MOMENT_COLUMNS):
                        G[lk, d] += pmom[j, d]
            continue
        for u in range(reps[p, PART_FIRST_VERTEX], reps[p + 1, PART_FIRST_VERTEX]):
            if S[u] != 1:
                continue
            lk = vlink[u]
            if lk >= 0:
                for d in range(MOMENT_COLUMNS):
                    G[lk, d] += vmom[u, d]
                continue
            for k in range(adj_start[u], adj_start[u + 1]):
                if u >= adj_vert[k]:
                    continue
                e = adj_edge[k]
                l1, l2 = elink[e, 0], elink[e, 1]
                for d in range(MOMENT_COLUMNS):
                    G[l1, d] += emom[e, EDGE_MOMENTS_T1 + d]
                    G[l2, d] += emom[e, EDGE_MOMENTS_T2 + d]


@inner(nogil=True, error_model="numpy")
def _add_interval_share(hand_mesh, mom, e, f, g, G):
    """Add to ``G`` (L, 6) the share of edge ``e = u → v`` whose inside intervals give
    ``f = Σ (b - a)`` and ``g = Σ (b² - a²) / 3 - f / 3``, on both its faces: for each face,
    ``f`` times the whole edge's share ``(F, M)`` (`tables.MomentTables.edge_moments`) plus
    ``(0, g (v - u) × F)`` (``2 f u + h (v - u) = f (u + v) + (h - f)(v - u)``: the share is
    linear in ``f`` and ``h``)."""
    V, E = hand_mesh.vertices, hand_mesh.edges
    emom = mom.edge_moments
    u, v = E[e, 0], E[e, 1]
    dx, dy, dz = V[v, 0] - V[u, 0], V[v, 1] - V[u, 1], V[v, 2] - V[u, 2]
    for side in range(2):
        lk = mom.edge_links[e, side]
        o = EDGE_MOMENTS_T2 if side else EDGE_MOMENTS_T1
        fx, fy, fz = emom[e, o], emom[e, o + 1], emom[e, o + 2]
        G[lk, 0] += f * fx
        G[lk, 1] += f * fy
        G[lk, 2] += f * fz
        G[lk, 3] += f * emom[e, o + 3] + g * (dy * fz - dz * fy)
        G[lk, 4] += f * emom[e, o + 4] + g * (dz * fx - dx * fz)
        G[lk, 5] += f * emom[e, o + 5] + g * (dx * fy - dy * fx)


@inner(nogil=True, error_model="numpy")
def crossed_edge_moments(hand_mesh, mom, S, cnt, rec_e, rec_l, nrec, chain, G):
    """Stage "crossed edges" of `hand_moments`: each crossed edge's inside intervals, less the
    whole edge `whole_edge_moments` added where its lower vertex is inside, added to ``G``
    (arguments as in `hand_moments`, ``chain`` being its scratch ``multi``).

    An edge crossed once is inside on ``[0, λ]`` or ``[λ, 1]``. The records of an edge crossed
    more than once are chained through ``chain``, the head's index kept in ``cnt`` (as
    ``-1 - index``) until `_multi_crossed` walks the chain and puts the count back: linear in
    the records, and ``cnt`` is as it was on return.
    """
    E = hand_mesh.edges
    chained = 0
    for i in range(nrec):
        e = rec_e[i]
        c = cnt[e]
        if c == 1:
            lam = rec_l[i]
            # Inside on [0, λ] (less the whole edge) or on [λ, 1]: f = ±(1 - λ), and
            # (h - f) / 3 = λ f / 3 either way.
            f = lam - 1.0 if S[E[e, 0]] == 1 else 1.0 - lam
            _add_interval_share(hand_mesh, mom, e, f, lam * f / 3.0, G)
            continue
        chain[i] = -1 if c > 0 else -1 - c
        cnt[e] = -1 - i
        chained += 1
    if chained > 0:
        _multi_crossed(hand_mesh, mom, S, cnt, rec_e, rec_l, nrec, chain, chained, G)


@inner(nogil=True, error_model="numpy")
def _multi_crossed(hand_mesh, mom, S, cnt, rec_e, rec_l, nrec, chain, chained, G):
    """The edges crossed more than once (``chained`` records, chained by
    `crossed_edge_moments`): each chain's parameters sorted, the edge's inside intervals from
    its lower vertex's status, and each edge's count put back into ``cnt``."""
    E = hand_mesh.edges
    lams = np.empty(chained)
    for i in range(nrec):
        e = rec_e[i]
        if cnt[e] >= 0:
            continue  # crossed once, or its chain already walked
        n = 0
        k = -1 - cnt[e]
        while k >= 0:
            lams[n] = rec_l[k]
            n += 1
            k = chain[k]
        cnt[e] = n
        _sort_small(lams, n)
        inside = S[E[e, 0]] == 1
        f = 0.0
        h = 0.0
        last = 0.0
        for k in range(n):
            if inside:
                f += lams[k] - last
                h += lams[k] * lams[k] - last * last
            last = lams[k]
            inside = not inside
        if inside:
            f += 1.0 - last
            h += 1.0 - last * last
        if S[E[e, 0]] == 1:
            f -= 1.0
            h -= 1.0
        _add_interval_share(hand_mesh, mom, e, f, (h - f) / 3.0, G)


@inner(nogil=True, error_model="numpy")
def _sort_small(x, n):
    """Insertion sort of x[:n] in place (an edge rarely crosses a surface more than twice)."""
    for i in range(1, n):
        y = x[i]
        j = i
        while j > 0 and x[j - 1] > y:
            x[j] = x[j - 1]
            j -= 1
        x[j] = y


@inner(nogil=True, error_model="numpy")
def hand_moments(
    hand_mesh, hand, mom, S, uniform, cnt, rec_e, rec_l, nrec, multi, segs, ncross, G
):  # fmt: skip
    """Moments ``(∫ n dA, ∫ x × n dA)`` of each link's boundary inside the object, added to
    ``G`` (L, 6), local coordinates, after a pose's volume pass: `segment_moments`,
    `whole_edge_moments` and `crossed_edge_moments` in turn.

    Parameters
    ----------
    hand_mesh : tables.MeshTables
    hand : tables.HandTables
    mom : tables.MomentTables
    S : numpy.ndarray, shape (hand n,) int8
        The hand's vertex statuses (1 inside the object).
    uniform : numpy.ndarray, shape (parts,) bool
        The parts classified whole.
    cnt : numpy.ndarray, shape (hand e,) int64
        Crossings recorded per hand edge (`tables.Workspace.hand_count`); written to, and put
        back.
    rec_e, rec_l, nrec : numpy.ndarray, numpy.ndarray, int
        The records' edges and parameters along ``u → v`` (`tables.Crossings`), and their
        number.
    multi : numpy.ndarray, shape (>= nrec,) int64
        Scratch.
    segs : numpy.ndarray, shape (>= ncross, 11)
        The pose's crossing segments (hand face, p, q, normal, link),
        `tables.Workspace.segments`.
    ncross : int
    G : numpy.ndarray, shape (L, 6)
    """
    segment_moments(segs, ncross, G)
    whole_edge_moments(hand_mesh, hand, mom, S, uniform, G)
    crossed_edge_moments(hand_mesh, mom, S, cnt, rec_e, rec_l, nrec, multi, G)
