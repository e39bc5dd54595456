"""Stage "pairs" of the exact kernel (numba): the terms of one crossing face pair, with the
exact test (certified orientation signs) and the pieces the common-line test shares with it.

See "Method" steps 2-3 and "Why it is exact" in ``docs/exact-backend.md``; `sums` holds the
terms' formulas.
"""

from __future__ import annotations

from exactgrasp.backends.exact.predicates import CROSS, NO, edge_triangle
from exactgrasp.backends.exact.tables import (
    DEGENERATE,
    DIST_ERR,
    OVERFLOW,
    POINT_CORNER,
    POINT_ERR,
    POINT_MESH,
    POINT_STARTS,
    POINT_XYZ,
)
from exactgrasp.backends.exact.tolerances import PARAM_ROUNDING, ROUNDING_PAD, TERM_ERR, U
from exactgrasp.compiling import inner
from exactgrasp.geometry.predicates import orient, orient_bound


@inner(nogil=True, error_model="numpy")
def _side(tri, dx, dy, dz, bound):
    """Side of d against the plane of triangle ``tri`` (corners a, b, c, each (x, y, z)),
    positive on the side ``(b - a) × (c - a)`` points to (as the floating-point plane tests;
    `orient` is positive on the other side): (certain sign or 0, value proportional to the
    signed distance)."""
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = tri
    d, ok = orient(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, bound)
    return (0 if not ok else (-1 if d > 0 else 1)), -d


@inner(nogil=True, error_model="numpy")
def _corner_sides(F, V, f, tri, row, sg, dt, bound):
    """Row ``row`` of ``sg`` / ``dt`` (`tables.Workspace.signs`, ``dists``): the corners of
    face f (of mesh V, F) against the plane of triangle ``tri`` of the other mesh (`_side`)."""
    for k in range(3):
        v = F[f, k]
        sg[row, k], dt[row, k] = _side(tri, V[v, 0], V[v, 1], V[v, 2], bound)


@inner(nogil=True, error_model="numpy")
def _one_sign(sg, row):
    """Whether the corners of row ``row`` of ``sg`` lie certainly on one side of the plane."""
    return sg[row, 0] != 0 and sg[row, 0] == sg[row, 1] and sg[row, 1] == sg[row, 2]


@inner(nogil=True, error_model="numpy")
def record_crossing(rec, count, nrec, row, edge, lam, dl):
    """Record a crossing of ``edge`` at parameter lam (error bound dl) as entry ``nrec[row]``
    of ``rec`` (`tables.Crossings`) and count it in ``count[edge]``. False, recording nothing,
    when ``rec`` is full."""
    n = nrec[row]
    if n >= rec.edge.shape[0]:
        return False
    rec.edge[n] = edge
    rec.lam[n] = lam
    rec.err[n] = dl
    nrec[row] = n + 1
    count[edge] += 1
    return True


@inner(nogil=True, error_model="numpy")
def _edges_through(f, side, row, tri, nrec, P, npt, sg, dt, bound, g):
    """The edges of face f of one mesh (``side``, see `pair`; row ``row`` of ``sg`` / ``dt``)
    that cross triangle ``tri`` (corners a, b, c) of the other mesh: each crossing point goes
    to P (the first two, columns ``POINT_*``: coordinates, error bound, whether it starts the
    common segment (see `crossing_starts`), ``row`` and the face corner k of the crossed edge
    k -> k + 1), and the edge's owning face records the crossing (edge, parameter, parameter
    error) once (`record_crossing`). ``dt[row, DIST_ERR]`` bounds the error of that row's
    values; ``g`` bounds every coordinate. Returns (points so far, code) with code `DEGENERATE`
    for an uncertain sign and `OVERFLOW` for a full record buffer."""
    F, TE, TO, V, _, count, rec = side
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = tri
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
            dl = param_err(dt[row, ku], dt[row, kv], dt[row, DIST_ERR])
            if npt < 2:
                span = 0.0
                for d in range(3):
                    P[npt, POINT_XYZ + d] = V[u, d] + lam * (V[v, d] - V[u, d])
                    span = max(span, abs(V[v, d] - V[u, d]))
                P[npt, POINT_ERR] = point_err(dl, span, g)
                starts = crossing_starts(row, sg[row, k], sg[row, k1])
                P[npt, POINT_STARTS] = 1.0 if starts else 0.0
                P[npt, POINT_MESH] = row
                P[npt, POINT_CORNER] = k
            npt += 1
            if TO[f, k] and not record_crossing(rec, count, nrec, row, TE[f, k], lam, dl):
                return npt, OVERFLOW
    return npt, NO


@inner(nogil=True, error_model="numpy")
def _triangle(V, F, f):
    """The corners of face f (of mesh V, F) as scalars: ((ax, ay, az), (bx, by, bz), (cx, cy,
    cz))."""
    a, b, c = F[f, 0], F[f, 1], F[f, 2]
    return (
        (V[a, 0], V[a, 1], V[a, 2]),
        (V[b, 0], V[b, 1], V[b, 2]),
        (V[c, 0], V[c, 1], V[c, 2]),
    )


@inner(nogil=True, error_model="numpy")
def point_of(P, i):
    """The coordinates of crossing point i of ``P`` (`tables.Workspace.points`)."""
    return P[i, POINT_XYZ], P[i, POINT_XYZ + 1], P[i, POINT_XYZ + 2]


@inner(nogil=True, error_model="numpy")
def pair(t, s, hand_side, object_side, scratch, sided, g):
    """Contribution of face pair (t of A, the hand, s of B, the object); records edge crossings
    in each side's records (`tables.Crossings`). Returns (segment term, its error bound, code)
    with code `NO` (no crossing), `CROSS`, `DEGENERATE` or `OVERFLOW`.

    Each side is (faces F, face_edges, face_owns, vertices V, face ``D``, crossing counts per
    edge, records) of its mesh, the object's vertices, ``D`` moved; ``scratch`` is (records per
    mesh ``nrec``, points ``P``, signs ``sg``, values ``dt``; `tables.Workspace`). With
    ``sided`` the caller has filled ``sg`` / ``dt`` (row 0: t's vertices against s's plane, row
    1: s's against t's; certain signs and values proportional to the distances, one scale per
    row, ``dt[row, DIST_ERR]`` a bound on their error) and both faces straddle the other's
    plane; otherwise they are computed here with `orient`. ``g`` bounds every coordinate.

    Arrays come in tuples of exactly those read, not in the mesh tuples: a call that is not
    compiled inline updates the reference count of every array it is passed."""
    AF, _, _, AV, AD, _, _ = hand_side
    BF, _, _, BV, BD, _, _ = object_side
    nrec, P, sg, dt = scratch
    t_tri = _triangle(AV, AF, t)
    s_tri = _triangle(BV, BF, s)
    (tax, tay, taz), (tbx, tby, tbz), (tcx, tcy, tcz) = t_tri
    (sax, say, saz), (sbx, sby, sbz), (scx, scy, scz) = s_tri
    ext = max(tax, tbx, tcx, sax, sbx, scx) - min(tax, tbx, tcx, sax, sbx, scx)
    ext = max(ext, max(tay, tby, tcy, say, sby, scy) - min(tay, tby, tcy, say, sby, scy))
    ext = max(ext, max(taz, tbz, tcz, saz, sbz, scz) - min(taz, tbz, tcz, saz, sbz, scz))
    bound = orient_bound(ext * ROUNDING_PAD)
    # Vertices of each face against the other's plane: a face wholly on one side is done.
    if not sided:
        dt[0, DIST_ERR] = dt[1, DIST_ERR] = bound
        _corner_sides(AF, AV, t, s_tri, 0, sg, dt, bound)
    if _one_sign(sg, 0):
        return 0.0, 0.0, NO
    if not sided:
        _corner_sides(BF, BV, s, t_tri, 1, sg, dt, bound)
    if _one_sign(sg, 1):
        return 0.0, 0.0, NO
    npt, code = _edges_through(t, hand_side, 0, s_tri, nrec, P, 0, sg, dt, bound, g)
    if code >= DEGENERATE:
        return 0.0, 0.0, code
    npt, code = _edges_through(s, object_side, 1, t_tri, nrec, P, npt, sg, dt, bound, g)
    if code >= DEGENERATE:
        return 0.0, 0.0, code
    if npt == 0:
        return 0.0, 0.0, NO
    if npt != 2 or P[0, POINT_STARTS] == P[1, POINT_STARTS]:
        return 0.0, 0.0, DEGENERATE
    i, j = (0, 1) if P[0, POINT_STARTS] > 0 else (1, 0)
    term, err = segment_term(
        point_of(P, i), point_of(P, j), P[i, POINT_ERR], P[j, POINT_ERR],
        (AD[t, 0], AD[t, 1], AD[t, 2]), (BD[s, 0], BD[s, 1], BD[s, 2]),
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
def segment_term(p, q, ep, eq, a, b):
    """Term of the segment p → q (points (x, y, z), already directed along ``n_t × n_s``, see
    `crossing_starts`) where face t (``D_t = a``) meets face s (``D_s = b``):
    ``(D_t - D_s) · (p × q) / 6``, and a bound on its error: rounding (`TERM_ERR`) and the
    points' own errors (``ep``, ``eq`` per coordinate)."""
    p0, p1, p2 = p
    q0, q1, q2 = q
    a0, a1, a2 = a
    b0, b1, b2 = b
    g0, g1, g2 = a0 - b0, a1 - b1, a2 - b2
    term = (g0 * (p1 * q2 - p2 * q1) + g1 * (p2 * q0 - p0 * q2) + g2 * (p0 * q1 - p1 * q0)) / 6.0
    pn = max(abs(p0), abs(p1), abs(p2))
    qn = max(abs(q0), abs(q1), abs(q2))
    dn = abs(a0) + abs(a1) + abs(a2) + abs(b0) + abs(b1) + abs(b2)
    # |g · (dp × q)| <= |g|_1 2 |dp|_inf |q|_inf, and the same for dq (and dp × dq).
    moved = (abs(g0) + abs(g1) + abs(g2)) * ((pn + ep) * (qn + eq) - pn * qn) / 3.0
    return term, TERM_ERR * U * dn * pn * qn + moved


@inner(nogil=True, error_model="numpy")
def corner_crossing(row, k0, face, g):
    """Where the edge from corner k0 to corner k0 + 1 of a face crosses the other face's plane,
    decided on the planes' common line (`search.trace_pairs`), for the hand's face (``row``
    0) or the object's (1).

    ``face`` is (vertex indices (3), corners (3, each (x, y, z)), their signed distances to the
    other plane (3; certain, opposite signs at the edge's ends), the bound on those distances'
    error); ``g`` bounds every coordinate. Scalars only: a routine taking the meshes' arrays
    would update their reference counts on every call. The point is computed as in `pair`
    (`_edges_through`): from the lower vertex index, so that both faces of an edge compute the
    same point.

    Returns
    -------
    (lam, dl, first, point, perr)
        The parameter along the edge from its lower-numbered vertex and its error bound,
        whether the crossing starts the common segment (`crossing_starts`), the point (x, y,
        z) and the bound on each of its coordinates' error (`point_err`).
    """
    index, corners, dists, err = face
    k1 = (k0 + 1) % 3
    d_0, d_1 = dists[k0], dists[k1]
    ux, uy, uz = corners[k0]
    vx, vy, vz = corners[k1]
    du, dv = d_0, d_1
    if index[k0] > index[k1]:
        ux, uy, uz, vx, vy, vz, du, dv = vx, vy, vz, ux, uy, uz, dv, du
    lam = du / (du - dv)
    dl = param_err(d_0, d_1, err)
    first = crossing_starts(row, d_0, d_1)
    dx, dy, dz = vx - ux, vy - uy, vz - uz
    perr = point_err(dl, max(abs(dx), abs(dy), abs(dz)), g)
    return lam, dl, first, (ux + lam * dx, uy + lam * dy, uz + lam * dz), perr
