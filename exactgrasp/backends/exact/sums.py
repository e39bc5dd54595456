"""The exact kernel's terms and sums (numba): face terms, edge weights, the edge sums and the
pose's volume with its error bound.

The volume of ``A ∩ B`` for closed, outward-oriented triangle meshes is, by the divergence
theorem with the field ``x / 3``,

``V = 1/3 (Σ_{t∈∂A} d_t · area(t ∩ B) + Σ_{s∈∂B} d_s · area(s ∩ A))``, ``d_t = n_t · x_t``.

Writing each clipped area with Green's theorem (``area · n = 1/2 ∮ p × dp``) turns the sum into
three kinds of purely local terms (``D_t = d_t n_t``):

* every edge ``u → v`` (``u < v``) of A, owned by face ``t1`` and shared with ``t2``:
  ``W_e · f_e`` with ``W_e = (D_t1 − D_t2) · (u × v) / 6`` and ``f_e`` the fraction of the
  edge inside B (0 or 1 unless the edge crosses ∂B), and the same for the edges of B;
* every pair of faces ``(t, s)`` that cross, along their common segment ``p → q`` directed as
  ``n_t × n_s``: ``(D_t − D_s) · (p × q) / 6`` (`pairs.segment_term`).

Only the signs of orientation determinants decide which terms appear (`predicates`, `search`,
`classify`); this module adds the terms up. See "Method" and "The volume's bound" in
``docs/exact-backend.md``.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.tables import DEGENERATE, OK, PART_FIRST_VERTEX, WEIGHT, WEIGHT_ERR
from exactgrasp.backends.exact.tolerances import BOUND_SLACK, TERM_ERR, U
from exactgrasp.compiling import inner, kernel


@kernel(nogil=True, error_model="numpy")
def face_terms(V, F, tiny, D, N):
    """Fill per face normal ``N`` (unnormalised) and ``D = (N·a) N / |N|²``, shapes (m, 3).

    ``D`` is set to zero where ``|N|² <= tiny``: such a face adds at most ``|a| sqrt(tiny) / 2``
    to the volume, and skipping it avoids dividing by zero.
    """
    # Scalar loads only: an array view per vertex costs two atomic reference-count updates,
    # which two threads sharing the mesh turn into cache-line contention.
    m = F.shape[0]
    for f in range(m):
        i, j, k = F[f, 0], F[f, 1], F[f, 2]
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
        D[f, 0] = D[f, 1] = D[f, 2] = 0.0
        if nn > tiny:
            s = (n0 * a0 + n1 * a1 + n2 * a2) / nn
            D[f, 0] = s * n0
            D[f, 1] = s * n1
            D[f, 2] = s * n2


@inner(nogil=True, error_model="numpy")
def edge_weight(V, D, E, ET, e, Dcoef, g):
    """``W_e = (D_t1 − D_t2) · (u × v) / 6`` for edge e, and a bound on its error: its
    rounding (`TERM_ERR`) and a third of what each face's rounded ``D`` costs (``Dcoef[t] * g``,
    see `prepare.face_d_coefs`)."""
    i, j = E[e, 0], E[e, 1]
    t1 = ET[e, 0]
    t2 = ET[e, 1]
    cx = V[i, 1] * V[j, 2] - V[i, 2] * V[j, 1]
    cy = V[i, 2] * V[j, 0] - V[i, 0] * V[j, 2]
    cz = V[i, 0] * V[j, 1] - V[i, 1] * V[j, 0]
    w = (
        (D[t1, 0] - D[t2, 0]) * cx + (D[t1, 1] - D[t2, 1]) * cy + (D[t1, 2] - D[t2, 2]) * cz
    ) / 6.0
    dn = abs(D[t1, 0]) + abs(D[t1, 1]) + abs(D[t1, 2]) + abs(D[t2, 0]) + abs(D[t2, 1])
    dn += abs(D[t2, 2])
    ui = max(abs(V[i, 0]), abs(V[i, 1]), abs(V[i, 2]))
    vj = max(abs(V[j, 0]), abs(V[j, 1]), abs(V[j, 2]))
    return w, TERM_ERR * U * dn * ui * vj + (Dcoef[t1] + Dcoef[t2]) * g / 3.0


@inner(nogil=True, error_model="numpy")
def edge_sum(
    V, D, E, ET, S, cnt, Wpre, adj_start, adj_vert, adj_edge, adj_split, reps, uniform, wsum,
    Dcoef, g,
):  # fmt: skip
    """Σ_e W_e over the edges of one mesh that nothing crosses and whose ends are inside;
    returns (sum, error bound, consistent). ``Wpre`` (e, 2) holds precomputed weights and
    their error bounds (fixed mesh) or is empty (weights computed here, with `edge_weight`
    from ``Dcoef`` and the coordinate bound ``g``). The bound adds the rounding of the sum,
    ``U Σ |partial sums|``.

    Consistency: an edge nothing crosses must have ends of one status. Only the edges at
    inside vertices are visited (an edge between two outside vertices adds nothing and is
    consistent), which checks every uncrossed edge. A part classified whole (``uniform``,
    see `classify.hand_statuses`) that is inside adds its own edges' summed weight
    ``wsum[p, WEIGHT]`` (error bound ``wsum[p, WEIGHT_ERR]``; they are uncrossed and
    consistent) and visits only its vertices' edges to other parts, which come first in each
    vertex's adjacency, up to ``adj_split[u]``.
    """
    have = Wpre.shape[0] > 0
    total = 0.0
    err = 0.0
    run = 0.0
    for p in range(reps.shape[0] - 1):
        whole = uniform[p]
        if whole:
            if S[reps[p, PART_FIRST_VERTEX]] != 1:
                continue
            total += wsum[p, WEIGHT]
            err += wsum[p, WEIGHT_ERR]
            run += abs(total)
        for u in range(reps[p, PART_FIRST_VERTEX], reps[p + 1, PART_FIRST_VERTEX]):
            if S[u] != 1:
                continue
            for k in range(adj_start[u], adj_split[u] if whole else adj_start[u + 1]):
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
                    run += abs(total)
    return total, err + U * run, True


@inner(nogil=True, error_model="numpy")
def _order_by_key(key):
    """The permutation that sorts ``key`` (n,) int64, ties by position (a heap sort: numba's
    own sorts cost seconds to compile)."""
    n = key.shape[0]
    order = np.arange(n)
    # Heapify, then move the largest to the end, n times.
    for start in range(n // 2 - 1, -1, -1):
        _sift(key, order, start, n)
    for end in range(n - 1, 0, -1):
        order[0], order[end] = order[end], order[0]
        _sift(key, order, 0, end)
    return order


@inner(nogil=True, error_model="numpy")
def _sift(key, order, root, end):
    """Sift ``order[root]`` down the max-heap ``order[:end]`` ordered by (key, position)."""
    while True:
        child = 2 * root + 1
        if child >= end:
            return
        a, b = order[child], order[child + 1] if child + 1 < end else order[child]
        if child + 1 < end and (key[b] > key[a] or (key[b] == key[a] and b > a)):
            child += 1
            a = b
        r = order[root]
        if key[a] > key[r] or (key[a] == key[r] and a > r):
            order[root], order[child] = a, r
            root = child
        else:
            return


@inner(nogil=True, error_model="numpy")
def crossed_sum(
    V, D, E, ET, S, cnt, rec_e, rec_l, rec_d, nrec, Wpre, multi, epart, uniform, Dcoef, g
):  # fmt: skip
    """Σ_e W_e f_e over the crossed edges of one mesh, f_e the share of edge e inside the
    other mesh (from the recorded crossing parameters ``rec_l`` of edges ``rec_e``, ``cnt[e]``
    of them per edge, each erring by up to ``rec_d``); returns (sum, error bound, consistent):
    the end statuses of each edge must differ by the parity of its crossings. ``Wpre``,
    ``Dcoef`` and ``g`` as in `edge_sum`; the bound holds ``|W_e|`` times the parameters'
    errors, the weights' errors and the sum's rounding.
    An edge crossed once needs no sorting; the records of the others are gathered in
    ``multi`` (scratch, at least ``nrec`` long) and sorted by edge. With parts (``epart`` not
    empty, see `edge_sum`), an edge of a part classified whole must not be crossed (it never
    is: the part's cell would be marked); that too counts as inconsistent."""
    have = Wpre.shape[0] > 0
    parts = epart.shape[0] > 0
    total = 0.0
    err = 0.0
    run = 0.0
    nm = 0
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
        # The branch here, not in a routine taking the arrays: that would cost atomic
        # reference-count updates per record.
        if have:
            we, ee = Wpre[e, WEIGHT], Wpre[e, WEIGHT_ERR]
        else:
            we, ee = edge_weight(V, D, E, ET, e, Dcoef, g)
        total += frac * we
        err += ee + abs(we) * rec_d[i]
        run += abs(total)
    if nm == 0:
        return total, err + 3.0 * U * run, True
    key = np.empty(nm, np.int64)
    for i in range(nm):
        key[i] = rec_e[multi[i]]
    order = _order_by_key(key)
    lam = np.empty(nm)
    i = 0
    while i < nm:
        e = key[order[i]]
        j = i
        dl = 0.0
        while j < nm and key[order[j]] == e:
            # Insertion sort: an edge rarely crosses the other surface more than twice.
            x = rec_l[multi[order[j]]]
            dl += rec_d[multi[order[j]]]
            m = j - i
            while m > 0 and lam[m - 1] > x:
                lam[m] = lam[m - 1]
                m -= 1
            lam[m] = x
            j += 1
        if S[E[e, 1]] != S[E[e, 0]] ^ ((j - i) & 1):
            return 0.0, 0.0, False
        inside = S[E[e, 0]] == 1
        frac = 0.0
        last = 0.0
        for m in range(j - i):
            if inside:
                frac += lam[m] - last
            last = lam[m]
            inside = not inside
        if inside:
            frac += 1.0 - last
        # The branch here, not in a routine taking the arrays: that would cost atomic
        # reference-count updates per record.
        if have:
            we, ee = Wpre[e, WEIGHT], Wpre[e, WEIGHT_ERR]
        else:
            we, ee = edge_weight(V, D, E, ET, e, Dcoef, g)
        total += frac * we
        # Sorting is 1-Lipschitz in each parameter: the alternating sum errs by at most
        # (crossings) times the largest parameter error.
        err += ee + abs(we) * (dl + 4.0 * U) * (j - i)
        run += abs(total)
        i = j
    return total, err + 3.0 * U * run, True


@inner(nogil=True, error_model="numpy")
def volume_sum(hand_mesh, hand, object_mesh, obj, scratch, seg, segerr, gscale, gb):
    """Stage "sum" of a pose (``docs/exact-backend.md``, "Method", the terms and step 6, and
    "The volume's bound; certified zero"): the edge sums of both meshes, each checking its
    edges' end statuses against their crossings, added to the crossing pairs' segment sum
    ``seg`` (error bound ``segerr``), with the pose's error bound.

    Parameters
    ----------
    hand_mesh, object_mesh : tables.MeshTables
        The hand (fixed) and the object (its vertices and ``D`` moved: ``scratch.object_V``,
        ``scratch.object_D``).
    hand : tables.HandTables
    obj : tables.ObjectTables
    scratch : tables.PoseScratch
        The pose's statuses, uniform parts and recorded crossings.
    seg, segerr : float
        Segment terms and their error bound (`search.trace_pairs`).
    gscale, gb : float
        Bounds on every coordinate of the pose, and on the moved object's.

    Returns
    -------
    (volume, bound, code) : (float, float, int)
        A volume within its bound of 0 is 0; one below minus it, or an inconsistent sum, has
        code `DEGENERATE`, else `OK`.
    """
    AV, AD, AE, AET = hand_mesh.vertices, hand.D, hand_mesh.edges, hand_mesh.edge_faces
    BV, BD, BE, BET = scratch.object_V, scratch.object_D, object_mesh.edges, object_mesh.edge_faces
    AS, BS, uniform, multi = (
        scratch.hand_status, scratch.object_status, scratch.uniform, scratch.multi,
    )  # fmt: skip
    W = scratch.work
    acnt, bcnt, arec, brec, nrec = W.hand_count, W.object_count, W.hand_rec, W.object_rec, W.nrec
    sa_, ea, oka = edge_sum(
        AV, AD, AE, AET, AS, acnt, hand.edge_weights, hand_mesh.adj_start,
        hand_mesh.adj_vertex, hand_mesh.adj_edge, hand.adj_split, hand.parts, uniform,
        hand.part_weights, hand.d_cost, gscale,
    )  # fmt: skip
    sa2, ea2, oka2 = crossed_sum(
        AV, AD, AE, AET, AS, acnt, arec.edge, arec.lam, arec.err, nrec[0], hand.edge_weights,
        multi, hand.edge_part, uniform, hand.d_cost, gscale,
    )  # fmt: skip
    sb_, eb, okb = edge_sum(
        BV, BD, BE, BET, BS, bcnt, obj.edge_weights, object_mesh.adj_start,
        object_mesh.adj_vertex, object_mesh.adj_edge, obj.adj_split, obj.parts, obj.whole,
        obj.part_weights, obj.d_cost, gb,
    )  # fmt: skip
    sb2, eb2, okb2 = crossed_sum(
        BV, BD, BE, BET, BS, bcnt, brec.edge, brec.lam, brec.err, nrec[1], obj.edge_weights,
        multi, obj.edge_part, obj.whole, obj.d_cost, gb,
    )  # fmt: skip
    code = OK if (oka and oka2 and okb and okb2) else DEGENERATE
    vol = sa_ + sa2 + sb_ + sb2 + seg
    # The four additions round by at most 4 U times the largest partial sum.
    bound = ea + ea2 + eb + eb2 + segerr
    bound += 4.0 * U * (abs(sa_) + abs(sa2) + abs(sb_) + abs(sb2) + abs(seg))
    bound *= BOUND_SLACK
    if abs(vol) <= bound:
        vol = 0.0
    elif vol < 0.0 and code == OK:
        code = DEGENERATE
    return vol, bound, code
