# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Stage "pairs" of the exact kernel (Cython, inline): the terms of one crossing face pair,
with the exact test (certified orientation signs) and the pieces the common-line test shares
with it.

See "Method" steps 2-3 and "Why it is exact" in ``docs/exact-backend.md``; ``_sums.pxd`` holds
the terms' formulas. A triangle's corners travel as 9 doubles (a, b, c, each x, y, z), scalars:
no array views in the hot loop.
"""

from libc.math cimport fabs
from libc.stdint cimport int64_t

from exactgrasp.backends.exact._constants cimport (
    DEGENERATE,
    DIST_ERR,
    OVERFLOW,
    PARAM_ROUNDING,
    POINT_CORNER,
    POINT_ERR,
    POINT_MESH,
    POINT_STARTS,
    POINT_XYZ,
    ROUNDING_PAD,
    TERM_ERR,
    U,
)
from exactgrasp.backends.exact._predicates cimport CROSS, NO, edge_triangle
from exactgrasp.backends.exact._tables cimport Crossings, MeshTables, Workspace
from exactgrasp.geometry._minmax cimport max2, min2
from exactgrasp.geometry._predicates cimport orient, orient_bound


cdef inline (int64_t, double) _side(
    const double *tri, double dx, double dy, double dz, double bound
) noexcept nogil:
    """Side of d against the plane of triangle ``tri`` (9 corner coordinates), positive on
    the side ``(b - a) × (c - a)`` points to (as the floating-point plane tests; `orient` is
    positive on the other side): (certain sign or 0, value proportional to the signed
    distance)."""
    cdef bint ok
    cdef double d = orient(
        tri[0], tri[1], tri[2], tri[3], tri[4], tri[5], tri[6], tri[7], tri[8],
        dx, dy, dz, bound, &ok,
    )
    return (0 if not ok else (-1 if d > 0 else 1)), -d


cdef inline void _corner_sides(
    int64_t[:, ::1] F, double[:, ::1] V, int64_t f, const double *tri, int64_t row,
    int64_t[:, ::1] sg, double[:, ::1] dt, double bound,
) noexcept nogil:
    """Row ``row`` of ``sg`` / ``dt`` (`tables.Workspace.signs`, ``dists``): the corners of
    face f (of mesh V, F) against the plane of triangle ``tri`` of the other mesh (`_side`)."""
    cdef int64_t k, v
    for k in range(3):
        v = F[f, k]
        sg[row, k], dt[row, k] = _side(tri, V[v, 0], V[v, 1], V[v, 2], bound)


cdef inline bint _one_sign(int64_t[:, ::1] sg, int64_t row) noexcept nogil:
    """Whether the corners of row ``row`` of ``sg`` lie certainly on one side of the plane."""
    return sg[row, 0] != 0 and sg[row, 0] == sg[row, 1] and sg[row, 1] == sg[row, 2]


cdef inline bint record_crossing(
    Crossings rec, int64_t[::1] count, int64_t[::1] nrec, int64_t row, int64_t edge,
    double lam, double dl,
) noexcept nogil:
    """Record a crossing of ``edge`` at parameter lam (error bound dl) as entry ``nrec[row]``
    of ``rec`` (`tables.Crossings`) and count it in ``count[edge]``. False, recording nothing,
    when ``rec`` is full."""
    cdef int64_t n = nrec[row]
    if n >= rec.edge.shape[0]:
        return False
    rec.edge[n] = edge
    rec.lam[n] = lam
    rec.err[n] = dl
    nrec[row] = n + 1
    count[edge] += 1
    return True


cdef inline (int64_t, int64_t) _edges_through(
    int64_t f, MeshTables mesh, double[:, ::1] V, int64_t[::1] count, Crossings rec,
    int64_t row, const double *tri, Workspace W, int64_t npt, double bound, double g,
) noexcept nogil:
    """The edges of face f of one mesh (faces, edges and owners of ``mesh``, vertices V,
    crossing counts ``count`` and records ``rec``; row ``row`` of ``W.signs`` / ``W.dists``)
    that cross triangle ``tri`` (9 corner coordinates) of the other mesh: each crossing point
    goes to ``W.points`` (the first two, columns ``POINT_*``: coordinates, error bound,
    whether it starts the common segment (see `crossing_starts`), ``row`` and the face
    corner k of the crossed edge k -> k + 1), and the edge's owning face records the crossing
    (edge, parameter, parameter error) once (`record_crossing`). ``dt[row, DIST_ERR]`` bounds
    the error of that row's values; ``g`` bounds every coordinate. Returns (points so far,
    code) with code `DEGENERATE` for an uncertain sign and `OVERFLOW` for a full record
    buffer."""
    cdef int64_t k, k1, u, v, ku, kv, d, code
    cdef double lam, dl, span
    for k in range(3):
        k1 = (k + 1) % 3
        u = mesh.faces[f, k]
        v = mesh.faces[f, k1]
        if W.signs[row, k] != 0 and W.signs[row, k] == W.signs[row, k1]:
            continue
        # Lower vertex index first, so that both faces of an edge evaluate the same thing.
        if u > v:
            u, v = v, u
            ku, kv = k1, k
        else:
            ku, kv = k, k1
        code, lam = edge_triangle(
            V[u, 0], V[u, 1], V[u, 2], V[v, 0], V[v, 1], V[v, 2],
            tri[0], tri[1], tri[2], tri[3], tri[4], tri[5], tri[6], tri[7], tri[8],
            W.signs[row, ku], W.dists[row, ku], W.signs[row, kv], W.dists[row, kv], bound,
        )
        if code == DEGENERATE:
            return npt, DEGENERATE
        if code == CROSS:
            dl = param_err(W.dists[row, ku], W.dists[row, kv], W.dists[row, DIST_ERR])
            if npt < 2:
                span = 0.0
                for d in range(3):
                    W.points[npt, POINT_XYZ + d] = V[u, d] + lam * (V[v, d] - V[u, d])
                    span = max2(span, fabs(V[v, d] - V[u, d]))
                W.points[npt, POINT_ERR] = point_err(dl, span, g)
                W.points[npt, POINT_STARTS] = (
                    1.0 if crossing_starts(row, W.signs[row, k], W.signs[row, k1]) else 0.0
                )
                W.points[npt, POINT_MESH] = row
                W.points[npt, POINT_CORNER] = k
            npt += 1
            if mesh.face_owns[f, k] and not record_crossing(
                rec, count, W.nrec, row, mesh.face_edges[f, k], lam, dl
            ):
                return npt, OVERFLOW
    return npt, NO


cdef inline void _triangle(
    double[:, ::1] V, int64_t[:, ::1] F, int64_t f, double *tri
) noexcept nogil:
    """The corners of face f (of mesh V, F) as scalars, into ``tri`` (9: a, b, c, each
    x, y, z)."""
    cdef int64_t k, d
    for k in range(3):
        for d in range(3):
            tri[3 * k + d] = V[F[f, k], d]


cdef inline (double, double, double) point_of(double[:, ::1] P, int64_t i) noexcept nogil:
    """The coordinates of crossing point i of ``P`` (`tables.Workspace.points`)."""
    return P[i, POINT_XYZ], P[i, POINT_XYZ + 1], P[i, POINT_XYZ + 2]


cdef inline double _extent(const double *t, const double *s) noexcept nogil:
    """Largest extent, over the three axes, of the six corners of triangles t and s (9
    coordinates each), as ``max(...) - min(...)`` of the six in that order."""
    cdef double ext = 0.0, hi, lo
    cdef int64_t d
    for d in range(3):
        hi = max2(max2(max2(max2(max2(t[d], t[3 + d]), t[6 + d]), s[d]), s[3 + d]), s[6 + d])
        lo = min2(min2(min2(min2(min2(t[d], t[3 + d]), t[6 + d]), s[d]), s[3 + d]), s[6 + d])
        ext = hi - lo if d == 0 else max2(ext, hi - lo)
    return ext


cdef inline (double, double, int64_t) pair(
    int64_t t, int64_t s, MeshTables hand_mesh, double[:, ::1] AV, double[:, ::1] AD,
    MeshTables object_mesh, double[:, ::1] BV, double[:, ::1] BD, Workspace W, bint sided,
    double g,
) noexcept nogil:
    """Contribution of face pair (t of A, the hand, s of B, the object); records edge
    crossings in each side's records (``W.hand_rec``, ``W.object_rec``). Returns (segment
    term, its error bound, code) with code `NO` (no crossing), `CROSS`, `DEGENERATE` or
    `OVERFLOW`.

    Each side is its mesh's tables, vertices and face ``D`` (the object's moved: BV, BD);
    ``W`` holds the records per mesh ``nrec``, points, signs ``sg`` and values ``dt``. With
    ``sided`` the caller has filled ``sg`` / ``dt`` (row 0: t's vertices against s's plane,
    row 1: s's against t's; certain signs and values proportional to the distances, one scale
    per row, ``dt[row, DIST_ERR]`` a bound on their error) and both faces straddle the other's
    plane; otherwise they are computed here with `orient`. ``g`` bounds every coordinate."""
    cdef double t_tri[9]
    cdef double s_tri[9]
    cdef double bound, term, err
    cdef int64_t npt, code, i, j
    _triangle(AV, hand_mesh.faces, t, t_tri)
    _triangle(BV, object_mesh.faces, s, s_tri)
    bound = orient_bound(_extent(t_tri, s_tri) * ROUNDING_PAD)
    # Vertices of each face against the other's plane: a face wholly on one side is done.
    if not sided:
        W.dists[0, DIST_ERR] = bound
        W.dists[1, DIST_ERR] = bound
        _corner_sides(hand_mesh.faces, AV, t, s_tri, 0, W.signs, W.dists, bound)
    if _one_sign(W.signs, 0):
        return 0.0, 0.0, NO
    if not sided:
        _corner_sides(object_mesh.faces, BV, s, t_tri, 1, W.signs, W.dists, bound)
    if _one_sign(W.signs, 1):
        return 0.0, 0.0, NO
    npt, code = _edges_through(
        t, hand_mesh, AV, W.hand_count, W.hand_rec, 0, s_tri, W, 0, bound, g
    )
    if code >= DEGENERATE:
        return 0.0, 0.0, code
    npt, code = _edges_through(
        s, object_mesh, BV, W.object_count, W.object_rec, 1, t_tri, W, npt, bound, g
    )
    if code >= DEGENERATE:
        return 0.0, 0.0, code
    if npt == 0:
        return 0.0, 0.0, NO
    if npt != 2 or W.points[0, POINT_STARTS] == W.points[1, POINT_STARTS]:
        return 0.0, 0.0, DEGENERATE
    i, j = (0, 1) if W.points[0, POINT_STARTS] > 0 else (1, 0)
    term, err = segment_term(
        W.points[i, POINT_XYZ], W.points[i, POINT_XYZ + 1], W.points[i, POINT_XYZ + 2],
        W.points[j, POINT_XYZ], W.points[j, POINT_XYZ + 1], W.points[j, POINT_XYZ + 2],
        W.points[i, POINT_ERR], W.points[j, POINT_ERR],
        AD[t, 0], AD[t, 1], AD[t, 2], BD[s, 0], BD[s, 1], BD[s, 2],
    )
    return term, err, CROSS


cdef inline bint crossing_starts(int64_t row, double s0, double s1) noexcept nogil:
    """Whether the crossing on the edge from corner sign s0 to corner sign s1 (certain,
    opposite; signs or signed distances) of a face, corners in the face's own order, is where
    the common segment of the pair starts along ``n_t × n_s``: for the hand face (row 0) the
    edge enters the object face's positive side, for the object face (row 1) it leaves the
    hand face's positive side. Exact: no rounded direction is compared."""
    if row == 0:
        return s0 < 0 < s1
    return s0 > 0 > s1


cdef inline double param_err(double du, double dv, double err) noexcept nogil:
    """Bound on the error of the crossing parameter ``du / (du - dv)`` of an edge whose ends
    have values du, dv (opposite, certain signs) erring by up to err: at most
    ``err / (|du| + |dv| - 2 err)``, so ``2 err / (|du| + |dv|)`` once
    ``|du| + |dv| >= 4 err`` (taken twice), else 1; plus rounding."""
    cdef double span = fabs(du) + fabs(dv)
    return (4.0 * err / span if span >= 4.0 * err else 1.0) + PARAM_ROUNDING


cdef inline double point_err(double dl, double span, double g) noexcept nogil:
    """Bound on each coordinate's error of ``x_u + lam (x_v - x_u)`` with lam erring by dl,
    ``span`` the largest coordinate difference of the edge, g bounding every coordinate."""
    return dl * span + 6.0 * U * g


cdef inline (double, double) segment_term(
    double p0, double p1, double p2, double q0, double q1, double q2, double ep, double eq,
    double a0, double a1, double a2, double b0, double b1, double b2,
) noexcept nogil:
    """Term of the segment p → q (already directed along ``n_t × n_s``, see
    `crossing_starts`) where face t (``D_t = a``) meets face s (``D_s = b``):
    ``(D_t - D_s) · (p × q) / 6``, and a bound on its error: rounding (`TERM_ERR`) and the
    points' own errors (``ep``, ``eq`` per coordinate)."""
    cdef double g0 = a0 - b0, g1 = a1 - b1, g2 = a2 - b2
    cdef double term = (
        g0 * (p1 * q2 - p2 * q1) + g1 * (p2 * q0 - p0 * q2) + g2 * (p0 * q1 - p1 * q0)
    ) / 6.0
    cdef double pn = max2(max2(fabs(p0), fabs(p1)), fabs(p2))
    cdef double qn = max2(max2(fabs(q0), fabs(q1)), fabs(q2))
    cdef double dn = fabs(a0) + fabs(a1) + fabs(a2) + fabs(b0) + fabs(b1) + fabs(b2)
    # |g · (dp × q)| <= |g|_1 2 |dp|_inf |q|_inf, and the same for dq (and dp × dq).
    cdef double moved = (
        (fabs(g0) + fabs(g1) + fabs(g2)) * ((pn + ep) * (qn + eq) - pn * qn) / 3.0
    )
    return term, TERM_ERR * U * dn * pn * qn + moved


cdef inline (double, double, bint, double, double, double, double) corner_crossing(
    int64_t row, int64_t k0, const int64_t *index, const double *corners,
    const double *dists, double err, double g,
) noexcept nogil:
    """Where the edge from corner k0 to corner k0 + 1 of a face crosses the other face's
    plane, decided on the planes' common line (`_search.trace_pairs`), for the hand's face
    (``row`` 0) or the object's (1).

    The face is its vertex indices ``index`` (3), its corners (9: each x, y, z), their signed
    distances to the other plane ``dists`` (3; certain, opposite signs at the edge's ends) and
    the bound ``err`` on those distances' error; ``g`` bounds every coordinate. The point is
    computed as in `pair` (`_edges_through`): from the lower vertex index, so that both faces
    of an edge compute the same point.

    Returns (lam, dl, first, x, y, z, perr): the parameter along the edge from its
    lower-numbered vertex and its error bound, whether the crossing starts the common segment
    (`crossing_starts`), the point and the bound on each of its coordinates' error
    (`point_err`)."""
    cdef int64_t k1 = (k0 + 1) % 3
    cdef int64_t a = k0, b = k1
    cdef double d_0 = dists[k0], d_1 = dists[k1]
    cdef double du = d_0, dv = d_1, lam, dl, dx, dy, dz
    if index[k0] > index[k1]:
        a, b, du, dv = k1, k0, d_1, d_0
    lam = du / (du - dv)
    dl = param_err(d_0, d_1, err)
    dx = corners[3 * b] - corners[3 * a]
    dy = corners[3 * b + 1] - corners[3 * a + 1]
    dz = corners[3 * b + 2] - corners[3 * a + 2]
    return (
        lam, dl, crossing_starts(row, d_0, d_1),
        corners[3 * a] + lam * dx, corners[3 * a + 1] + lam * dy, corners[3 * a + 2] + lam * dz,
        point_err(dl, max2(max2(fabs(dx), fabs(dy)), fabs(dz)), g),
    )
