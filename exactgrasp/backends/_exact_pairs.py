"""Numba kernel of one face pair of the exact backend (see `_exact_kernels` for the method)."""

from __future__ import annotations

from numba import njit

from exactgrasp.backends._exact_kernels import edge_triangle, orient, orient_bound


@njit(cache=True, nogil=True, error_model="numpy")
def _side(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, bound):
    d, ok = orient(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, bound)
    return (0 if not ok else (1 if d > 0 else -1)), d


@njit(cache=True, nogil=True, error_model="numpy")
def _edges_through(
    f, F, TE, TO, V, row, ax, ay, az, bx, by, bz, cx, cy, cz,
    cnt, rec_e, rec_l, nrec, P, npt, sg, dt, bound,
):  # fmt: skip
    """The edges of face f (of mesh V, F, row `row` of `sg`/`dt`) that cross triangle abc of
    the other mesh: each crossing point goes to P (the first two), and the edge's owning face
    records the crossing (edge, parameter) once. Returns (points so far, code) with code 2 for
    an uncertain sign and 3 for a full record buffer."""
    cap = rec_e.shape[0]
    for k in range(3):
        k1 = (k + 1) % 3
        u = F[f, k]
        v = F[f, k1]
        if sg[row, k] != 0 and sg[row, k] == sg[row, k1]:
            continue
        # Lower vertex index first, so that both faces of an edge evaluate the same thing.
        if u > v:
            u, v = v, u
            ku, kv = k1, k
        else:
            ku, kv = k, k1
        code, lam = edge_triangle(
            V[u, 0], V[u, 1], V[u, 2], V[v, 0], V[v, 1], V[v, 2],
            ax, ay, az, bx, by, bz, cx, cy, cz,
            sg[row, ku], dt[row, ku], sg[row, kv], dt[row, kv], bound,
        )  # fmt: skip
        if code == 2:
            return npt, 2
        if code == 1:
            if npt < 2:
                for d in range(3):
                    P[npt, d] = V[u, d] + lam * (V[v, d] - V[u, d])
            npt += 1
            if TO[f, k]:
                if nrec[row] >= cap:
                    return npt, 3
                rec_e[nrec[row]] = TE[f, k]
                rec_l[nrec[row]] = lam
                nrec[row] += 1
                cnt[TE[f, k]] += 1
    return npt, 0


@njit(cache=True, nogil=True, error_model="numpy")
def pair(
    t, s, AF, ATE, ATO, AV, BF, BTE, BTO, BV, AD, AN, BD, BN, acnt, bcnt,
    arec_e, arec_l, brec_e, brec_l, nrec, P, sg, dt, sided,
):  # fmt: skip
    """Contribution of face pair (t of A, s of B); records edge crossings. Returns
    (segment term, code) with code 0 no crossing, 1 crossing, 2 degenerate, 3 overflow.

    With ``sided`` the caller has filled ``sg`` / ``dt`` (row 0: t's vertices against s's
    plane, row 1: s's against t's; certain signs and values proportional to the distances,
    one scale per row) and both faces straddle the other's plane; otherwise they are computed
    here with `orient`.

    Arrays come one by one, not in the mesh tuples: unpacking a tuple of arrays on every call
    costs more than the pair test."""
    t0, t1, t2 = AF[t, 0], AF[t, 1], AF[t, 2]
    s0, s1, s2 = BF[s, 0], BF[s, 1], BF[s, 2]
    tax, tay, taz = AV[t0, 0], AV[t0, 1], AV[t0, 2]
    tbx, tby, tbz = AV[t1, 0], AV[t1, 1], AV[t1, 2]
    tcx, tcy, tcz = AV[t2, 0], AV[t2, 1], AV[t2, 2]
    sax, say, saz = BV[s0, 0], BV[s0, 1], BV[s0, 2]
    sbx, sby, sbz = BV[s1, 0], BV[s1, 1], BV[s1, 2]
    scx, scy, scz = BV[s2, 0], BV[s2, 1], BV[s2, 2]
    ext = max(tax, tbx, tcx, sax, sbx, scx) - min(tax, tbx, tcx, sax, sbx, scx)
    ext = max(ext, max(tay, tby, tcy, say, sby, scy) - min(tay, tby, tcy, say, sby, scy))
    ext = max(ext, max(taz, tbz, tcz, saz, sbz, scz) - min(taz, tbz, tcz, saz, sbz, scz))
    bound = orient_bound(ext * (1.0 + 1e-12))
    # Vertices of each face against the other's plane: a face wholly on one side is done.
    for k in range(0 if sided else 3):
        v = AF[t, k]
        sg[0, k], dt[0, k] = _side(
            sax, say, saz, sbx, sby, sbz, scx, scy, scz, AV[v, 0], AV[v, 1], AV[v, 2], bound
        )
    if sg[0, 0] != 0 and sg[0, 0] == sg[0, 1] and sg[0, 1] == sg[0, 2]:
        return 0.0, 0
    for k in range(0 if sided else 3):
        v = BF[s, k]
        sg[1, k], dt[1, k] = _side(
            tax, tay, taz, tbx, tby, tbz, tcx, tcy, tcz, BV[v, 0], BV[v, 1], BV[v, 2], bound
        )
    if sg[1, 0] != 0 and sg[1, 0] == sg[1, 1] and sg[1, 1] == sg[1, 2]:
        return 0.0, 0
    npt, code = _edges_through(
        t, AF, ATE, ATO, AV, 0, sax, say, saz, sbx, sby, sbz, scx, scy, scz,
        acnt, arec_e, arec_l, nrec, P, 0, sg, dt, bound,
    )  # fmt: skip
    if code >= 2:
        return 0.0, code
    npt, code = _edges_through(
        s, BF, BTE, BTO, BV, 1, tax, tay, taz, tbx, tby, tbz, tcx, tcy, tcz,
        bcnt, brec_e, brec_l, nrec, P, npt, sg, dt, bound,
    )  # fmt: skip
    if code >= 2:
        return 0.0, code
    if npt == 0:
        return 0.0, 0
    if npt != 2:
        return 0.0, 2
    return (
        segment_term(
            P[0, 0], P[0, 1], P[0, 2], P[1, 0], P[1, 1], P[1, 2], AN[t, 0], AN[t, 1], AN[t, 2],
            BN[s, 0], BN[s, 1], BN[s, 2], AD[t, 0] - BD[s, 0], AD[t, 1] - BD[s, 1],
            AD[t, 2] - BD[s, 2],
        ),
        1,
    )  # fmt: skip


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def segment_term(p0, p1, p2, q0, q1, q2, a0, a1, a2, b0, b1, b2, g0, g1, g2):
    """Term of the segment pq where face t (normal a) meets face s (normal b): the segment is
    directed along a x b (A ∩ B then lies to its left on face t) and weighted by
    g = D_t - D_s: ``g · (p x q) / 6``."""
    cx = a1 * b2 - a2 * b1
    cy = a2 * b0 - a0 * b2
    cz = a0 * b1 - a1 * b0
    if (q0 - p0) * cx + (q1 - p1) * cy + (q2 - p2) * cz < 0:
        p0, p1, p2, q0, q1, q2 = q0, q1, q2, p0, p1, p2
    return (g0 * (p1 * q2 - p2 * q1) + g1 * (p2 * q0 - p0 * q2) + g2 * (p0 * q1 - p1 * q0)) / 6.0
