# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Stage "pairs" of the exact kernel (Cython, inline): the crossing face pairs, traced along
the curves where the surfaces cross from the seeds' candidates, and their segment terms.

See "Method", steps 2 and 3, and "Why it is exact" in ``docs/exact-backend.md``.
`trace_pairs` runs in stages (`_object_face`, `_planes`, `_on_common_line`, `_line_segment`,
`_exact_pair`, `_evaluate`, `_keep`) that share its state in one `Trace` record: inline
stages cost no reference counts (numba's calls between its functions did).
"""

from libc.math cimport INFINITY, fabs, sqrt
from libc.stdint cimport int64_t, uint64_t
from libc.string cimport memset

from exactgrasp.backends.exact._constants cimport (
    DEGENERATE,
    DIST_ERR,
    FACE_ACROSS,
    FACE_CORNERS,
    FACE_D,
    FACE_D_COST,
    FACE_EDGES,
    FACE_ERR_COEF,
    FACE_LINK,
    FACE_NORMAL,
    FACE_OFFSET,
    FACE_OWNS,
    FACE_VERTICES,
    GRID_MARGIN,
    GROW,
    KAPPA_MAX,
    LINE_ROUNDING,
    LINE_SLACK,
    OK,
    OVERFLOW,
    PARAM_ROUNDING,
    PLANE_ERR,
    PLANE_ERR_NONE,
    PLANE_TOL,
    POINT_CORNER,
    POINT_MESH,
    POINT_STARTS,
    POINT_XYZ,
    SEGMENT_FACE,
    SEGMENT_LINK,
    SEGMENT_NORMAL,
    SEGMENT_OBJECT_FACE,
    SEGMENT_P,
    SEGMENT_Q,
    U,
)
from exactgrasp.backends.exact._pairs cimport corner_crossing, max2, min2, pair, segment_term
from exactgrasp.backends.exact._predicates cimport CROSS, sign
from exactgrasp.backends.exact._tables cimport (
    Crossings,
    HandTables,
    MeshTables,
    ObjectTables,
    Workspace,
)

# Multiplier of the pair table's hash (Fibonacci hashing; the int64 products wrap, so they
# are taken in uint64_t).
cdef extern from *:
    """
    static const int64_t EG_HASH_MULTIPLIER = -7046029254386353131LL;
    """
    const int64_t HASH_MULTIPLIER "EG_HASH_MULTIPLIER"

# The pair table's hash takes the product's bits from this one up.
cdef enum:
    HASH_SHIFT = 24


# The state `trace_pairs` shares with its stages: the call's constants and sums, the object
# face last loaded (s: vertex indices, corners, box widened by the grid margin, unit normal,
# plane offset, tolerances), the hand face of the pair (t: vertex indices, corners, distances
# e to s's plane; distances f of s's corners to t's plane) and the pair's outcome.
ctypedef struct Trace:
    double gscale, gb, margin, ptol
    int64_t token, tag, mask, cap, mb
    double seg, segerr, run
    int64_t ncross, npairs, s_cur
    int64_t si[3]
    double sc[9]
    double smin[3]
    double smax[3]
    double nx, ny, nz, sd, eps_s, tol_e, beta_s
    int64_t ti[3]
    double tc[9]
    double e[3]
    double f[3]
    double eps_t, tol_f
    bint crossing, decided, sided
    int64_t exit_row, exit_k
    double term, terr, px, py, pz, qx, qy, qz


cdef inline double plane_err_coef(double kappa) noexcept nogil:
    """Bound on the error of a plane distance with a face's unit normal, divided by the
    coordinate bound G (`PLANE_ERR`); `PLANE_ERR_NONE` beyond `KAPPA_MAX` (or no normal)."""
    if kappa <= KAPPA_MAX:
        return PLANE_ERR * U * (1.0 + kappa)
    return PLANE_ERR_NONE


cdef inline int64_t _lone(double d0, double d1, double d2) noexcept nogil:
    """Index of the vertex alone on its side of a plane (signed distances d*, none zero,
    not all of one sign): the two edges from it are the ones that cross the plane."""
    if (d0 > 0) == (d1 > 0):
        return 2
    if (d0 > 0) == (d2 > 0):
        return 1
    return 0


cdef inline (double, double, double) _on_line(
    double x0, double x1, double x2, double d0, double d1, double d2, int64_t k, double span,
    double err, double rho,
) noexcept nogil:
    """Where a triangle's two crossing edges meet a plane, projected on a direction (that of
    the plane's line with another plane, as computed): (a, b, error bound), a on the edge
    from the lone vertex k to corner k + 1 (face corner k's edge), b on the edge from k to
    corner k + 2 (corner k + 2's edge). x* are the vertices' projections on that direction,
    d* their signed distances to the plane, all farther than twice their error bound ``err``;
    ``span`` bounds every projected difference of the corners, ``rho`` the projections'
    rounding."""
    cdef double xk, xi, xj, dk, di, dj, ri, rj, a, b
    if k == 0:
        xk, xi, xj, dk, di, dj = x0, x1, x2, d0, d1, d2
    elif k == 1:
        xk, xi, xj, dk, di, dj = x1, x2, x0, d1, d2, d0
    else:
        xk, xi, xj, dk, di, dj = x2, x0, x1, d2, d0, d1
    ri = 1.0 / (fabs(dk) + fabs(di))
    rj = 1.0 / (fabs(dk) + fabs(dj))
    a = xk + (xi - xk) * (fabs(dk) * ri)
    b = xk + (xj - xk) * (fabs(dk) * rj)
    # The exact point's projection is xk + lam* (xi - xk) with |lam - lam*| <= 4 err ri
    # (`param_err`), so a errs by span times that, plus the rounding of the projections.
    return a, b, span * (4.0 * err * max2(ri, rj) + PARAM_ROUNDING) + rho


cdef inline (int64_t, double, double, double) _line_ends(
    const double *corners, const double *d, double Dx, double Dy, double Dz, double span,
    double err, double rho,
) noexcept nogil:
    """Where a face (corners (9: each x, y, z), signed distances ``d`` (3) to the other plane,
    erring by up to ``err``) crosses that plane, projected on direction (Dx, Dy, Dz): its
    lone vertex k (`_lone`), then `_on_line`'s a, b and error bound. Scalars only."""
    cdef int64_t k = _lone(d[0], d[1], d[2])
    cdef double a, b, e
    a, b, e = _on_line(
        Dx * corners[0] + Dy * corners[1] + Dz * corners[2],
        Dx * corners[3] + Dy * corners[4] + Dz * corners[5],
        Dx * corners[6] + Dy * corners[7] + Dz * corners[8],
        d[0], d[1], d[2], k, span, err, rho,
    )
    return k, a, b, e


cdef inline void _object_face(
    Trace *T, MeshTables object_mesh, ObjectTables obj, double[:, ::1] BV,
    double[:, ::1] BN, int64_t s,
) noexcept nogil:
    """Load object face s into ``T``: its vertex indices and corners (moved, ``BV``), its box
    widened by the grid margin, its unit normal (of ``BN``) and plane offset, the error bound
    of a distance to its plane (from its conditioning ``|b - a| |c - a| / |N|``) and the
    tolerance of its plane tests, and what its rounded ``D`` costs its terms."""
    cdef int64_t k, d
    cdef double nrm, inv, l1, l2
    cdef double *c = T.sc
    T.s_cur = s
    for k in range(3):
        T.si[k] = object_mesh.faces[s, k]
        for d in range(3):
            c[3 * k + d] = BV[T.si[k], d]
    for d in range(3):
        T.smax[d] = max2(max2(c[d], c[3 + d]), c[6 + d]) + T.margin
        T.smin[d] = min2(min2(c[d], c[3 + d]), c[6 + d]) - T.margin
    nrm = sqrt(BN[s, 0] * BN[s, 0] + BN[s, 1] * BN[s, 1] + BN[s, 2] * BN[s, 2])
    inv = 1.0 / nrm if nrm > 0 else 0.0
    # The face's conditioning |b - a| |c - a| / |N| widens its tolerances.
    l1 = (c[3] - c[0]) * (c[3] - c[0]) + (c[4] - c[1]) * (c[4] - c[1])
    l1 = l1 + (c[5] - c[2]) * (c[5] - c[2])
    l2 = (c[6] - c[0]) * (c[6] - c[0]) + (c[7] - c[1]) * (c[7] - c[1])
    l2 = l2 + (c[8] - c[2]) * (c[8] - c[2])
    T.eps_s = plane_err_coef(sqrt(l1 * l2) * inv if nrm > 0 else INFINITY) * T.gscale
    T.tol_e = max2(T.ptol, 2.0 * T.eps_s)
    T.beta_s = obj.d_cost[s] * T.gb
    T.nx, T.ny, T.nz = BN[s, 0] * inv, BN[s, 1] * inv, BN[s, 2] * inv
    T.sd = T.nx * c[0] + T.ny * c[1] + T.nz * c[2]


cdef inline bint _planes(Trace *T, HandTables hand, int64_t ft) noexcept nogil:
    """Load hand face ft into ``T`` from its record (`HandTables.face_records`,
    ``face_links``: a few cache lines instead of one per array and vertex) and test both
    faces against the other's plane in floating point, with a tolerance far above rounding
    (the exact tests follow in `pair`): whether they are certainly apart. Fills ``T.e``
    (t's corners against s's plane) and, unless t is apart from it, ``T.f``, ``T.eps_t`` and
    ``T.tol_f`` (s's corners against t's plane), else zeros."""
    cdef int64_t k
    cdef double tol_e = T.tol_e, tol_f
    cdef double *e = T.e
    cdef double *f = T.f
    cdef bint apart
    for k in range(3):
        T.ti[k] = hand.face_links[ft, FACE_VERTICES + k]
    for k in range(9):
        T.tc[k] = hand.face_records[ft, FACE_CORNERS + k]
    for k in range(3):
        e[k] = T.tc[3 * k] * T.nx + T.tc[3 * k + 1] * T.ny + T.tc[3 * k + 2] * T.nz - T.sd
        f[k] = 0.0
    T.eps_t = T.tol_f = 0.0
    apart = ((e[0] > tol_e) & (e[1] > tol_e) & (e[2] > tol_e)) | (
        (e[0] < -tol_e) & (e[1] < -tol_e) & (e[2] < -tol_e)
    )
    if apart:
        return True
    for k in range(3):
        f[k] = (
            T.sc[3 * k] * hand.face_records[ft, FACE_NORMAL]
            + T.sc[3 * k + 1] * hand.face_records[ft, FACE_NORMAL + 1]
            + T.sc[3 * k + 2] * hand.face_records[ft, FACE_NORMAL + 2]
            - hand.face_records[ft, FACE_OFFSET]
        )
    T.eps_t = hand.face_records[ft, FACE_ERR_COEF] * T.gscale
    T.tol_f = tol_f = max2(T.ptol, 2.0 * T.eps_t)
    return ((f[0] > tol_f) & (f[1] > tol_f) & (f[2] > tol_f)) | (
        (f[0] < -tol_f) & (f[1] < -tol_f) & (f[2] < -tol_f)
    )


cdef inline bint _record_line(
    Crossings rec, int64_t[::1] count, int64_t[::1] nrec, int64_t row, int64_t ed,
    double lam, double dl, int64_t cap,
) noexcept nogil:
    """Record a crossing of edge ``ed`` (parameter lam, error bound dl) found on the common
    line in row ``row``'s records ``rec`` and count it in ``count[ed]``; False, recording
    nothing, when ``cap`` records are there already."""
    if nrec[row] >= cap:
        return False
    rec.edge[nrec[row]] = ed
    rec.lam[nrec[row]] = lam
    rec.err[nrec[row]] = dl
    nrec[row] += 1
    count[ed] += 1
    return True


cdef inline int64_t _line_segment(
    Trace *T, HandTables hand, MeshTables object_mesh, double[:, ::1] BD, Workspace W,
    int64_t ft, int64_t s, int64_t kt, double at, double bt, int64_t ks, double as_,
    double bs,
) noexcept nogil:
    """The segment of a pair decided on the common line: the overlap's two ends, each where
    an edge of one face crosses the other face (`corner_crossing`, on scalars; t's ends at,
    bt from its lone corner kt, s's as_, bs from ks); the face owning that edge records it,
    in its own mesh's arrays. Sets ``T``'s term, its error, the points p (start) and q (end)
    and the end's edge (``exit_row``, ``exit_k``: the curve goes on across it). Returns `OK`,
    `OVERFLOW` (records full) or `DEGENERATE` (not one start and one end)."""
    cdef double lot = min2(at, bt), hit = max2(at, bt)
    cdef double los = min2(as_, bs), his = max2(as_, bs)
    cdef double lam, dl, x, y, z, perr, end, ep = 0.0, eq = 0.0
    cdef int64_t npt = 0, nstart = 0, w, k0
    cdef bint first
    T.px = T.py = T.pz = T.qx = T.qy = T.qz = 0.0
    for w in range(4):
        if w < 2:
            end = at if w == 0 else bt
            if not (los < end < his):
                continue
            k0 = kt if w == 0 else (kt + 2) % 3
            lam, dl, first, x, y, z, perr = corner_crossing(
                0, k0, T.ti, T.tc, T.e, T.eps_s, T.gscale
            )
            if hand.face_links[ft, FACE_OWNS + k0] and not _record_line(
                W.hand_rec, W.hand_count, W.nrec, 0, hand.face_links[ft, FACE_EDGES + k0],
                lam, dl, T.cap,
            ):
                return OVERFLOW
        else:
            end = as_ if w == 2 else bs
            if not (lot < end < hit):
                continue
            k0 = ks if w == 2 else (ks + 2) % 3
            lam, dl, first, x, y, z, perr = corner_crossing(
                1, k0, T.si, T.sc, T.f, T.eps_t, T.gscale
            )
            if object_mesh.face_owns[s, k0] and not _record_line(
                W.object_rec, W.object_count, W.nrec, 1, object_mesh.face_edges[s, k0],
                lam, dl, T.cap,
            ):
                return OVERFLOW
        # The segment runs from its start to its end along n_t x n_s; the curve goes on
        # across the end's edge.
        if first:
            T.px, T.py, T.pz, ep = x, y, z, perr
            nstart += 1
        else:
            T.qx, T.qy, T.qz, eq = x, y, z, perr
            T.exit_row = 0 if w < 2 else 1
            T.exit_k = k0
        npt += 1
    if npt != 2 or nstart != 1:
        return DEGENERATE
    T.term, T.terr = segment_term(
        T.px, T.py, T.pz, T.qx, T.qy, T.qz, ep, eq,
        hand.face_records[ft, FACE_D], hand.face_records[ft, FACE_D + 1],
        hand.face_records[ft, FACE_D + 2], BD[s, 0], BD[s, 1], BD[s, 2],
    )
    T.crossing = T.decided = True
    return OK


cdef inline int64_t _on_common_line(
    Trace *T, HandTables hand, MeshTables object_mesh, double[:, ::1] BD, Workspace W,
    int64_t ft, int64_t s,
) noexcept nogil:
    """Both planes straddled and every vertex clear of the other plane: the faces' crossing
    segments on the planes' common line decide in floating point where every end of one is
    far (beyond rounding) from both ends of the other (apart, or `_line_segment`). Anything
    closer goes to the exact `pair`, with the signs and distances filled here. Returns `OK`,
    `OVERFLOW` or `DEGENERATE`."""
    cdef double ux = hand.face_records[ft, FACE_NORMAL]
    cdef double uy = hand.face_records[ft, FACE_NORMAL + 1]
    cdef double uz = hand.face_records[ft, FACE_NORMAL + 2]
    cdef double Dx = uy * T.nz - uz * T.ny
    cdef double Dy = uz * T.nx - ux * T.nz
    cdef double Dz = ux * T.ny - uy * T.nx
    cdef double ext = 0.0, dnorm, span, rho, at, bt, errt, as_, bs, errs, tol
    cdef int64_t d, kt, ks
    cdef double *c = T.tc
    # Extent of the six corners (the object face's by its box).
    for d in range(3):
        tol = max2(max2(max2(T.smax[d], c[d]), c[3 + d]), c[6 + d]) - min2(
            min2(min2(T.smin[d], c[d]), c[3 + d]), c[6 + d]
        )
        ext = tol if d == 0 else max2(ext, tol)
    # Any direction serves: the four points lie on the common line, so their order along it
    # is their order here (or reversed).
    dnorm = fabs(Dx) + fabs(Dy) + fabs(Dz)
    span = ext * dnorm
    rho = LINE_ROUNDING * U * dnorm * T.gscale
    kt, at, bt, errt = _line_ends(T.tc, T.e, Dx, Dy, Dz, span, T.eps_s, rho)
    ks, as_, bs, errs = _line_ends(T.sc, T.f, Dx, Dy, Dz, span, T.eps_t, rho)
    tol = (errt + errs) * LINE_SLACK
    if max2(min2(as_, bs) - max2(at, bt), min2(at, bt) - max2(as_, bs)) > tol:
        T.decided = True
        return OK
    if min2(min2(min2(fabs(at - as_), fabs(at - bs)), fabs(bt - as_)), fabs(bt - bs)) > tol:
        return _line_segment(T, hand, object_mesh, BD, W, ft, s, kt, at, bt, ks, as_, bs)
    for d in range(3):
        W.signs[0, d] = sign(T.e[d])
    for d in range(3):
        W.signs[1, d] = sign(T.f[d])
    for d in range(3):
        W.dists[0, d] = T.e[d]
    W.dists[0, DIST_ERR] = T.eps_s
    for d in range(3):
        W.dists[1, d] = T.f[d]
    W.dists[1, DIST_ERR] = T.eps_t
    return OK


cdef inline int64_t _exact_pair(
    Trace *T, MeshTables hand_mesh, HandTables hand, MeshTables object_mesh,
    double[:, ::1] BV, double[:, ::1] BD, Workspace W, int64_t ft, int64_t s,
) noexcept nogil:
    """The pair by the exact `pair` (with the signs and distances `_on_common_line` filled
    where ``T.sided``): on a crossing, ``T``'s term, its error, the points p (start) and q
    (end) and the end's edge. Returns `OK`, `DEGENERATE` or `OVERFLOW`."""
    cdef int64_t pc, j
    T.term, T.terr, pc = pair(
        ft, s, hand_mesh, hand_mesh.vertices, hand.D, object_mesh, BV, BD, W, T.sided,
        T.gscale,
    )
    if pc >= DEGENERATE:
        return DEGENERATE if pc == DEGENERATE else OVERFLOW
    if pc == CROSS:
        T.crossing = True
        j = 0 if W.points[0, POINT_STARTS] == 0.0 else 1
        T.exit_row = <int64_t>W.points[j, POINT_MESH]
        T.exit_k = <int64_t>W.points[j, POINT_CORNER]
        T.px = W.points[1 - j, POINT_XYZ]
        T.py = W.points[1 - j, POINT_XYZ + 1]
        T.pz = W.points[1 - j, POINT_XYZ + 2]
        T.qx = W.points[j, POINT_XYZ]
        T.qy = W.points[j, POINT_XYZ + 1]
        T.qz = W.points[j, POINT_XYZ + 2]
    return OK


cdef inline int64_t _evaluate(
    Trace *T, MeshTables hand_mesh, HandTables hand, MeshTables object_mesh, ObjectTables obj,
    double[:, ::1] BV, double[:, ::1] BD, double[:, ::1] BN, Workspace W, int64_t ft,
    int64_t s,
) noexcept nogil:
    """Evaluate pair (ft, s): the plane tests (`_planes`), then the common line where both
    faces straddle the other's plane with every vertex clear of it (`_on_common_line`), then
    where undecided the exact `pair`. Sets ``T.crossing`` and, on a crossing, the term, its
    error, the segment's ends and the end's edge. Returns `OK`, `DEGENERATE` or
    `OVERFLOW`."""
    cdef int64_t code
    cdef bint apart
    if s != T.s_cur:
        _object_face(T, object_mesh, obj, BV, BN, s)
    T.crossing = False
    T.exit_row = T.exit_k = 0
    T.term = T.terr = 0.0
    T.sided = False
    apart = _planes(T, hand, ft)
    T.decided = apart
    if not apart:
        T.sided = (min2(min2(fabs(T.e[0]), fabs(T.e[1])), fabs(T.e[2])) > T.tol_e) & (
            min2(min2(fabs(T.f[0]), fabs(T.f[1])), fabs(T.f[2])) > T.tol_f
        )
        if T.sided:
            code = _on_common_line(T, hand, object_mesh, BD, W, ft, s)
            if code != OK:
                return code
        if not T.decided:
            return _exact_pair(T, hand_mesh, hand, object_mesh, BV, BD, W, ft, s)
    return OK


cdef inline void _keep(
    Trace *T, HandTables hand, Workspace W, int64_t ft, int64_t s
) noexcept nogil:
    """A crossing pair (ft, s): its segment in ``W.segments`` (for the derivatives; none
    kept where that has no rows) and its term and error bound in the sums."""
    cdef int64_t n = T.ncross
    if W.segments.shape[0] > 0:
        W.segments[n, SEGMENT_FACE] = ft
        W.segments[n, SEGMENT_P] = T.px
        W.segments[n, SEGMENT_P + 1] = T.py
        W.segments[n, SEGMENT_P + 2] = T.pz
        W.segments[n, SEGMENT_Q] = T.qx
        W.segments[n, SEGMENT_Q + 1] = T.qy
        W.segments[n, SEGMENT_Q + 2] = T.qz
        W.segments[n, SEGMENT_NORMAL] = hand.face_records[ft, FACE_NORMAL]
        W.segments[n, SEGMENT_NORMAL + 1] = hand.face_records[ft, FACE_NORMAL + 1]
        W.segments[n, SEGMENT_NORMAL + 2] = hand.face_records[ft, FACE_NORMAL + 2]
        W.segments[n, SEGMENT_LINK] = hand.face_records[ft, FACE_LINK]
        W.segments[n, SEGMENT_OBJECT_FACE] = s
    T.seg += T.term
    T.run += fabs(T.seg)
    T.segerr += T.terr + hand.face_records[ft, FACE_D_COST] + T.beta_s
    T.ncross += 1


cdef inline int64_t _slot(Trace *T, Workspace W, int64_t key) noexcept nogil:
    """The pair table's slot of ``key``: where this call stored it, else the first slot
    this call has not used after the key's hash (open addressing)."""
    cdef int64_t h = (
        <int64_t>(<uint64_t>key * <uint64_t>HASH_MULTIPLIER) >> HASH_SHIFT
    ) & T.mask
    while (W.pair_tags[h] >> 1) == T.token and W.pair_keys[h] != key:
        h = (h + 1) & T.mask
    return h


cdef inline (double, double, int64_t, int64_t, int64_t) trace_pairs(
    MeshTables hand_mesh, HandTables hand, MeshTables object_mesh, ObjectTables obj,
    double[:, ::1] BV, double[:, ::1] BD, double[:, ::1] BN, Workspace W, int64_t nseeds,
    double gscale, double gb, double hcell, int64_t token,
) noexcept nogil:
    """Stage "pairs" of a pose (``docs/exact-backend.md``, "Method", steps 2 and 3): every
    crossing face pair and its segment term, by tracing the curves where the surfaces cross
    from the candidate pairs ``W.seeds[:nseeds]``. A crossing pair's segment ends where an
    edge of one face crosses the other; the next pair along the curve is the face across
    that edge with the other face. Every pair is evaluated once (``W.pair_keys``: an
    open-addressing table tagged with ``token``, unique per call, positive, below 2**30); a
    pair reached along a curve must cross, one that does not is an inconsistency.

    BV, BD, BN (object n, 3), (object m, 3), (object m, 3) are the moved object's vertices,
    face ``D`` and normals; ``gscale``, ``gb`` bound every coordinate of the pose and of the
    moved object; ``hcell`` is the hand grid's cell edge. Returns (segment sum, its error
    bound, crossings, pairs evaluated, code), code `OK`, `DEGENERATE` (an uncertain sign or
    an inconsistency), `OVERFLOW` (records full) or `GROW` (the pair table is half full)."""
    cdef Trace T
    cdef int64_t k, ft, s, key, h, code, ed
    cdef bint chained
    memset(&T, 0, sizeof(Trace))
    T.gscale, T.gb = gscale, gb
    T.margin = GRID_MARGIN * hcell
    # Plane distances below this may be sign-uncertain in floating point; far above rounding.
    T.ptol = PLANE_TOL * hcell
    # A slot of this call holds 2 token (no crossing) or 2 token + 1 (a crossing).
    T.token, T.tag = token, 2 * token
    T.mask = W.pair_keys.shape[0] - 1
    T.cap = W.hand_rec.edge.shape[0]
    T.mb = object_mesh.faces.shape[0]
    T.s_cur = -1
    for k in range(nseeds):
        ft, s = W.seeds[k, 0], W.seeds[k, 1]
        chained = False
        while True:
            key = ft * T.mb + s
            h = _slot(&T, W, key)
            if (W.pair_tags[h] >> 1) == token:
                # Evaluated already: the rest of its curve is traced (or being traced).
                if chained and W.pair_tags[h] == T.tag:
                    return T.seg, T.segerr, T.ncross, T.npairs, DEGENERATE
                break
            if 2 * (T.npairs + 1) > T.mask + 1:
                return T.seg, T.segerr, T.ncross, T.npairs, GROW
            W.pair_tags[h] = T.tag
            W.pair_keys[h] = key
            T.npairs += 1
            code = _evaluate(&T, hand_mesh, hand, object_mesh, obj, BV, BD, BN, W, ft, s)
            if code != OK:
                return T.seg, T.segerr, T.ncross, T.npairs, code
            if not T.crossing:
                if chained:
                    return T.seg, T.segerr, T.ncross, T.npairs, DEGENERATE
                break
            W.pair_tags[h] = T.tag + 1
            _keep(&T, hand, W, ft, s)
            chained = True
            # The next pair along the curve: across the end's edge.
            if T.exit_row == 0:
                ft = hand.face_links[ft, FACE_ACROSS + T.exit_k]
            else:
                ed = object_mesh.face_edges[s, T.exit_k]
                s = object_mesh.edge_faces[ed, 1] if object_mesh.edge_faces[ed, 0] == s else (
                    object_mesh.edge_faces[ed, 0]
                )
    return T.seg, T.segerr + U * T.run, T.ncross, T.npairs, OK
