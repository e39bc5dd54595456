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
what the moments give). The tables they read are built by `moment_layout`.
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
)
from exactgrasp.compiling import inner

__all__ = ["add_edge", "add_piece", "crossed_edge_moments", "hand_moments", "touch"]


@inner(nogil=True, error_model="numpy")
def touch(stamp, touched, listed, pose, r):
    """Row ``r`` touched by pose ``pose``, ``listed`` rows in ``touched`` so far: listed the
    first time (`tables.MomentRows`' ``stamp`` and ``touched``). Returns the rows listed now.
    No branch: the rows come in no order the processor could guess."""
    touched[listed] = r
    fresh = stamp[r] != pose
    stamp[r] = pose
    return listed + 1 if fresh else listed


@inner(nogil=True, error_model="numpy")
def segment_moments(segs, ncross, G):
    """Stage "segments" of `hand_moments`: the traced segments' pieces, each on its hand face
    (boundary ``p → q``; its normal and link came with it), added to ``G``'s rows.

    Parameters
    ----------
    segs : numpy.ndarray, shape (>= ncross, 11)
        The pose's crossing segments (hand face, p, q, unit normal, link),
        `tables.Workspace.segments`; length units.
    ncross : int
    G : tables.MomentRows
    """
    rows, stamp, touched, state = G.values, G.stamp, G.touched, G.state
    listed, pose = state[0], state[1]
    for k in range(ncross):
        p, q, n = SEGMENT_P, SEGMENT_Q, SEGMENT_NORMAL
        px, py, pz = segs[k, p], segs[k, p + 1], segs[k, p + 2]
        qx, qy, qz = segs[k, q], segs[k, q + 1], segs[k, q + 2]
        nx, ny, nz = segs[k, n], segs[k, n + 1], segs[k, n + 2]
        lk = int(segs[k, SEGMENT_LINK])
        listed = touch(stamp, touched, listed, pose, lk)
        add_piece(rows, lk, nx, ny, nz, px, py, pz, qx, qy, qz)
    state[0] = listed


@inner(nogil=True, error_model="numpy")
def add_piece(rows, r, nx, ny, nz, px, py, pz, qx, qy, qz):
    """Add to ``rows[r]`` the moments of a boundary piece ``p → q`` of a face with unit
    normal ``n``: ``∫ n dA += n c / 2`` and ``∫ x × n dA += ((p + q) × n) c / 6``, with
    ``c = n · (p × q)``."""
    c = nx * (py * qz - pz * qy) + ny * (pz * qx - px * qz) + nz * (px * qy - py * qx)
    sx, sy, sz = px + qx, py + qy, pz + qz
    a = c / 2.0
    b = c / 6.0  # one division a piece, not three
    rows[r, 0] += nx * a
    rows[r, 1] += ny * a
    rows[r, 2] += nz * a
    rows[r, 3] += (sy * nz - sz * ny) * b
    rows[r, 4] += (sz * nx - sx * nz) * b
    rows[r, 5] += (sx * ny - sy * nx) * b


@inner(nogil=True, error_model="numpy")
def whole_edge_moments(hand_mesh, hand, mom, S, uniform, G):
    """Stage "whole edges" of `hand_moments`: the whole edges from every inside vertex to
    higher-numbered ones, crossed or not (`crossed_edge_moments` corrects the crossed ones; an
    uncrossed one from an inside vertex ends inside, as `sums.edge_sum` checks), added to
    ``G``'s rows: one sum per link for a part classified whole (``uniform``) and inside (or
    its marker, `tables.MomentTables.part_from`), one row per inside vertex of the other parts
    (edge by edge at a seam between links). Arguments as in `hand_moments`.
    """
    rows, stamp, touched, state = G.values, G.stamp, G.touched, G.state
    listed, pose = state[0], state[1]
    adj_start, adj_vert, adj_edge = hand_mesh.adj_start, hand_mesh.adj_vertex, hand_mesh.adj_edge
    reps = hand.parts
    elink, emom = mom.edge_links, mom.edge_moments
    vlink, vmom = mom.vertex_link, mom.vertex_moments
    pstart, plink, pmom = mom.part_start, mom.part_link, mom.part_moments
    marker = mom.part_from[0]
    for p in range(reps.shape[0] - 1):
        if uniform[p]:
            if S[reps[p, PART_FIRST_VERTEX]] == 1 and marker >= 0:
                listed = touch(stamp, touched, listed, pose, marker + p)
            elif S[reps[p, PART_FIRST_VERTEX]] == 1:
                for j in range(pstart[p], pstart[p + 1]):
                    lk = plink[j]
                    listed = touch(stamp, touched, listed, pose, lk)
                    for d in range(MOMENT_COLUMNS):
                        rows[lk, d] += pmom[j, d]
            continue
        for u in range(reps[p, PART_FIRST_VERTEX], reps[p + 1, PART_FIRST_VERTEX]):
            if S[u] != 1:
                continue
            lk = vlink[u]
            if lk >= 0:
                listed = touch(stamp, touched, listed, pose, lk)
                for d in range(MOMENT_COLUMNS):
                    rows[lk, d] += vmom[u, d]
                continue
            for k in range(adj_start[u], adj_start[u + 1]):
                if u >= adj_vert[k]:
                    continue
                listed = add_edge(rows, stamp, touched, listed, pose, elink, emom, adj_edge[k])
    state[0] = listed


@inner(nogil=True, error_model="numpy")
def add_edge(rows, stamp, touched, listed, pose, elink, emom, e):
    """Add whole edge ``e``'s shares of its two faces' moments (``emom``) to their rows
    (``elink``), listing the rows (`touch`); returns the rows listed now."""
    r1, r2 = elink[e, 0], elink[e, 1]
    listed = touch(stamp, touched, listed, pose, r1)
    listed = touch(stamp, touched, listed, pose, r2)
    for d in range(MOMENT_COLUMNS):
        rows[r1, d] += emom[e, EDGE_MOMENTS_T1 + d]
        rows[r2, d] += emom[e, EDGE_MOMENTS_T2 + d]
    return listed


@inner(nogil=True, error_model="numpy")
def _add_interval_share(V, E, elink, emom, e, f, g, G):
    """Add to ``G`` (`tables.MomentRows.values`, both rows touched) the share of edge
    ``e = u → v`` whose inside intervals give ``f = Σ (b - a)`` and
    ``g = Σ (b² - a²) / 3 - f / 3``, on both its faces: for each face, ``f`` times the whole
    edge's share ``(F, M)`` (`tables.MomentTables.edge_moments`) plus ``(0, g (v - u) × F)``
    (``2 f u + h (v - u) = f (u + v) + (h - f)(v - u)``: the share is linear in ``f`` and
    ``h``). ``V``, ``E``: the mesh's vertices and edges; ``elink``, ``emom``: each edge's
    rows and whole shares (`tables.MomentTables.edge_links`, ``edge_moments``, or the
    object's)."""
    rows = G
    u, v = E[e, 0], E[e, 1]
    dx, dy, dz = V[v, 0] - V[u, 0], V[v, 1] - V[u, 1], V[v, 2] - V[u, 2]
    for side in range(2):
        lk = elink[e, side]
        o = EDGE_MOMENTS_T2 if side else EDGE_MOMENTS_T1
        fx, fy, fz = emom[e, o], emom[e, o + 1], emom[e, o + 2]
        rows[lk, 0] += f * fx
        rows[lk, 1] += f * fy
        rows[lk, 2] += f * fz
        rows[lk, 3] += f * emom[e, o + 3] + g * (dy * fz - dz * fy)
        rows[lk, 4] += f * emom[e, o + 4] + g * (dz * fx - dx * fz)
        rows[lk, 5] += f * emom[e, o + 5] + g * (dx * fy - dy * fx)


@inner(nogil=True, error_model="numpy")
def crossed_edge_moments(V, E, elink, emom, S, cnt, rec_e, rec_l, nrec, chain, G):
    """Stage "crossed edges" of `hand_moments` (and `object_moments.object_moments`): each
    crossed edge's inside intervals, less the whole edge added where its lower vertex is
    inside (`whole_edge_moments`), added to ``G`` (arguments as in `hand_moments`, ``chain``
    being its scratch ``multi``; the mesh's ``V``, ``E``, ``elink``, ``emom`` as
    `_add_interval_share` takes them).

    An edge crossed once is inside on ``[0, λ]`` or ``[λ, 1]``. The records of an edge crossed
    more than once are chained through ``chain``, the head's index kept in ``cnt`` (as
    ``-1 - index``) until `_multi_crossed` walks the chain and puts the count back: linear in
    the records, and ``cnt`` is as it was on return.
    """
    values, stamp, touched, state = G.values, G.stamp, G.touched, G.state
    listed, pose = state[0], state[1]
    chained = 0
    for i in range(nrec):
        e = rec_e[i]
        c = cnt[e]
        # Rows are marked touched here, where the marks are locals (not per addition).
        listed = touch(stamp, touched, listed, pose, elink[e, 0])
        listed = touch(stamp, touched, listed, pose, elink[e, 1])
        if c == 1:
            lam = rec_l[i]
            # Inside on [0, λ] (less the whole edge) or on [λ, 1]: f = ±(1 - λ), and
            # (h - f) / 3 = λ f / 3 either way.
            f = lam - 1.0 if S[E[e, 0]] == 1 else 1.0 - lam
            _add_interval_share(V, E, elink, emom, e, f, lam * f / 3.0, values)
            continue
        chain[i] = -1 if c > 0 else -1 - c
        cnt[e] = -1 - i
        chained += 1
    state[0] = listed
    if chained > 0:
        _multi_crossed(V, E, elink, emom, S, cnt, rec_e, rec_l, nrec, chain, chained, values)


@inner(nogil=True, error_model="numpy")
def _multi_crossed(V, E, elink, emom, S, cnt, rec_e, rec_l, nrec, chain, chained, G):
    """The edges crossed more than once (``chained`` records, chained by
    `crossed_edge_moments`): each chain's parameters sorted, the edge's inside intervals from
    its lower vertex's status, and each edge's count put back into ``cnt`` (``G``:
    `tables.MomentRows.values`, the rows touched)."""
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
        _add_interval_share(V, E, elink, emom, e, f, (h - f) / 3.0, G)


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
    ``G``'s rows (L), local coordinates, after a pose's volume pass: `segment_moments`,
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
    G : tables.MomentRows
        The moments' rows (L), each row touched listed there.
    """
    segment_moments(segs, ncross, G)
    whole_edge_moments(hand_mesh, hand, mom, S, uniform, G)
    V, E = hand_mesh.vertices, hand_mesh.edges
    elink, emom = mom.edge_links, mom.edge_moments
    crossed_edge_moments(V, E, elink, emom, S, cnt, rec_e, rec_l, nrec, multi, G)
