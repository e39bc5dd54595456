# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""The volume's derivatives in the kernel, compiled (Cython, inline): the moments
``(∫ n dA, ∫ x × n dA)`` of each link's boundary inside the moved object, summed from what
the volume's pass leaves behind; the arithmetic of the numba stage it replaced,
operation for operation.

The hand's boundary inside the object is, face by face, a polygon bounded by pieces of the
face's edges inside the object and by the segments where it crosses the object's surface. For
a planar piece boundary with unit normal ``n``, per directed piece ``p → q``, with
``c = n · (p × q)``: ``∫ n dA += n c / 2`` and ``∫ x × n dA += ((p + q) × n) c / 6``. An
edge's share inside is ``f`` times the whole edge's (tabled) plus ``(0, (h - f)(v - u) × F /
3)``, ``f = Σ (b - a)`` and ``h = Σ (b² - a²)`` over its inside intervals ``[a, b]``, ``F``
the whole edge's first three (see "Derivatives" in ``docs/exact-backend.md``).

An edge crossed more than once has its records' parameters sorted by relinking their chain
in the scratch ``chain`` (numba sorted a copy in an array it allocated): the same values in
the same order, so the same sums.

The directives above are this file's own: those of a ``.pyx`` that cimports it do not reach
its inline functions (bounds and division checks would stay).
"""

from libc.stdint cimport int8_t, int64_t, uint8_t

from exactgrasp.backends.exact._constants cimport (
    EDGE_MOMENTS_T1,
    EDGE_MOMENTS_T2,
    MOMENT_COLUMNS,
    PART_FIRST_VERTEX,
    SEGMENT_LINK,
    SEGMENT_NORMAL,
    SEGMENT_P,
    SEGMENT_Q,
)
from exactgrasp.backends.exact._tables cimport HandTables, MeshTables, MomentRows, MomentTables

#: A chain's head and its length.
ctypedef (int64_t, int64_t) Chain


cdef inline int64_t touch(
    int64_t[::1] stamp, int64_t[::1] touched, int64_t listed, int64_t pose, int64_t r
) noexcept nogil:
    """Row ``r`` touched by pose ``pose``, ``listed`` rows in ``touched`` so far: listed the
    first time (`tables.MomentRows`' ``stamp`` and ``touched``). Returns the rows listed now.
    No branch: the rows come in no order the processor could guess."""
    touched[listed] = r
    cdef bint fresh = stamp[r] != pose
    stamp[r] = pose
    return listed + fresh


cdef inline void add_piece(
    double[:, ::1] rows, int64_t r, double nx, double ny, double nz, double px, double py,
    double pz, double qx, double qy, double qz,
) noexcept nogil:
    """Add to ``rows[r]`` the moments of a boundary piece ``p → q`` of a face with unit
    normal ``n``: ``∫ n dA += n c / 2`` and ``∫ x × n dA += ((p + q) × n) c / 6``, with
    ``c = n · (p × q)``."""
    cdef double c = nx * (py * qz - pz * qy) + ny * (pz * qx - px * qz) + nz * (px * qy - py * qx)
    cdef double sx = px + qx, sy = py + qy, sz = pz + qz
    cdef double a = c / 2.0
    cdef double b = c / 6.0  # one division a piece, not three
    rows[r, 0] += nx * a
    rows[r, 1] += ny * a
    rows[r, 2] += nz * a
    rows[r, 3] += (sy * nz - sz * ny) * b
    rows[r, 4] += (sz * nx - sx * nz) * b
    rows[r, 5] += (sx * ny - sy * nx) * b


cdef inline void segment_moments(double[:, ::1] segs, int64_t ncross, MomentRows G) noexcept nogil:
    """Stage "segments" of `hand_moments`: the traced segments' pieces, each on its hand face
    (boundary ``p → q``; its normal and link came with it), added to ``G``'s rows.
    ``segs`` (>= ncross, `tables.SEGMENT_COLUMNS`): the pose's crossing segments
    (`tables.Workspace.segments`), length units."""
    cdef int64_t[::1] state = G.state
    cdef int64_t listed = state[0], pose = state[1], k, lk
    cdef int64_t p = SEGMENT_P, q = SEGMENT_Q, n = SEGMENT_NORMAL
    for k in range(ncross):
        lk = <int64_t>segs[k, SEGMENT_LINK]
        listed = touch(G.stamp, G.touched, listed, pose, lk)
        add_piece(
            G.values, lk, segs[k, n], segs[k, n + 1], segs[k, n + 2], segs[k, p],
            segs[k, p + 1], segs[k, p + 2], segs[k, q], segs[k, q + 1], segs[k, q + 2],
        )
    state[0] = listed


cdef inline int64_t add_edge(
    double[:, ::1] rows, int64_t[::1] stamp, int64_t[::1] touched, int64_t listed,
    int64_t pose, int64_t[:, ::1] elink, double[:, ::1] emom, int64_t e,
) noexcept nogil:
    """Add whole edge ``e``'s shares of its two faces' moments (``emom``) to their rows
    (``elink``), listing the rows (`touch`); returns the rows listed now."""
    cdef int64_t r1 = elink[e, 0], r2 = elink[e, 1], d
    listed = touch(stamp, touched, listed, pose, r1)
    listed = touch(stamp, touched, listed, pose, r2)
    for d in range(MOMENT_COLUMNS):
        rows[r1, d] += emom[e, EDGE_MOMENTS_T1 + d]
        rows[r2, d] += emom[e, EDGE_MOMENTS_T2 + d]
    return listed


cdef inline void whole_edge_moments(
    MeshTables hand_mesh, HandTables hand, MomentTables mom, int8_t[::1] S,
    uint8_t[::1] uniform, MomentRows G,
) noexcept nogil:
    """Stage "whole edges" of `hand_moments`: the whole edges from every inside vertex to
    higher-numbered ones, crossed or not (`crossed_edge_moments` corrects the crossed ones),
    added to ``G``'s rows: one sum per link for a part classified whole (``uniform``) and
    inside (or its marker, `tables.MomentTables.part_from`), one row per inside vertex of the
    other parts (edge by edge at a seam between links; or the vertex's marker,
    `moment_layout.vertex_markers`). Arguments as in `hand_moments`.
    """
    cdef double[:, ::1] rows = G.values
    cdef int64_t[::1] stamp = G.stamp, touched = G.touched, state = G.state
    cdef int64_t[::1] adj_start = hand_mesh.adj_start, adj_vert = hand_mesh.adj_vertex
    cdef int64_t[::1] pstart = mom.part_start, plink = mom.part_link, vlink = mom.vertex_link
    cdef int64_t[:, ::1] reps = hand.parts
    cdef int64_t listed = state[0], pose = state[1], marker = mom.part_from[0]
    cdef int64_t p, j, lk, d, u, k
    for p in range(reps.shape[0] - 1):
        if uniform[p]:
            if S[reps[p, PART_FIRST_VERTEX]] == 1 and marker >= 0:
                listed = touch(stamp, touched, listed, pose, marker + p)
            elif S[reps[p, PART_FIRST_VERTEX]] == 1:
                for j in range(pstart[p], pstart[p + 1]):
                    lk = plink[j]
                    listed = touch(stamp, touched, listed, pose, lk)
                    for d in range(MOMENT_COLUMNS):
                        rows[lk, d] += mom.part_moments[j, d]
            continue
        for u in range(reps[p, PART_FIRST_VERTEX], reps[p + 1, PART_FIRST_VERTEX]):
            if S[u] != 1:
                continue
            lk = vlink[u]
            if lk >= 0 and lk >= marker >= 0:
                # A vertex's marker (`moment_layout.vertex_markers`): nothing to add.
                listed = touch(stamp, touched, listed, pose, lk)
                continue
            if lk >= 0:
                listed = touch(stamp, touched, listed, pose, lk)
                for d in range(MOMENT_COLUMNS):
                    rows[lk, d] += mom.vertex_moments[u, d]
                continue
            for k in range(adj_start[u], adj_start[u + 1]):
                if u >= adj_vert[k]:
                    continue
                listed = add_edge(
                    rows, stamp, touched, listed, pose, mom.edge_links, mom.edge_moments,
                    hand_mesh.adj_edge[k],
                )
    state[0] = listed


cdef inline void _add_interval_share(
    double[:, ::1] V, int64_t[:, ::1] E, int64_t[:, ::1] elink, double[:, ::1] emom,
    int64_t e, double f, double g, double[:, ::1] G,
) noexcept nogil:
    """Add to ``G`` (`tables.MomentRows.values`, both rows touched) the share of edge
    ``e = u → v`` whose inside intervals give ``f = Σ (b - a)`` and
    ``g = Σ (b² - a²) / 3 - f / 3``, on both its faces: for each face, ``f`` times the whole
    edge's share ``(F, M)`` plus ``(0, g (v - u) × F)``. ``V``, ``E``: the mesh's vertices and
    edges; ``elink``, ``emom``: each edge's rows and whole shares
    (`tables.MomentTables.edge_links`, ``edge_moments``, or the object's). ``G`` is written
    through as given: a local view of it would take and drop a reference (two atomic
    operations) per crossed edge."""
    cdef int64_t u = E[e, 0], v = E[e, 1], side, lk, o
    cdef double dx = V[v, 0] - V[u, 0], dy = V[v, 1] - V[u, 1], dz = V[v, 2] - V[u, 2]
    cdef double fx, fy, fz
    for side in range(2):
        lk = elink[e, side]
        o = EDGE_MOMENTS_T2 if side else EDGE_MOMENTS_T1
        fx, fy, fz = emom[e, o], emom[e, o + 1], emom[e, o + 2]
        G[lk, 0] += f * fx
        G[lk, 1] += f * fy
        G[lk, 2] += f * fz
        G[lk, 3] += f * emom[e, o + 3] + g * (dy * fz - dz * fy)
        G[lk, 4] += f * emom[e, o + 4] + g * (dz * fx - dx * fz)
        G[lk, 5] += f * emom[e, o + 5] + g * (dx * fy - dy * fx)


cdef inline Chain _sort_chain(
    double[::1] rec_l, int64_t[::1] chain, int64_t head
) noexcept nogil:
    """The chain of records from ``head`` (linked through ``chain``, -1 ending it) relinked in
    increasing order of their parameters ``rec_l``; returns its new head and its length.
    Insertion sort in the chain's order, as numba's `_sort_small` sorted the parameters copied
    in that order: the list is built largest first and scanned from there, as an array is
    scanned from its end, then reversed (the same order, ties and all)."""
    cdef int64_t k = head, top = -1, n = 0, nxt, prev, cur
    cdef double x
    while k >= 0:
        nxt = chain[k]
        x = rec_l[k]
        prev = -1
        cur = top
        while cur >= 0 and rec_l[cur] > x:
            prev = cur
            cur = chain[cur]
        chain[k] = cur
        if prev < 0:
            top = k
        else:
            chain[prev] = k
        n += 1
        k = nxt
    prev = -1
    k = top
    while k >= 0:
        nxt = chain[k]
        chain[k] = prev
        prev = k
        k = nxt
    return prev, n


cdef inline void _multi_crossed(
    double[:, ::1] V, int64_t[:, ::1] E, int64_t[:, ::1] elink, double[:, ::1] emom,
    int8_t[::1] S, int64_t[::1] cnt, int64_t[::1] rec_e, double[::1] rec_l, int64_t nrec,
    int64_t[::1] chain, double[:, ::1] G,
) noexcept nogil:
    """The edges crossed more than once (chained by `crossed_edge_moments`): each chain's
    parameters sorted (`_sort_chain`), the edge's inside intervals from its lower vertex's
    status, and each edge's count put back into ``cnt`` (``G``:
    `tables.MomentRows.values`, the rows touched)."""
    cdef int64_t i, e, k, n
    cdef bint inside
    cdef double f, h, last, lam
    for i in range(nrec):
        e = rec_e[i]
        if cnt[e] >= 0:
            continue  # crossed once, or its chain already walked
        k, n = _sort_chain(rec_l, chain, -1 - cnt[e])
        cnt[e] = n
        inside = S[E[e, 0]] == 1
        f = 0.0
        h = 0.0
        last = 0.0
        while k >= 0:
            lam = rec_l[k]
            if inside:
                f += lam - last
                h += lam * lam - last * last
            last = lam
            inside = not inside
            k = chain[k]
        if inside:
            f += 1.0 - last
            h += 1.0 - last * last
        if S[E[e, 0]] == 1:
            f -= 1.0
            h -= 1.0
        _add_interval_share(V, E, elink, emom, e, f, (h - f) / 3.0, G)


cdef inline void crossed_edge_moments(
    double[:, ::1] V, int64_t[:, ::1] E, int64_t[:, ::1] elink, double[:, ::1] emom,
    int8_t[::1] S, int64_t[::1] cnt, int64_t[::1] rec_e, double[::1] rec_l, int64_t nrec,
    int64_t[::1] chain, MomentRows G,
) noexcept nogil:
    """Stage "crossed edges" of `hand_moments` (and `_object_moments.object_moments`): each
    crossed edge's inside intervals, less the whole edge added where its lower vertex is
    inside (`whole_edge_moments`), added to ``G`` (arguments as in `hand_moments`, ``chain``
    being its scratch ``multi``; the mesh's ``V``, ``E``, ``elink``, ``emom`` as
    `_add_interval_share` takes them).

    An edge crossed once is inside on ``[0, λ]`` or ``[λ, 1]``. The records of an edge crossed
    more than once are chained through ``chain``, the head's index kept in ``cnt`` (as
    ``-1 - index``) until `_multi_crossed` walks the chain and puts the count back: linear in
    the records, and ``cnt`` is as it was on return.
    """
    cdef int64_t[::1] state = G.state
    cdef int64_t listed = state[0], pose = state[1], chained = 0, i, e, c
    cdef double lam, f
    for i in range(nrec):
        e = rec_e[i]
        c = cnt[e]
        # Rows are marked touched here, where the marks are locals (not per addition).
        listed = touch(G.stamp, G.touched, listed, pose, elink[e, 0])
        listed = touch(G.stamp, G.touched, listed, pose, elink[e, 1])
        if c == 1:
            lam = rec_l[i]
            # Inside on [0, λ] (less the whole edge) or on [λ, 1]: f = ±(1 - λ), and
            # (h - f) / 3 = λ f / 3 either way.
            f = lam - 1.0 if S[E[e, 0]] == 1 else 1.0 - lam
            _add_interval_share(V, E, elink, emom, e, f, lam * f / 3.0, G.values)
            continue
        chain[i] = -1 if c > 0 else -1 - c
        cnt[e] = -1 - i
        chained += 1
    state[0] = listed
    if chained > 0:
        _multi_crossed(V, E, elink, emom, S, cnt, rec_e, rec_l, nrec, chain, G.values)


cdef inline void hand_moments(
    MeshTables hand_mesh, HandTables hand, MomentTables mom, int8_t[::1] S,
    uint8_t[::1] uniform, int64_t[::1] cnt, int64_t[::1] rec_e, double[::1] rec_l,
    int64_t nrec, int64_t[::1] multi, double[:, ::1] segs, int64_t ncross, MomentRows G,
) noexcept nogil:
    """Moments ``(∫ n dA, ∫ x × n dA)`` of each link's boundary inside the object, added to
    ``G``'s rows (L), local coordinates, after a pose's volume pass: `segment_moments`,
    `whole_edge_moments` and `crossed_edge_moments` in turn.

    ``S`` (hand n,) int8: the hand's vertex statuses (1 inside the object); ``uniform``
    (parts,): the parts classified whole; ``cnt`` (hand e,): crossings recorded per hand edge
    (`tables.Workspace.hand_count`), written to and put back; ``rec_e``, ``rec_l``, ``nrec``:
    the records' edges and parameters along ``u → v`` (`tables.Crossings`) and their number;
    ``multi`` (>= nrec,): scratch; ``segs`` (>= ncross, 12): the pose's crossing segments
    (`tables.Workspace.segments`); ``G``: the moments' rows (L), each row touched listed.
    """
    segment_moments(segs, ncross, G)
    whole_edge_moments(hand_mesh, hand, mom, S, uniform, G)
    crossed_edge_moments(
        hand_mesh.vertices, hand_mesh.edges, mom.edge_links, mom.edge_moments, S, cnt, rec_e,
        rec_l, nrec, multi, G,
    )
