"""Numba kernel computing hand ∩ moved object for a batch of poses (see `_exact_kernels`).

Meshes travel as tuples (built by `_exact_geometry.prepare_mesh`)::

    mesh = (V, F, E, ET, TE, TO, adj_start, adj_vert, adj_edge)
    grid = (lo, h, n, status, cell_start, cell_tris)

``E`` (e, 2) are the undirected edges ``u < v``; ``ET`` (e, 2) their faces ``t1`` (holding the
directed edge ``u → v``) and ``t2``; ``TE`` (m, 3) the edge of each face corner ``k → k+1`` and
``TO`` (m, 3) whether that face is the edge's ``t1``. The grid's ``status`` is 1 (inside),
0 (outside) or -1 (a cell touched by the surface), ``cell_start``/``cell_tris`` list the
faces touching each cell.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from exactgrasp.backends.exact.kernels import (
    U,
    cell_index,
    edge_weight_err,
    face_terms,
    plane_err_coef,
    point_status,
    ray_status,
    surface_cells_in,
    tri_box_xyz,
    tri_cell_range,
)
from exactgrasp.backends.exact.pairs import (
    crossing_starts,
    pair,
    param_err,
    point_err,
    segment_term,
)

#: Object faces are first tested in runs of this many consecutive faces (see `_near_chunks`).
CHUNK = 16
#: Rounding of the projections on the common line, in units of U |direction|_1 G: each
#: projection errs by 3.1, the interpolation by twice that; taken as 16.
LINE_ROUNDING = 16.0
#: The common-line comparisons' own rounding (relative, far below this).
LINE_SLACK = 1.0 + 1e-6
#: A pose's volume is certified zero within its error bound times this (the bound's own
#: rounding, relative, is far below it).
BOUND_SLACK = 1.0 + 1e-6
#: Per-pose result codes.
OK, CULLED, DEGENERATE, OVERFLOW = 0, 1, 2, 3
#: Columns of the per-pose statistics array.
STAT_PAIRS, STAT_CROSSING, STAT_CELLS_TOUCHED, STAT_CELLS_INSIDE, STAT_CELLS_OUTSIDE = range(5)
N_STATS = 5


@njit(cache=True, nogil=True, error_model="numpy")
def _spread(S, adj_start, adj_vert, adj_edge, cnt, queue, tail):
    """Breadth-first from the ``tail`` vertices in ``queue``: every unknown (-1) neighbour
    takes the status of the vertex it is reached from, flipped by the parity of the crossings
    on the edge between them."""
    head = 0
    while head < tail:
        u = queue[head]
        head += 1
        for k in range(adj_start[u], adj_start[u + 1]):
            w = adj_vert[k]
            if S[w] == -1:
                S[w] = S[u] ^ (cnt[adj_edge[k]] & 1)
                queue[tail] = w
                tail += 1


@njit(cache=True, nogil=True, error_model="numpy")
def _next_unknown(S, start, reps, uniform):
    """The first vertex at or after ``start`` whose status is unknown (-1), or -1. Parts
    classified whole (``uniform``, see `_hand_statuses`) are known and skipped."""
    for k in range(reps.shape[0] - 1):
        if uniform[k] or reps[k + 1, 1] <= start:
            continue
        for u in range(max(start, reps[k, 1]), reps[k + 1, 1]):
            if S[u] == -1:
                return u
    return -1


@njit(cache=True, nogil=True, error_model="numpy")
def _resolve(S, adj_start, adj_vert, adj_edge, cnt, queue, reps, uniform):
    """Give every vertex of unknown status (-1) the status of a neighbour, flipped by the
    parity of the crossings on the edge between them. Returns the first vertex still unknown
    (its component has no vertex of known status), or -1. Only the parts (``reps``, see
    `ExactIntersector._cell_reps`) not classified whole (``uniform``) are searched."""
    tail = 0
    for p in range(reps.shape[0] - 1):
        if uniform[p]:
            continue
        for u in range(reps[p, 1], reps[p + 1, 1]):
            if S[u] != -1:
                continue
            for k in range(adj_start[u], adj_start[u + 1]):
                w = adj_vert[k]
                if S[w] >= 0:
                    S[u] = S[w] ^ (cnt[adj_edge[k]] & 1)
                    queue[tail] = u
                    tail += 1
                    break
    _spread(S, adj_start, adj_vert, adj_edge, cnt, queue, tail)
    return _next_unknown(S, 0, reps, uniform)


@njit(cache=True, nogil=True, error_model="numpy")
def _edge_sum(
    V, D, E, ET, S, cnt, Wpre, adj_start, adj_vert, adj_edge, adj_split, reps, uniform, wsum,
    Dcoef, g,
):  # fmt: skip
    """Σ_e W_e over the edges of one mesh that nothing crosses and whose ends are inside;
    returns (sum, error bound, consistent). ``Wpre`` (e, 2) holds precomputed weights and
    their error bounds (fixed mesh) or is empty (weights computed here, with `edge_weight_err`
    from ``Dcoef`` and the coordinate bound ``g``). The bound adds the rounding of the sum,
    ``U Σ |partial sums|``.

    Consistency: an edge nothing crosses must have ends of one status. Only the edges at
    inside vertices are visited (an edge between two outside vertices adds nothing and is
    consistent), which checks every uncrossed edge. A part classified whole (``uniform``,
    see `_hand_statuses`) that is inside adds its own edges' summed weight ``wsum[p, 0]``
    (error bound ``wsum[p, 1]``; they are uncrossed and consistent) and visits only its
    vertices' edges to other parts, which come first in each vertex's adjacency, up to
    ``adj_split[u]``.
    """
    have = Wpre.shape[0] > 0
    total = 0.0
    err = 0.0
    run = 0.0
    for p in range(reps.shape[0] - 1):
        whole = uniform[p]
        if whole:
            if S[reps[p, 1]] != 1:
                continue
            total += wsum[p, 0]
            err += wsum[p, 1]
            run += abs(total)
        for u in range(reps[p, 1], reps[p + 1, 1]):
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
                        total += Wpre[e, 0]
                        err += Wpre[e, 1]
                    else:
                        we, ee = edge_weight_err(V, D, E, ET, e, Dcoef, g)
                        total += we
                        err += ee
                    run += abs(total)
    return total, err + U * run, True


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _weight(V, D, E, ET, e, Wpre, have, Dcoef, g):
    if have:
        return Wpre[e, 0], Wpre[e, 1]
    return edge_weight_err(V, D, E, ET, e, Dcoef, g)


@njit(cache=True, nogil=True, error_model="numpy")
def _crossed_sum(
    V, D, E, ET, S, cnt, rec_e, rec_l, rec_d, nrec, Wpre, multi, epart, uniform, Dcoef, g
):  # fmt: skip
    """Σ_e W_e f_e over the crossed edges of one mesh, f_e the share of edge e inside the
    other mesh (from the recorded crossing parameters ``rec_l`` of edges ``rec_e``, ``cnt[e]``
    of them per edge, each erring by up to ``rec_d``); returns (sum, error bound, consistent):
    the end statuses of each edge must differ by the parity of its crossings. ``Wpre``,
    ``Dcoef`` and ``g`` as in `_edge_sum`; the bound holds ``|W_e|`` times the parameters'
    errors, the weights' errors and the sum's rounding.
    An edge crossed once needs no sorting; the records of the others are gathered in
    ``multi`` (scratch, at least ``nrec`` long) and sorted by edge. With parts (``epart`` not
    empty, see `_edge_sum`), an edge of a part classified whole must not be crossed (it never
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
        we, ee = _weight(V, D, E, ET, e, Wpre, have, Dcoef, g)
        total += frac * we
        err += ee + abs(we) * rec_d[i]
        run += abs(total)
    if nm == 0:
        return total, err + 3.0 * U * run, True
    key = np.empty(nm, np.int64)
    for i in range(nm):
        key[i] = rec_e[multi[i]]
    order = np.argsort(key)
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
        we, ee = _weight(V, D, E, ET, e, Wpre, have, Dcoef, g)
        total += frac * we
        # Sorting is 1-Lipschitz in each parameter: the alternating sum errs by at most
        # (crossings) times the largest parameter error.
        err += ee + abs(we) * (dl + 4.0 * U) * (j - i)
        run += abs(total)
        i = j
    return total, err + 3.0 * U * run, True


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sgn(x):
    return 1 if x > 0 else -1


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _box_meets_face(
    x0, y0, z0, x1, y1, z1, smin0, smin1, smin2, smax0, smax1, smax2, hx, hy, hz, sd, tol
):
    """Whether the box [x0, x1] × [y0, y1] × [z0, z1] may meet an object face: its box
    (smin*, smax*, already grown by the margin) and its plane (unit normal 2 (hx, hy, hz),
    offset sd; tolerance tol) are no separating axes. Evaluated in full, without branches (the
    outcome is hard to predict, see `_object_faces`)."""
    return (
        (x0 <= smax0)
        & (x1 >= smin0)
        & (y0 <= smax1)
        & (y1 >= smin1)
        & (z0 <= smax2)
        & (z1 >= smin2)
        & (
            abs(hx * (x0 + x1) + hy * (y0 + y1) + hz * (z0 + z1) - sd)
            <= abs(hx) * (x1 - x0) + abs(hy) * (y1 - y0) + abs(hz) * (z1 - z0) + tol
        )
    )


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _lone(d0, d1, d2):
    """Index of the vertex alone on its side of a plane (signed distances d*, none zero,
    not all of one sign): the two edges from it are the ones that cross the plane."""
    if (d0 > 0) == (d1 > 0):
        return 2
    if (d0 > 0) == (d2 > 0):
        return 1
    return 0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _on_line(x0, x1, x2, d0, d1, d2, k, span, err, rho):
    """Where a triangle's two crossing edges meet a plane, projected on a direction (that of
    the plane's line with another plane, as computed): (a, b, error bound), a on the edge from
    the lone vertex k to corner k + 1 (face corner k's edge), b on the edge from k to corner
    k + 2 (corner k + 2's edge). x* are the vertices' projections on that direction, d* their
    signed distances to the plane, all farther than twice their error bound ``err``; ``span``
    bounds every projected difference of the corners, ``rho`` the projections' rounding."""
    if k == 0:
        xk, xi, xj, dk, di, dj = x0, x1, x2, d0, d1, d2
    elif k == 1:
        xk, xi, xj, dk, di, dj = x1, x2, x0, d1, d2, d0
    else:
        xk, xi, xj, dk, di, dj = x2, x0, x1, d2, d0, d1
    ri = 1.0 / (abs(dk) + abs(di))
    rj = 1.0 / (abs(dk) + abs(dj))
    a = xk + (xi - xk) * (abs(dk) * ri)
    b = xk + (xj - xk) * (abs(dk) * rj)
    # The exact point's projection is xk + lam* (xi - xk) with |lam - lam*| <= 4 err ri
    # (`param_err`), so a errs by span times that, plus the rounding of the projections.
    return a, b, span * (4.0 * err * max(ri, rj) + 4.0 * U) + rho


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _pick(d0, d1, d2, k):
    return d0 if k == 0 else (d1 if k == 1 else d2)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _crossing(u, v, du, dv):
    """Edge uv (signed distances du, dv to a plane, of opposite signs) meets the plane at
    ``x_u + lam (x_v - x_u)``: (u, v, lam) with the lower vertex index first, as in `pair`,
    so that both faces of an edge compute the same point."""
    if u > v:
        u, v, du, dv = v, u, dv, du
    return u, v, du / (du - dv)


@njit(cache=True, nogil=True, error_model="numpy")
def _object_faces(A, X, agrid, B, BV, BD, BN, W, margin, ptol, gscale, stamp0, near, Bdc, gb):
    """All terms of the object's faces against the hand: finds the hand faces each may cross
    through the hand's cell grid and evaluates each pair. Returns (segment sum, its error
    bound, crossings, pairs tried, code); stops at the first degenerate pair or overflow.

    Every floating-point decision has a tolerance at least twice its error bound: a plane
    test of a face with the face's own bound (`plane_err_coef` of its conditioning, times the
    coordinate bound ``gscale``; hand faces' coefficients in ``AP[:, 4]``), at least ``ptol``;
    the box and walk filters likewise. ``Bdc`` (object faces) and ``AP[:, 5]`` (hand faces,
    absolute) are what each face's rounded ``D`` costs its terms (`face_d_coef`), ``gb`` the
    object's coordinate bound.

    The loop over faces lives here, not in the caller, so that the tuples are unpacked once
    per pose: unpacking them per face cost more than the whole search."""
    AV, AF, ATE, ATO = A[0], A[1], A[4], A[5]
    BTE, BTO = B[4], B[5]
    AD, CBB, AP, nxt, PT = X[0], X[6], X[3], X[7], X[8]
    alo, ah, an, acs, act, atable = agrid[0], agrid[1], agrid[2], agrid[4], agrid[5], agrid[6]
    iah = 1.0 / ah
    acnt, bcnt, arec, brec, nrec, stamp, P, sg, dt, rng, cellmark, buf = W
    arec_e, arec_l, arec_d = arec[0], arec[1], arec[2]
    brec_e, brec_l, brec_d = brec[0], brec[1], brec[2]
    cap = arec_e.shape[0]
    BF = B[1]
    seg = 0.0
    segerr = 0.0
    run = 0.0
    ncross = 0
    npairs = 0
    for s in range(BF.shape[0]):
        if not near[s // CHUNK]:
            continue
        if not tri_cell_range(BV, BF, s, alo, ah, an, margin, rng):
            continue
        if surface_cells_in(atable, an, rng) == 0:
            continue
        # Corners as scalars: array views in these loops would cost atomic reference counts.
        i0, i1, i2 = BF[s, 0], BF[s, 1], BF[s, 2]
        sa0, sa1, sa2 = BV[i0, 0], BV[i0, 1], BV[i0, 2]
        sb0, sb1, sb2 = BV[i1, 0], BV[i1, 1], BV[i1, 2]
        sc0, sc1, sc2 = BV[i2, 0], BV[i2, 1], BV[i2, 2]
        smax0 = max(sa0, sb0, sc0) + margin
        smax1 = max(sa1, sb1, sc1) + margin
        smax2 = max(sa2, sb2, sc2) + margin
        smin0 = min(sa0, sb0, sc0) - margin
        smin1 = min(sa1, sb1, sc1) - margin
        smin2 = min(sa2, sb2, sc2) - margin
        nrm = np.sqrt(BN[s, 0] ** 2 + BN[s, 1] ** 2 + BN[s, 2] ** 2)
        inv = 1.0 / nrm if nrm > 0 else 0.0
        # The face's conditioning |b - a| |c - a| / |N| widens its tolerances (slivers).
        l1 = (sb0 - sa0) ** 2 + (sb1 - sa1) ** 2 + (sb2 - sa2) ** 2
        l2 = (sc0 - sa0) ** 2 + (sc1 - sa1) ** 2 + (sc2 - sa2) ** 2
        eps_s = plane_err_coef(np.sqrt(l1 * l2) * inv if nrm > 0 else np.inf) * gscale
        tol_e = max(ptol, 2.0 * eps_s)
        beta_s = Bdc[s] * gb
        nx, ny, nz = BN[s, 0] * inv, BN[s, 1] * inv, BN[s, 2] * inv
        hx, hy, hz = 0.5 * nx, 0.5 * ny, 0.5 * nz
        sd = nx * sa0 + ny * sa1 + nz * sa2
        # Walk the columns along the normal's dominant axis d and visit only the cells the face's
        # plane passes through (with a margin); the separating-axis test then decides.
        d = 0
        if abs(ny) > abs(nx):
            d = 1
        if abs(nz) > max(abs(nx), abs(ny)):
            d = 2
        a = (d + 1) % 3
        b = (d + 2) % 3
        nd = nx if d == 0 else (ny if d == 1 else nz)
        na_ = nx if a == 0 else (ny if a == 1 else nz)
        nb_ = nx if b == 0 else (ny if b == 1 else nz)
        stride_a = an[1] * an[2] if a == 0 else (an[2] if a == 1 else 1)
        stride_b = an[1] * an[2] if b == 0 else (an[2] if b == 1 else 1)
        stride_d = an[1] * an[2] if d == 0 else (an[2] if d == 1 else 1)
        # Over a column's cross-section (grown by the margin) the plane's coordinate along d
        # spans its value at the centre plus or minus `spread`.
        inv_nd = 1.0 / nd if nrm > 0 else 0.0
        spread = (abs(na_) + abs(nb_)) * abs(inv_nd) * (0.5 * ah + margin)
        slack = max(1e-6 * ah, 4.0 * eps_s)
        for ia in range(rng[a, 0], rng[a, 1] + 1):
            za = sd - na_ * (alo[a] + (ia + 0.5) * ah)
            for ib in range(rng[b, 0], rng[b, 1] + 1):
                d0, d1 = rng[d, 0], rng[d, 1]
                if nrm > 0:
                    z = (za - nb_ * (alo[b] + (ib + 0.5) * ah)) * inv_nd
                    d0 = max(d0, int(np.floor((z - spread - slack - alo[d]) * iah)))
                    d1 = min(d1, int(np.floor((z + spread + slack - alo[d]) * iah)))
                base = ia * stride_a + ib * stride_b
                # Only the cells holding hand faces: `nxt` jumps to the next one along d.
                cur = nxt[d, base + d0 * stride_d] if d0 <= d1 else an[d]
                while cur <= d1:
                    c = base + cur * stride_d
                    cur = nxt[d, c + stride_d] if cur + 1 < an[d] else an[d]
                    # Separating axes between the face and what the cell holds of the faces it
                    # lists (cheapest first): the coordinate axes against the listed faces'
                    # common bounding box clipped to the cell, the listed faces' mean normal (a
                    # thin slab where the hand's surface is nearly flat), the face's own normal
                    # against that box, all with one branch (each alone would often
                    # mispredict); last the face's edges against the box (`tri_box`). A crossing
                    # outside this cell is found in another cell that both faces touch.
                    x0, y0, z0 = PT[c, 5], PT[c, 6], PT[c, 7]
                    x1, y1, z1 = PT[c, 8], PT[c, 9], PT[c, 10]
                    pa0 = PT[c, 0] * sa0 + PT[c, 1] * sa1 + PT[c, 2] * sa2
                    pa1 = PT[c, 0] * sb0 + PT[c, 1] * sb1 + PT[c, 2] * sb2
                    pa2 = PT[c, 0] * sc0 + PT[c, 1] * sc1 + PT[c, 2] * sc2
                    ok = (
                        _box_meets_face(
                            x0, y0, z0, x1, y1, z1, smin0, smin1, smin2, smax0, smax1, smax2,
                            hx, hy, hz, sd, max(margin, 2.0 * eps_s),
                        )
                        & (min(pa0, pa1, pa2) <= PT[c, 4])
                        & (max(pa0, pa1, pa2) >= PT[c, 3])
                    )  # fmt: skip
                    if not ok:
                        continue
                    if not tri_box_xyz(
                        0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1),
                        0.5 * (x1 - x0) + margin, 0.5 * (y1 - y0) + margin,
                        0.5 * (z1 - z0) + margin,
                        sa0, sa1, sa2, sb0, sb1, sb2, sc0, sc1, sc2,
                    ):  # fmt: skip
                        continue
                    cellmark[c] = True
                    # The listed faces' boxes against the object face's box and plane, without
                    # branches (half of them pass: a branch per test would mispredict); the
                    # survivors are gathered in `buf`.
                    m = 0
                    for q in range(acs[c], acs[c + 1]):
                        x0, y0, z0 = CBB[q, 0], CBB[q, 1], CBB[q, 2]
                        x1, y1, z1 = CBB[q, 3], CBB[q, 4], CBB[q, 5]
                        ok = _box_meets_face(
                            x0, y0, z0, x1, y1, z1, smin0, smin1, smin2, smax0, smax1, smax2,
                            hx, hy, hz, sd, max(2.0 * ptol, 2.0 * eps_s),
                        )  # fmt: skip
                        buf[m] = q
                        m += 1 if ok else 0
                    for j in range(m):
                        q = buf[j]
                        ft = act[q]
                        if stamp[ft] == stamp0 + s:
                            continue
                        stamp[ft] = stamp0 + s
                        # Both faces against the other's plane in floating point, with a tolerance
                        # far above rounding; the exact tests follow in _pair.
                        v0, v1, v2 = AF[ft, 0], AF[ft, 1], AF[ft, 2]
                        e0 = AV[v0, 0] * nx + AV[v0, 1] * ny + AV[v0, 2] * nz - sd
                        e1 = AV[v1, 0] * nx + AV[v1, 1] * ny + AV[v1, 2] * nz - sd
                        e2 = AV[v2, 0] * nx + AV[v2, 1] * ny + AV[v2, 2] * nz - sd
                        if ((e0 > tol_e) & (e1 > tol_e) & (e2 > tol_e)) | (
                            (e0 < -tol_e) & (e1 < -tol_e) & (e2 < -tol_e)
                        ):
                            continue
                        f0 = sa0 * AP[ft, 0] + sa1 * AP[ft, 1] + sa2 * AP[ft, 2] - AP[ft, 3]
                        f1 = sb0 * AP[ft, 0] + sb1 * AP[ft, 1] + sb2 * AP[ft, 2] - AP[ft, 3]
                        f2 = sc0 * AP[ft, 0] + sc1 * AP[ft, 1] + sc2 * AP[ft, 2] - AP[ft, 3]
                        eps_t = AP[ft, 4] * gscale
                        tol_f = max(ptol, 2.0 * eps_t)
                        if ((f0 > tol_f) & (f1 > tol_f) & (f2 > tol_f)) | (
                            (f0 < -tol_f) & (f1 < -tol_f) & (f2 < -tol_f)
                        ):
                            continue
                        # Both planes straddled and every vertex clear of the other plane:
                        # the faces' crossing segments on the planes' common line decide in
                        # floating point where every end of one is far (beyond rounding) from
                        # both ends of the other. Anything closer goes to the exact `pair`.
                        # Scalars only in here: passing arrays to a function that is not
                        # inlined costs atomic reference counts on every call.
                        sided = (min(abs(e0), abs(e1), abs(e2)) > tol_e) & (
                            min(abs(f0), abs(f1), abs(f2)) > tol_f
                        )
                        if sided:
                            ux, uy, uz = AP[ft, 0], AP[ft, 1], AP[ft, 2]
                            Dx = uy * nz - uz * ny
                            Dy = uz * nx - ux * nz
                            Dz = ux * ny - uy * nx
                            t0x, t0y, t0z = AV[v0, 0], AV[v0, 1], AV[v0, 2]
                            t1x, t1y, t1z = AV[v1, 0], AV[v1, 1], AV[v1, 2]
                            t2x, t2y, t2z = AV[v2, 0], AV[v2, 1], AV[v2, 2]
                            # Extent of the six corners (the object face's by its box).
                            ext = max(
                                max(smax0, t0x, t1x, t2x) - min(smin0, t0x, t1x, t2x),
                                max(smax1, t0y, t1y, t2y) - min(smin1, t0y, t1y, t2y),
                                max(smax2, t0z, t1z, t2z) - min(smin2, t0z, t1z, t2z),
                            )
                            # Any direction serves: the four points lie on the common line,
                            # so their order along it is their order here (or reversed).
                            dnorm = abs(Dx) + abs(Dy) + abs(Dz)
                            span = ext * dnorm
                            rho = LINE_ROUNDING * U * dnorm * gscale
                            kt = _lone(e0, e1, e2)
                            at, bt, errt = _on_line(
                                Dx * t0x + Dy * t0y + Dz * t0z,
                                Dx * t1x + Dy * t1y + Dz * t1z,
                                Dx * t2x + Dy * t2y + Dz * t2z,
                                e0, e1, e2, kt, span, eps_s, rho,
                            )  # fmt: skip
                            ks = _lone(f0, f1, f2)
                            as_, bs, errs = _on_line(
                                Dx * sa0 + Dy * sa1 + Dz * sa2,
                                Dx * sb0 + Dy * sb1 + Dz * sb2,
                                Dx * sc0 + Dy * sc1 + Dz * sc2,
                                f0, f1, f2, ks, span, eps_t, rho,
                            )  # fmt: skip
                            lot, hit = min(at, bt), max(at, bt)
                            los, his = min(as_, bs), max(as_, bs)
                            tol = (errt + errs) * LINE_SLACK
                            if max(los - hit, lot - his) > tol:
                                continue
                            npairs += 1
                            if min(abs(at - as_), abs(at - bs), abs(bt - as_), abs(bt - bs)) > tol:
                                # The overlap's two ends, each where an edge of one face crosses
                                # the other face; the face owning that edge records it. The hand
                                # and object branches are written out twice on purpose: a shared
                                # helper taking the meshes' arrays, even inlined, cost 36,000
                                # reference-count updates a pose and 2-4 % of the time.
                                npt = 0
                                nstart = 0
                                px = py = pz = qx = qy = qz = 0.0
                                ep = eq = 0.0
                                for w in range(4):
                                    if w < 2:
                                        if not (los < (at if w == 0 else bt) < his):
                                            continue
                                        k0 = kt if w == 0 else (kt + 2) % 3
                                        k1 = (k0 + 1) % 3
                                        d_0, d_1 = _pick(e0, e1, e2, k0), _pick(e0, e1, e2, k1)
                                        u, v, lam = _crossing(AF[ft, k0], AF[ft, k1], d_0, d_1)
                                        dl = param_err(d_0, d_1, eps_s)
                                        first = crossing_starts(0, d_0, d_1)
                                        dx_ = AV[v, 0] - AV[u, 0]
                                        dy_ = AV[v, 1] - AV[u, 1]
                                        dz_ = AV[v, 2] - AV[u, 2]
                                        cx_ = AV[u, 0] + lam * dx_
                                        cy_ = AV[u, 1] + lam * dy_
                                        cz_ = AV[u, 2] + lam * dz_
                                        if ATO[ft, k0]:
                                            if nrec[0] >= cap:
                                                return seg, segerr, ncross, npairs, OVERFLOW
                                            ed = ATE[ft, k0]
                                            arec_e[nrec[0]] = ed
                                            arec_l[nrec[0]] = lam
                                            arec_d[nrec[0]] = dl
                                            nrec[0] += 1
                                            acnt[ed] += 1
                                    else:
                                        if not (lot < (as_ if w == 2 else bs) < hit):
                                            continue
                                        k0 = ks if w == 2 else (ks + 2) % 3
                                        k1 = (k0 + 1) % 3
                                        d_0, d_1 = _pick(f0, f1, f2, k0), _pick(f0, f1, f2, k1)
                                        u, v, lam = _crossing(BF[s, k0], BF[s, k1], d_0, d_1)
                                        dl = param_err(d_0, d_1, eps_t)
                                        first = crossing_starts(1, d_0, d_1)
                                        dx_ = BV[v, 0] - BV[u, 0]
                                        dy_ = BV[v, 1] - BV[u, 1]
                                        dz_ = BV[v, 2] - BV[u, 2]
                                        cx_ = BV[u, 0] + lam * dx_
                                        cy_ = BV[u, 1] + lam * dy_
                                        cz_ = BV[u, 2] + lam * dz_
                                        if BTO[s, k0]:
                                            if nrec[1] >= cap:
                                                return seg, segerr, ncross, npairs, OVERFLOW
                                            ed = BTE[s, k0]
                                            brec_e[nrec[1]] = ed
                                            brec_l[nrec[1]] = lam
                                            brec_d[nrec[1]] = dl
                                            nrec[1] += 1
                                            bcnt[ed] += 1
                                    perr = point_err(dl, max(abs(dx_), abs(dy_), abs(dz_)), gscale)
                                    # The segment runs from its start to its end along n_t x n_s.
                                    if first:
                                        px, py, pz, ep = cx_, cy_, cz_, perr
                                        nstart += 1
                                    else:
                                        qx, qy, qz, eq = cx_, cy_, cz_, perr
                                    npt += 1
                                if npt != 2 or nstart != 1:
                                    return seg, segerr, ncross, npairs, DEGENERATE
                                term, terr = segment_term(
                                    px, py, pz, qx, qy, qz, ep, eq, AD[ft, 0], AD[ft, 1],
                                    AD[ft, 2], BD[s, 0], BD[s, 1], BD[s, 2],
                                )  # fmt: skip
                                seg += term
                                run += abs(seg)
                                segerr += terr + AP[ft, 5] + beta_s
                                ncross += 1
                                continue
                            sg[0, 0], sg[0, 1], sg[0, 2] = _sgn(e0), _sgn(e1), _sgn(e2)
                            sg[1, 0], sg[1, 1], sg[1, 2] = _sgn(f0), _sgn(f1), _sgn(f2)
                            dt[0, 0], dt[0, 1], dt[0, 2], dt[0, 3] = e0, e1, e2, eps_s
                            dt[1, 0], dt[1, 1], dt[1, 2], dt[1, 3] = f0, f1, f2, eps_t
                        else:
                            npairs += 1
                        term, terr, pc = pair(
                            ft, s, AF, ATE, ATO, AV, BF, BTE, BTO, BV, AD, BD, acnt, bcnt,
                            arec, brec, nrec, P, sg, dt, sided, gscale,
                        )  # fmt: skip
                        if pc >= 2:
                            code = DEGENERATE if pc == 2 else OVERFLOW
                            return seg, segerr, ncross, npairs, code
                        if pc == 1:
                            seg += term
                            run += abs(seg)
                            segerr += terr + AP[ft, 5] + beta_s
                            ncross += 1
    return seg, segerr + U * run, ncross, npairs, OK


@njit(cache=True, nogil=True, error_model="numpy")
def _near_chunks(chunks, R, t, agrid, margin, rng, near):
    """Which runs of `CHUNK` object faces may come near the hand's surface: the bounding
    sphere of each run (``chunks`` (k, 4): centre in the object's frame, radius), moved by
    ``x -> R x + t``, must hold a surface cell of the hand grid in its bounding box."""
    alo, ah, an, atable = agrid[0], agrid[1], agrid[2], agrid[6]
    iah = 1.0 / ah
    for k in range(chunks.shape[0]):
        r = chunks[k, 3] + margin
        ok = True
        for d in range(3):
            m = R[d, 0] * chunks[k, 0] + R[d, 1] * chunks[k, 1] + R[d, 2] * chunks[k, 2] + t[d]
            i0 = int(np.floor((m - r - alo[d]) * iah))
            i1 = int(np.floor((m + r - alo[d]) * iah))
            if i1 < 0 or i0 >= an[d]:
                ok = False
                break
            rng[d, 0] = max(i0, 0)
            rng[d, 1] = min(i1, an[d] - 1)
        near[k] = ok and surface_cells_in(atable, an, rng) > 0


@njit(cache=True, nogil=True, error_model="numpy")
def _statuses(S, V, grid):
    """Status of every vertex of V in the other mesh's grid (1 inside, 0 outside, -1 in a cell
    the other surface touches), V being in that mesh's frame. One loop with scalar loads: a
    call per vertex with the grid's arrays would cost atomic reference counts (`point_status`
    does the same for one point)."""
    lo, ih, n, status = grid[0], 1.0 / grid[1], grid[2], grid[3]
    l0, l1, l2, n0, n1, n2 = lo[0], lo[1], lo[2], n[0], n[1], n[2]
    for i in range(V.shape[0]):
        c = cell_index(V[i, 0], V[i, 1], V[i, 2], l0, l1, l2, ih, n0, n1, n2)
        S[i] = 0 if c < 0 else status[c]


@njit(cache=True, nogil=True, error_model="numpy")
def _hand_statuses(S, V, R, t, grid, reps, cellmark, whole, uniform):
    """`_statuses` of the hand's vertices in the object's grid, part by part (``reps``, see
    `ExactIntersector._cell_reps`), the vertices moved by ``x -> R^T (x - t)``.

    A part whose cell no object face reached (``cellmark`` False; with ``whole``) holds no
    point of the object's surface: the convex region it bounds (cell ∩ its faces' box ∩
    their slab, see `_object_faces`) is wholly inside or wholly outside, so the first vertex
    found in a cell of known status gives every vertex's status (``uniform[k]`` True).
    Other parts get a status per vertex (-1 where unknown)."""
    lo, ih, n, status = grid[0], 1.0 / grid[1], grid[2], grid[3]
    l0, l1, l2, n0, n1, n2 = lo[0], lo[1], lo[2], n[0], n[1], n[2]
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    t0, t1, t2 = t[0], t[1], t[2]
    for k in range(reps.shape[0] - 1):
        each = not (whole and not cellmark[reps[k, 0]])
        st = -1
        for i in range(reps[k, 1], reps[k + 1, 1]):
            d0, d1, d2 = V[i, 0] - t0, V[i, 1] - t1, V[i, 2] - t2
            x = r00 * d0 + r10 * d1 + r20 * d2
            y = r01 * d0 + r11 * d1 + r21 * d2
            z = r02 * d0 + r12 * d1 + r22 * d2
            c = cell_index(x, y, z, l0, l1, l2, ih, n0, n1, n2)
            si = 0 if c < 0 else status[c]
            if each:
                S[i] = si
            elif si >= 0:
                st = si
                break
        uniform[k] = not each and st >= 0
        if not each:
            for i in range(reps[k, 1], reps[k + 1, 1]):
                S[i] = st


@njit(cache=True, nogil=True, error_model="numpy")
def pose_volumes(poses, A, X, agrid, B, bchunks, bgrid, bdc, tiny, cap, out, bounds, codes, stats):
    """Volume of A ∩ (pose · B) for each pose; A (the hand) is fixed, B is in its own frame.

    ``X = (AD, AN, ABB, AP, reps, AW, CBB, nxt, PT, epart, wsum, split)`` holds per-face
    data of A (`face_terms`, bounding boxes, unit plane), its parts (grid cells holding
    vertices, see `ExactIntersector._cell_reps`), A's edge weights, the search's tables
    (`_object_faces`) and A's edges by part (`ExactIntersector._part_edges`).
    ``bdc`` holds per face of B what its rounded ``D`` may cost (`face_d_coef`, over the
    coordinate bound).

    Each volume comes with an error bound (terms' rounding, crossing points' errors, the
    faces' rounded ``D`` and the sums' rounding; see docs/exact-backend.md). A volume within
    it of zero is exactly 0; one below minus it is inconsistent and reported DEGENERATE, so no
    negative volume is returned.
    ``bounds[i]`` is that bound (0 where the volume is certified zero: its own error bound
    then covers the true volume).
    ``codes[i]`` is OK, DEGENERATE or OVERFLOW (the caller recomputes those with a boolean);
    ``stats[i]`` counts pairs tried, crossing pairs, and A's surface cells touched /
    untouched inside / untouched outside.
    """
    AV, AF, AE, AET = A[0], A[1], A[2], A[3]
    BV0, BF, BE, BET = B[0], B[1], B[2], B[3]
    AD = X[0]
    cell_rep, epart = X[4], X[9]
    ah, acs = agrid[1], agrid[4]
    na, nb = AV.shape[0], BV0.shape[0]
    mb = BF.shape[0]
    BV = np.empty_like(BV0)
    BD = np.empty((mb, 3))
    BN = np.empty((mb, 3))
    # Statuses in one byte each: the hand's are read at random by the edge walks.
    AS = np.empty(na, np.int8)
    uniform = np.zeros(cell_rep.shape[0] - 1, np.bool_)
    BS = np.empty(nb, np.int8)
    # The object is one part, never classified whole.
    breps = np.array([[-1, 0], [-1, nb]], np.int64)
    bwhole = np.zeros(1, np.bool_)
    bsplit = B[6][1:]
    noparts = np.empty(0, np.int64)
    acnt = np.zeros(AE.shape[0], np.int64)
    bcnt = np.zeros(BE.shape[0], np.int64)
    arec = (np.empty(cap, np.int64), np.empty(cap), np.empty(cap))
    brec = (np.empty(cap, np.int64), np.empty(cap), np.empty(cap))
    nrec = np.zeros(2, np.int64)
    multi = np.empty(cap, np.int64)
    stamp = np.full(AF.shape[0], -1, np.int64)
    cellmark = np.zeros(acs.shape[0] - 1, np.bool_)
    queue = np.empty(max(na, nb), np.int64)
    xq = np.empty(3)
    astamp = np.full(AF.shape[0], -1, np.int64)
    bstamp = np.full(mb, -1, np.int64)
    token = -1
    near = np.zeros(bchunks.shape[0], np.bool_)
    W = (
        acnt,
        bcnt,
        arec,
        brec,
        nrec,
        stamp,
        np.empty((2, 5)),
        np.empty((2, 3), np.int64),
        np.empty((2, 4)),
        np.empty((3, 2), np.int64),
        cellmark,
        np.empty(max(1, np.max(acs[1:] - acs[:-1])), np.int64),
    )
    noW = np.empty((0, 2))
    noDc = np.empty(0)
    margin = 1e-9 * ah
    # Plane distances below this may be sign-uncertain in floating point; far above rounding.
    ptol = 1e-9 * ah
    # Bounds on every vertex's length (hand; object in its frame): the error bounds'
    # coordinate scale. The coordinates are local (about the hand's centre), so it measures
    # the geometry's size, not its position.
    amax = 0.0
    for i in range(na):
        amax = max(amax, AV[i, 0] ** 2 + AV[i, 1] ** 2 + AV[i, 2] ** 2)
    amax = max(np.sqrt(amax) * (1.0 + 1e-12), 1e-300)
    bmax = 0.0
    for i in range(nb):
        bmax = max(bmax, BV0[i, 0] ** 2 + BV0[i, 1] ** 2 + BV0[i, 2] ** 2)
    bmax = np.sqrt(bmax) * (1.0 + 1e-12)
    nparts = cell_rep.shape[0] - 1
    for ip in range(poses.shape[0]):
        R = poses[ip, :3, :3]
        t = poses[ip, :3, 3]
        r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
        r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
        r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
        t0, t1, t2 = t[0], t[1], t[2]
        for i in range(nb):
            x, y, z = BV0[i, 0], BV0[i, 1], BV0[i, 2]
            BV[i, 0] = r00 * x + r01 * y + r02 * z + t0
            BV[i, 1] = r10 * x + r11 * y + r12 * z + t1
            BV[i, 2] = r20 * x + r21 * y + r22 * z + t2
        face_terms(BV, BF, tiny, BD, BN)
        # |R x + t| <= |x| + |t| bounds every moved coordinate.
        gb = bmax + np.sqrt(t0 * t0 + t1 * t1 + t2 * t2) * (1.0 + 1e-12)
        gscale = max(amax, gb)
        _statuses(BS, BV, agrid)
        # Counters are cleared where the last pose set them; face stamps are unique per pose
        # (ip * mb + s), so neither needs a pass over a whole mesh.
        for k in range(nrec[0]):
            acnt[arec[0][k]] = 0
        for k in range(nrec[1]):
            bcnt[brec[0][k]] = 0
        nrec[:] = 0
        cellmark[:] = False
        _near_chunks(bchunks, R, t, agrid, margin, W[9], near)
        seg, segerr, ncross, npairs, code = _object_faces(
            A, X, agrid, B, BV, BD, BN, W, margin, ptol, gscale, ip * mb, near, bdc, gb
        )
        # After the search: the cells it marked tell which parts are classified whole.
        _hand_statuses(AS, AV, R, t, bgrid, cell_rep, cellmark, code == OK, uniform)
        if code == OK:
            u = _resolve(AS, A[6], A[7], A[8], acnt, queue, cell_rep, uniform)
            while u >= 0 and code == OK:
                # A component with no vertex of known status (a small shell wholly in cells
                # the object's surface touches): one exact point test in the object's frame.
                for k in range(3):
                    xq[k] = (
                        R[0, k] * (AV[u, 0] - t[0])
                        + R[1, k] * (AV[u, 1] - t[1])
                        + R[2, k] * (AV[u, 2] - t[2])
                    )
                token += 1
                AS[u] = ray_status(xq, BV0, BF, bgrid, bstamp, token)
                if AS[u] < 0:
                    code = DEGENERATE
                else:
                    queue[0] = u
                    _spread(AS, A[6], A[7], A[8], acnt, queue, 1)
                    u = _next_unknown(AS, u + 1, cell_rep, uniform)
        if code == OK:
            u = _resolve(BS, B[6], B[7], B[8], bcnt, queue, breps, bwhole)
            while u >= 0 and code == OK:
                token += 1
                BS[u] = ray_status(BV[u], AV, AF, agrid, astamp, token)
                if BS[u] < 0:
                    code = DEGENERATE
                else:
                    queue[0] = u
                    _spread(BS, B[6], B[7], B[8], bcnt, queue, 1)
                    u = _next_unknown(BS, u + 1, breps, bwhole)
        if code == OK:
            sa_, ea, oka = _edge_sum(
                AV, AD, AE, AET, AS, acnt, X[5], A[6], A[7], A[8], X[11], cell_rep, uniform,
                X[10], noDc, gscale,
            )  # fmt: skip
            sa2, ea2, oka2 = _crossed_sum(
                AV, AD, AE, AET, AS, acnt, arec[0], arec[1], arec[2], nrec[0], X[5], multi,
                epart, uniform, noDc, gscale,
            )  # fmt: skip
            sb_, eb, okb = _edge_sum(
                BV, BD, BE, BET, BS, bcnt, noW, B[6], B[7], B[8], bsplit, breps, bwhole, noW,
                bdc, gb,
            )  # fmt: skip
            sb2, eb2, okb2 = _crossed_sum(
                BV, BD, BE, BET, BS, bcnt, brec[0], brec[1], brec[2], nrec[1], noW, multi,
                noparts, bwhole, bdc, gb,
            )  # fmt: skip
            if not (oka and oka2 and okb and okb2):
                code = DEGENERATE
            vol = sa_ + sa2 + sb_ + sb2 + seg
            # The four additions round by at most 4 U times the largest partial sum.
            bound = ea + ea2 + eb + eb2 + segerr
            bound += 4.0 * U * (abs(sa_) + abs(sa2) + abs(sb_) + abs(sb2) + abs(seg))
            bound *= BOUND_SLACK
            if abs(vol) <= bound:
                vol = 0.0
            elif vol < 0.0 and code == OK:
                code = DEGENERATE
            out[ip] = vol
            bounds[ip] = bound
        codes[ip] = code
        stats[ip, STAT_PAIRS] = npairs
        stats[ip, STAT_CROSSING] = ncross
        touched = 0
        inside = 0
        for k in range(nparts):
            if cellmark[cell_rep[k, 0]]:
                touched += 1
            elif AS[cell_rep[k, 1]] == 1:
                inside += 1
        stats[ip, STAT_CELLS_TOUCHED] = touched
        stats[ip, STAT_CELLS_INSIDE] = inside
        stats[ip, STAT_CELLS_OUTSIDE] = nparts - touched - inside


@njit(cache=True, nogil=True, error_model="numpy")
def _shell_straddles(V, comp, seen, R, t, inverse, grid):
    """Whether some shell of mesh V (vertex -> shell `comp`) has a vertex in a cell wholly
    inside the other mesh and one in a cell wholly outside it; the vertices move by x -> R x + t
    (or by the inverse transform) into the frame of the other mesh's `grid`."""
    lo, h, n, status = grid[0], grid[1], grid[2], grid[3]
    seen[:] = False
    x = np.empty(3)
    for i in range(V.shape[0]):
        for k in range(3):
            if inverse:
                x[k] = (
                    R[0, k] * (V[i, 0] - t[0])
                    + R[1, k] * (V[i, 1] - t[1])
                    + R[2, k] * (V[i, 2] - t[2])
                )
            else:
                x[k] = R[k, 0] * V[i, 0] + R[k, 1] * V[i, 1] + R[k, 2] * V[i, 2] + t[k]
        st = point_status(x, lo, h, n, status)
        if st < 0:
            continue
        seen[comp[i], st] = True
        if seen[comp[i], 0] and seen[comp[i], 1]:
            return True
    return False


@njit(cache=True, nogil=True, error_model="numpy")
def surfaces_cross(poses, AV, acomp, ancomp, agrid, BV0, bcomp, bncomp, bgrid):
    """Per pose, whether the moved object's surface certainly crosses the hand's: a connected
    shell of either mesh has one vertex in a cell wholly inside the other mesh and another in
    a cell wholly outside it. Such a pose can never be culled, so the broad phase is not asked
    about it (False means "not known", not "apart")."""
    out = np.zeros(poses.shape[0], np.bool_)
    aseen = np.zeros((ancomp, 2), np.bool_)
    bseen = np.zeros((bncomp, 2), np.bool_)
    for ip in range(poses.shape[0]):
        R = poses[ip, :3, :3]
        t = poses[ip, :3, 3]
        out[ip] = _shell_straddles(BV0, bcomp, bseen, R, t, False, agrid) or _shell_straddles(
            AV, acomp, aseen, R, t, True, bgrid
        )
    return out
