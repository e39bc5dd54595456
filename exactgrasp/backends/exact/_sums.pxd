# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""The exact kernel's terms and sums, compiled (Cython, inline): face terms, edge weights, the
edge sums and the pose's volume with its error bound; the arithmetic of the
numba stage it replaced, operation for operation.

The volume of ``A ∩ B`` for closed, outward-oriented triangle meshes is, by the divergence
theorem with the field ``x / 3``, a sum of purely local terms (``D_t = d_t n_t``): per edge
``u → v`` of either mesh, owned by face ``t1`` and shared with ``t2``, ``W_e · f_e`` with
``W_e = (D_t1 − D_t2) · (u × v) / 6`` and ``f_e`` the fraction of the edge inside the other
mesh; per pair of crossing faces a segment term (`_search.pxd`). This module adds the edges' terms
up. See "Method" and "The volume's bound" in ``docs/exact-backend.md``.

The edges crossed more than once are sorted in place in the records' scratch ``multi``
(numba sorted a copy): the same order, so the same sums.

The directives above are this file's own: those of a ``.pyx`` that cimports it do not reach
its inline functions (bounds and division checks would stay).
"""

from libc.math cimport fabs
from libc.stdint cimport int8_t, int64_t, uint8_t

from exactgrasp.backends.exact._constants cimport (
    BOUND_SLACK,
    DEGENERATE,
    OK,
    PART_FIRST_VERTEX,
    TERM_ERR,
    U,
    WEIGHT,
    WEIGHT_ERR,
)
from exactgrasp.backends.exact._tables cimport (
    HandTables,
    MeshTables,
    ObjectTables,
    PoseScratch,
)
from exactgrasp.geometry._minmax cimport max2

#: A term and its error bound.
ctypedef (double, double) Term
#: A sum, its error bound, and whether the statuses it read were consistent.
ctypedef (double, double, bint) Sum
#: A pose's volume, its bound and its code (`OK` or `DEGENERATE`).
ctypedef (double, double, int64_t) Volume


cdef inline void face_terms(
    const double[:, ::1] V, const int64_t[:, ::1] F, double tiny, double[:, ::1] D,
    double[:, ::1] N,
) noexcept nogil:
    """Fill per face normal ``N`` (unnormalised) and ``D = (N·a) N / |N|²``, shapes (m, 3),
    of the mesh ``V`` (n, 3), ``F`` (m, 3) (length units).

    ``D`` is set to zero where ``|N|² <= tiny``: such a face adds at most ``|a| sqrt(tiny) / 2``
    to the volume, and skipping it avoids dividing by zero.
    """
    cdef int64_t f, i, j, k
    cdef double a0, a1, a2, b0, b1, b2, c0, c1, c2, n0, n1, n2, nn, s
    for f in range(F.shape[0]):
        i = F[f, 0]
        j = F[f, 1]
        k = F[f, 2]
        a0, a1, a2 = V[i, 0], V[i, 1], V[i, 2]
        b0, b1, b2 = V[j, 0] - a0, V[j, 1] - a1, V[j, 2] - a2
        c0, c1, c2 = V[k, 0] - a0, V[k, 1] - a1, V[k, 2] - a2
        n0 = b1 * c2 - b2 * c1
        n1 = b2 * c0 - b0 * c2
        n2 = b0 * c1 - b1 * c0
        N[f, 0] = n0
        N[f, 1] = n1
        N[f, 2] = n2
        nn = n0 * n0 + n1 * n1 + n2 * n2
        D[f, 0] = 0.0
        D[f, 1] = 0.0
        D[f, 2] = 0.0
        if nn > tiny:
            s = (n0 * a0 + n1 * a1 + n2 * a2) / nn
            D[f, 0] = s * n0
            D[f, 1] = s * n1
            D[f, 2] = s * n2


cdef inline Term edge_weight(
    double[:, ::1] V, double[:, ::1] D, int64_t[:, ::1] E, int64_t[:, ::1] ET, int64_t e,
    double[::1] Dcoef, double g,
) noexcept nogil:
    """``W_e = (D_t1 − D_t2) · (u × v) / 6`` for edge e, and a bound on its error: its
    rounding (`TERM_ERR`) and a third of what each face's rounded ``D`` costs (``Dcoef[t] * g``,
    see `prepare.face_d_coefs`)."""
    cdef int64_t i = E[e, 0], j = E[e, 1], t1 = ET[e, 0], t2 = ET[e, 1]
    cdef double cx = V[i, 1] * V[j, 2] - V[i, 2] * V[j, 1]
    cdef double cy = V[i, 2] * V[j, 0] - V[i, 0] * V[j, 2]
    cdef double cz = V[i, 0] * V[j, 1] - V[i, 1] * V[j, 0]
    cdef double w = (
        (D[t1, 0] - D[t2, 0]) * cx + (D[t1, 1] - D[t2, 1]) * cy + (D[t1, 2] - D[t2, 2]) * cz
    ) / 6.0
    cdef double dn = (
        fabs(D[t1, 0]) + fabs(D[t1, 1]) + fabs(D[t1, 2]) + fabs(D[t2, 0]) + fabs(D[t2, 1])
    )
    dn += fabs(D[t2, 2])
    cdef double ui = max2(max2(fabs(V[i, 0]), fabs(V[i, 1])), fabs(V[i, 2]))
    cdef double vj = max2(max2(fabs(V[j, 0]), fabs(V[j, 1])), fabs(V[j, 2]))
    return w, TERM_ERR * U * dn * ui * vj + (Dcoef[t1] + Dcoef[t2]) * g / 3.0


cdef inline Sum edge_sum(
    double[:, ::1] V, double[:, ::1] D, int64_t[:, ::1] E, int64_t[:, ::1] ET, int8_t[::1] S,
    int64_t[::1] cnt, double[:, ::1] Wpre, int64_t[::1] adj_start, int64_t[::1] adj_vert,
    int64_t[::1] adj_edge, int64_t[::1] adj_split, int64_t[:, ::1] reps, uint8_t[::1] uniform,
    double[:, ::1] wsum, double[::1] Dcoef, double g,
) noexcept nogil:
    """Σ_e W_e over the edges of one mesh that nothing crosses and whose ends are inside;
    returns (sum, error bound, consistent). ``Wpre`` (e, 2) holds precomputed weights and
    their error bounds (fixed mesh) or is empty (weights computed here, with `edge_weight`
    from ``Dcoef`` and the coordinate bound ``g``). The bound adds the rounding of the sum,
    ``U Σ |partial sums|``.

    Consistency: an edge nothing crosses must have ends of one status; only the edges at
    inside vertices are visited. A part classified whole (``uniform``) that is inside adds
    its own edges' summed weight ``wsum[p, WEIGHT]`` (error bound ``wsum[p, WEIGHT_ERR]``) and
    visits only its vertices' edges to other parts, up to ``adj_split[u]``.
    """
    cdef bint have = Wpre.shape[0] > 0, whole
    cdef double total = 0.0, err = 0.0, run = 0.0, we, ee
    cdef int64_t p, u, k, e, w, stop
    for p in range(reps.shape[0] - 1):
        whole = uniform[p]
        if whole:
            if S[reps[p, PART_FIRST_VERTEX]] != 1:
                continue
            total += wsum[p, WEIGHT]
            err += wsum[p, WEIGHT_ERR]
            run += fabs(total)
        for u in range(reps[p, PART_FIRST_VERTEX], reps[p + 1, PART_FIRST_VERTEX]):
            if S[u] != 1:
                continue
            stop = adj_split[u] if whole else adj_start[u + 1]
            for k in range(adj_start[u], stop):
                e = adj_edge[k]
                if cnt[e] != 0:
                    continue
                w = adj_vert[k]
                if S[w] != 1:
                    return 0.0, 0.0, False
                if u < w:
                    if have:
                        total += Wpre[e, WEIGHT]
                        err += Wpre[e, WEIGHT_ERR]
                    else:
                        we, ee = edge_weight(V, D, E, ET, e, Dcoef, g)
                        total += we
                        err += ee
                    run += fabs(total)
    return total, err + U * run, True


cdef inline void _sift(
    int64_t[::1] key, int64_t[::1] order, int64_t root, int64_t end
) noexcept nogil:
    """Sift ``order[root]`` down the max-heap ``order[:end]`` ordered by (key, index)."""
    cdef int64_t child, a, b, r
    while True:
        child = 2 * root + 1
        if child >= end:
            return
        a = order[child]
        b = order[child + 1] if child + 1 < end else order[child]
        if child + 1 < end and (key[b] > key[a] or (key[b] == key[a] and b > a)):
            child += 1
            a = b
        r = order[root]
        if key[a] > key[r] or (key[a] == key[r] and a > r):
            order[root] = a
            order[child] = r
            root = child
        else:
            return


cdef inline void _order_by_key(int64_t[::1] key, int64_t[::1] order, int64_t n) noexcept nogil:
    """Sort ``order[:n]`` (distinct indices into ``key``, int64) in place by (key, index): a
    heap sort, numba's step for step where ``order`` starts increasing (numba sorted the
    positions ``0..n-1`` by (key of the index there, position): the same decisions)."""
    cdef int64_t start, end, tmp
    # Heapify, then move the largest to the end, n times.
    for start in range(n // 2 - 1, -1, -1):
        _sift(key, order, start, n)
    for end in range(n - 1, 0, -1):
        tmp = order[0]
        order[0] = order[end]
        order[end] = tmp
        _sift(key, order, 0, end)


cdef inline Sum _multi_sum(
    double[:, ::1] V, double[:, ::1] D, int64_t[:, ::1] E, int64_t[:, ::1] ET, int8_t[::1] S,
    int64_t[::1] rec_e, double[::1] rec_l, double[::1] rec_d, double[:, ::1] Wpre,
    int64_t[::1] multi, int64_t nm, double[::1] Dcoef, double g, double total, double err,
    double run,
) noexcept nogil:
    """The rest of `crossed_sum` (its sums so far ``total``, ``err``, ``run``): the edges
    crossed more than once, whose ``nm`` records ``multi`` lists in increasing order. The
    records are sorted in place by edge, then each edge's by parameter (insertion sort in
    record order, as numba sorted a copy of the parameters: the same values in the same
    order)."""
    cdef bint have = Wpre.shape[0] > 0, inside
    cdef int64_t i = 0, j, m, e, r
    cdef double dl, x, frac, last, we, ee
    _order_by_key(rec_e, multi, nm)
    while i < nm:
        e = rec_e[multi[i]]
        j = i
        dl = 0.0
        while j < nm and rec_e[multi[j]] == e:
            # Insertion sort: an edge rarely crosses the other surface more than twice.
            r = multi[j]
            x = rec_l[r]
            dl += rec_d[r]
            m = j
            while m > i and rec_l[multi[m - 1]] > x:
                multi[m] = multi[m - 1]
                m -= 1
            multi[m] = r
            j += 1
        if S[E[e, 1]] != S[E[e, 0]] ^ ((j - i) & 1):
            return 0.0, 0.0, False
        inside = S[E[e, 0]] == 1
        frac = 0.0
        last = 0.0
        for m in range(i, j):
            if inside:
                frac += rec_l[multi[m]] - last
            last = rec_l[multi[m]]
            inside = not inside
        if inside:
            frac += 1.0 - last
        if have:
            we, ee = Wpre[e, WEIGHT], Wpre[e, WEIGHT_ERR]
        else:
            we, ee = edge_weight(V, D, E, ET, e, Dcoef, g)
        total += frac * we
        # Sorting is 1-Lipschitz in each parameter: the alternating sum errs by at most
        # (crossings) times the largest parameter error.
        err += ee + fabs(we) * (dl + 4.0 * U) * (j - i)
        run += fabs(total)
        i = j
    return total, err + 3.0 * U * run, True


cdef inline Sum crossed_sum(
    double[:, ::1] V, double[:, ::1] D, int64_t[:, ::1] E, int64_t[:, ::1] ET, int8_t[::1] S,
    int64_t[::1] cnt, int64_t[::1] rec_e, double[::1] rec_l, double[::1] rec_d, int64_t nrec,
    double[:, ::1] Wpre, int64_t[::1] multi, int64_t[::1] epart, uint8_t[::1] uniform,
    double[::1] Dcoef, double g,
) noexcept nogil:
    """Σ_e W_e f_e over the crossed edges of one mesh, f_e the share of edge e inside the
    other mesh (from the recorded crossing parameters ``rec_l`` of edges ``rec_e``, ``cnt[e]``
    of them per edge, each erring by up to ``rec_d``); returns (sum, error bound, consistent):
    the end statuses of each edge must differ by the parity of its crossings. ``Wpre``,
    ``Dcoef`` and ``g`` as in `edge_sum`; the bound holds ``|W_e|`` times the parameters'
    errors, the weights' errors and the sum's rounding.
    An edge crossed once needs no sorting; the records of the others are gathered in
    ``multi`` (scratch, at least ``nrec`` long) for `_multi_sum`. With parts (``epart`` not
    empty), an edge of a part classified whole must not be crossed (it never is: the part's
    cell would be marked); that too counts as inconsistent."""
    cdef bint have = Wpre.shape[0] > 0, parts = epart.shape[0] > 0
    cdef double total = 0.0, err = 0.0, run = 0.0, frac, we, ee
    cdef int64_t nm = 0, i, e
    cdef int8_t s0
    for i in range(nrec):
        e = rec_e[i]
        if parts and epart[e] >= 0 and uniform[epart[e]]:
            return 0.0, 0.0, False
        if cnt[e] != 1:
            multi[nm] = i
            nm += 1
            continue
        s0 = S[E[e, 0]]
        if S[E[e, 1]] == s0:
            return 0.0, 0.0, False
        frac = rec_l[i] if s0 == 1 else 1.0 - rec_l[i]
        if have:
            we, ee = Wpre[e, WEIGHT], Wpre[e, WEIGHT_ERR]
        else:
            we, ee = edge_weight(V, D, E, ET, e, Dcoef, g)
        total += frac * we
        err += ee + fabs(we) * rec_d[i]
        run += fabs(total)
    if nm == 0:
        return total, err + 3.0 * U * run, True
    return _multi_sum(
        V, D, E, ET, S, rec_e, rec_l, rec_d, Wpre, multi, nm, Dcoef, g, total, err, run
    )


cdef inline Volume volume_sum(
    MeshTables hand_mesh, HandTables hand, MeshTables object_mesh, ObjectTables obj,
    PoseScratch scratch, double seg, double segerr, double gscale, double gb,
) noexcept nogil:
    """Stage "sum" of a pose (``docs/exact-backend.md``, "Method", the terms and step 6, and
    "The volume's bound; certified zero"): the edge sums of both meshes, each checking its
    edges' end statuses against their crossings, added to the crossing pairs' segment sum
    ``seg`` (error bound ``segerr``), with the pose's error bound.

    ``hand_mesh``, ``object_mesh``: the hand (fixed) and the object (its vertices and ``D``
    moved: ``scratch.object_V``, ``scratch.object_D``); ``scratch``: the pose's statuses,
    uniform parts and recorded crossings; ``gscale``, ``gb``: bounds on every coordinate of
    the pose, and on the moved object's. Returns (volume, bound, code): a volume within its
    bound of 0 is 0; one below minus it, or an inconsistent sum, has code `DEGENERATE`, else
    `OK`.
    """
    cdef double sa_, ea, sa2, ea2, sb_, eb, sb2, eb2, vol, bound
    cdef bint oka, oka2, okb, okb2
    cdef int64_t code
    cdef int64_t[::1] nrec = scratch.work.nrec
    sa_, ea, oka = edge_sum(
        hand_mesh.vertices, hand.D, hand_mesh.edges, hand_mesh.edge_faces, scratch.hand_status,
        scratch.work.hand_count, hand.edge_weights, hand_mesh.adj_start, hand_mesh.adj_vertex,
        hand_mesh.adj_edge, hand.adj_split, hand.parts, scratch.uniform, hand.part_weights,
        hand.d_cost, gscale,
    )
    sa2, ea2, oka2 = crossed_sum(
        hand_mesh.vertices, hand.D, hand_mesh.edges, hand_mesh.edge_faces, scratch.hand_status,
        scratch.work.hand_count, scratch.work.hand_rec.edge, scratch.work.hand_rec.lam,
        scratch.work.hand_rec.err, nrec[0], hand.edge_weights, scratch.multi, hand.edge_part,
        scratch.uniform, hand.d_cost, gscale,
    )
    sb_, eb, okb = edge_sum(
        scratch.object_V, scratch.object_D, object_mesh.edges, object_mesh.edge_faces,
        scratch.object_status, scratch.work.object_count, obj.edge_weights,
        object_mesh.adj_start, object_mesh.adj_vertex, object_mesh.adj_edge, obj.adj_split,
        obj.parts, obj.whole, obj.part_weights, obj.d_cost, gb,
    )
    sb2, eb2, okb2 = crossed_sum(
        scratch.object_V, scratch.object_D, object_mesh.edges, object_mesh.edge_faces,
        scratch.object_status, scratch.work.object_count, scratch.work.object_rec.edge,
        scratch.work.object_rec.lam, scratch.work.object_rec.err, nrec[1], obj.edge_weights,
        scratch.multi, obj.edge_part, obj.whole, obj.d_cost, gb,
    )
    code = OK if (oka and oka2 and okb and okb2) else DEGENERATE
    vol = sa_ + sa2 + sb_ + sb2 + seg
    # The four additions round by at most 4 U times the largest partial sum.
    bound = ea + ea2 + eb + eb2 + segerr
    bound += 4.0 * U * (fabs(sa_) + fabs(sa2) + fabs(sb_) + fabs(sb2) + fabs(seg))
    bound *= BOUND_SLACK
    if fabs(vol) <= bound:
        vol = 0.0
    elif vol < 0.0 and code == OK:
        code = DEGENERATE
    return vol, bound, code
