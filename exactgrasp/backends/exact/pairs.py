"""Stage "pairs" of the exact kernel (numba): the terms of one crossing face pair, with the
exact test (certified orientation signs) and the pieces the common-line test shares with it.

See "Method" steps 2-3 and "Why it is exact" in ``docs/exact-backend.md``; `sums` holds the
terms' formulas.
"""

from __future__ import annotations

from exactgrasp.backends.exact.predicates import CROSS, NO, edge_triangle
from exactgrasp.backends.exact.tables import DEGENERATE, OVERFLOW
from exactgrasp.backends.exact.tolerances import PARAM_ROUNDING, ROUNDING_PAD, TERM_ERR, U
from exactgrasp.compiling import inner
from exactgrasp.geometry.predicates import orient, orient_bound


@inner(nogil=True, error_model="numpy")
def _side(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, bound):
    """Side of d against the plane of abc, positive on the side ``(b - a) × (c - a)`` points
    to (as the floating-point plane tests; `orient` is positive on the other side): (certain
    sign or 0, value proportional to the signed distance)."""
    d, ok = orient(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, bound)
    return (0 if not ok else (-1 if d > 0 else 1)), -d


@inner(nogil=True, error_model="numpy")
def _edges_through(
    f, F, TE, TO, V, row, ax, ay, az, bx, by, bz, cx, cy, cz,
    cnt, rec_e, rec_l, rec_d, nrec, P, npt, sg, dt, bound, g,
):  # fmt: skip
    """The edges of face f (of mesh V, F, row `row` of `sg`/`dt`) that cross triangle abc of
    the other mesh: each crossing point goes to P (the first two: coordinates, error bound,
    whether it starts the common segment (see `crossing_starts`), ``row`` and the face corner k
    of the crossed edge k -> k + 1), and the edge's owning face
    records the crossing (edge, parameter, parameter error) once. ``dt[row, 3]`` bounds the
    error of that row's values; ``g`` bounds every coordinate. Returns (points so far, code)
    with code `DEGENERATE` for an uncertain sign and `OVERFLOW` for a full record buffer."""
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
        if code == DEGENERATE:
            return npt, DEGENERATE
        if code == CROSS:
            dl = param_err(dt[row, ku], dt[row, kv], dt[row, 3])
            if npt < 2:
                span = 0.0
                for d in range(3):
                    P[npt, d] = V[u, d] + lam * (V[v, d] - V[u, d])
                    span = max(span, abs(V[v, d] - V[u, d]))
                P[npt, 3] = point_err(dl, span, g)
                P[npt, 4] = 1.0 if crossing_starts(row, sg[row, k], sg[row, k1]) else 0.0
                P[npt, 5] = row
                P[npt, 6] = k
            npt += 1
            if TO[f, k]:
                if nrec[row] >= cap:
                    return npt, OVERFLOW
                rec_e[nrec[row]] = TE[f, k]
                rec_l[nrec[row]] = lam
                rec_d[nrec[row]] = dl
                nrec[row] += 1
                cnt[TE[f, k]] += 1
    return npt, NO


@inner(nogil=True, error_model="numpy")
def pair(
    t, s, AF, ATE, ATO, AV, BF, BTE, BTO, BV, AD, BD, acnt, bcnt,
    arec, brec, nrec, P, sg, dt, sided, g,
):  # fmt: skip
    """Contribution of face pair (t of A, s of B); records edge crossings in ``arec`` /
    ``brec`` (`tables.Crossings`). Returns (segment term, its error bound, code) with code
    `NO` (no crossing), `CROSS`, `DEGENERATE` or `OVERFLOW`.

    With ``sided`` the caller has filled ``sg`` / ``dt`` (row 0: t's vertices against s's
    plane, row 1: s's against t's; certain signs and values proportional to the distances,
    one scale per row, ``dt[row, 3]`` a bound on their error) and both faces straddle the
    other's plane; otherwise they are computed here with `orient`. ``g`` bounds every
    coordinate.

    Arrays come one by one, not in the mesh tuples: unpacking a tuple of arrays on every call
    costs more than the pair test (the records' three arrays excepted)."""
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
    bound = orient_bound(ext * ROUNDING_PAD)
    # Vertices of each face against the other's plane: a face wholly on one side is done.
    if not sided:
        dt[0, 3] = dt[1, 3] = bound
    for k in range(0 if sided else 3):
        v = AF[t, k]
        sg[0, k], dt[0, k] = _side(
            sax, say, saz, sbx, sby, sbz, scx, scy, scz, AV[v, 0], AV[v, 1], AV[v, 2], bound
        )
    if sg[0, 0] != 0 and sg[0, 0] == sg[0, 1] and sg[0, 1] == sg[0, 2]:
        return 0.0, 0.0, NO
    for k in range(0 if sided else 3):
        v = BF[s, k]
        sg[1, k], dt[1, k] = _side(
            tax, tay, taz, tbx, tby, tbz, tcx, tcy, tcz, BV[v, 0], BV[v, 1], BV[v, 2], bound
        )
    if sg[1, 0] != 0 and sg[1, 0] == sg[1, 1] and sg[1, 1] == sg[1, 2]:
        return 0.0, 0.0, NO
    npt, code = _edges_through(
        t, AF, ATE, ATO, AV, 0, sax, say, saz, sbx, sby, sbz, scx, scy, scz,
        acnt, arec.edge, arec.lam, arec.err, nrec, P, 0, sg, dt, bound, g,
    )  # fmt: skip
    if code >= DEGENERATE:
        return 0.0, 0.0, code
    npt, code = _edges_through(
        s, BF, BTE, BTO, BV, 1, tax, tay, taz, tbx, tby, tbz, tcx, tcy, tcz,
        bcnt, brec.edge, brec.lam, brec.err, nrec, P, npt, sg, dt, bound, g,
    )  # fmt: skip
    if code >= DEGENERATE:
        return 0.0, 0.0, code
    if npt == 0:
        return 0.0, 0.0, NO
    if npt != 2 or P[0, 4] == P[1, 4]:
        return 0.0, 0.0, DEGENERATE
    i, j = (0, 1) if P[0, 4] > 0 else (1, 0)
    term, err = segment_term(
        P[i, 0], P[i, 1], P[i, 2], P[j, 0], P[j, 1], P[j, 2], P[i, 3], P[j, 3],
        AD[t, 0], AD[t, 1], AD[t, 2], BD[s, 0], BD[s, 1], BD[s, 2],
    )  # fmt: skip
    return term, err, CROSS


@inner(nogil=True, error_model="numpy")
def crossing_starts(row, s0, s1):
    """Whether the crossing on the edge from corner sign s0 to corner sign s1 (certain,
    opposite) of a face, corners in the face's own order, is where the common segment of the
    pair starts along ``n_t × n_s``: for the hand face (row 0) the edge enters the object
    face's positive side, for the object face (row 1) it leaves the hand face's positive side.
    (In the plane of t, ``n_t × n_s`` is the in-plane part of ``n_s`` turned by +90 degrees, so
    t's counter-clockwise boundary enters the positive side at the segment's start; the same
    for s with ``n_s × n_t = -(n_t × n_s)``.) Exact: no rounded direction is compared."""
    if row == 0:
        return s0 < 0 < s1
    return s0 > 0 > s1


@inner(nogil=True, error_model="numpy")
def param_err(du, dv, err):
    """Bound on the error of the crossing parameter ``du / (du - dv)`` of an edge whose ends
    have values du, dv (opposite, certain signs) erring by up to
    err: at most ``err / (|du| + |dv| - 2 err)``, so ``2 err / (|du| + |dv|)`` once
    ``|du| + |dv| >= 4 err`` (taken twice), else 1; plus rounding."""
    span = abs(du) + abs(dv)
    return (4.0 * err / span if span >= 4.0 * err else 1.0) + PARAM_ROUNDING


@inner(nogil=True, error_model="numpy")
def point_err(dl, span, g):
    """Bound on each coordinate's error of ``x_u + lam (x_v - x_u)`` with lam erring by dl,
    ``span`` the largest coordinate difference of the edge, g bounding every coordinate."""
    return dl * span + 6.0 * U * g


@inner(nogil=True, error_model="numpy")
def segment_term(p0, p1, p2, q0, q1, q2, ep, eq, a0, a1, a2, b0, b1, b2):
    """Term of the segment p → q (already directed along ``n_t × n_s``, see
    `crossing_starts`) where face t (``D_t = a``) meets face s (``D_s = b``):
    ``(D_t - D_s) · (p × q) / 6``, and a bound on its error: rounding (`TERM_ERR`) and the
    points' own errors (``ep``, ``eq`` per coordinate)."""
    g0, g1, g2 = a0 - b0, a1 - b1, a2 - b2
    term = (g0 * (p1 * q2 - p2 * q1) + g1 * (p2 * q0 - p0 * q2) + g2 * (p0 * q1 - p1 * q0)) / 6.0
    pn = max(abs(p0), abs(p1), abs(p2))
    qn = max(abs(q0), abs(q1), abs(q2))
    dn = abs(a0) + abs(a1) + abs(a2) + abs(b0) + abs(b1) + abs(b2)
    # |g · (dp × q)| <= |g|_1 2 |dp|_inf |q|_inf, and the same for dq (and dp × dq).
    moved = (abs(g0) + abs(g1) + abs(g2)) * ((pn + ep) * (qn + eq) - pn * qn) / 3.0
    return term, TERM_ERR * U * dn * pn * qn + moved


@inner(nogil=True, error_model="numpy")
def _pick(x0, x1, x2, k):
    """The k-th of three scalars (no array view in the hot loop)."""
    return x0 if k == 0 else (x1 if k == 1 else x2)


@inner(nogil=True, error_model="numpy")
def corner_crossing(
    row, k0, i0, i1, i2, x0, y0, z0, x1, y1, z1, x2, y2, z2, d0, d1, d2, err, g
):  # fmt: skip
    """Where the edge from corner k0 to corner k0 + 1 of a face crosses the other face's plane,
    decided on the planes' common line (`search.trace_pairs`), for the hand's face (``row``
    0) or the object's (1).

    ``i*`` are the face's vertex indices, ``x*, y*, z*`` its corners, ``d*`` their signed
    distances to the other plane (certain, opposite signs at the edge's ends, each erring by
    up to ``err``); ``g`` bounds every coordinate. Scalars only: a routine taking the meshes'
    arrays, even inlined, costs reference-count updates on every call. The point is computed
    as in `pair` (`_edges_through`): from the lower vertex index, so that both faces of an edge
    compute the same point.

    Returns
    -------
    (lam, dl, first, px, py, pz, perr)
        The parameter along the edge from its lower-numbered vertex and its error bound,
        whether the crossing starts the common segment (`crossing_starts`), the point and the
        bound on each of its coordinates' error (`point_err`).
    """
    k1 = (k0 + 1) % 3
    d_0, d_1 = _pick(d0, d1, d2, k0), _pick(d0, d1, d2, k1)
    ux, uy, uz = _pick(x0, x1, x2, k0), _pick(y0, y1, y2, k0), _pick(z0, z1, z2, k0)
    vx, vy, vz = _pick(x0, x1, x2, k1), _pick(y0, y1, y2, k1), _pick(z0, z1, z2, k1)
    du, dv = d_0, d_1
    if _pick(i0, i1, i2, k0) > _pick(i0, i1, i2, k1):
        ux, uy, uz, vx, vy, vz, du, dv = vx, vy, vz, ux, uy, uz, dv, du
    lam = du / (du - dv)
    dl = param_err(d_0, d_1, err)
    first = crossing_starts(row, d_0, d_1)
    dx, dy, dz = vx - ux, vy - uy, vz - uz
    perr = point_err(dl, max(abs(dx), abs(dy), abs(dz)), g)
    return lam, dl, first, ux + lam * dx, uy + lam * dy, uz + lam * dz, perr
