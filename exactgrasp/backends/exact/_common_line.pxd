# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Stage "pairs" of the exact kernel (Cython, inline), its common-line test: where both faces
of a pair straddle the other's plane with every vertex clear of it, their crossing segments on
the planes' common line decide the pair in floating point wherever every end of one is far
(beyond rounding) from both ends of the other (`_on_common_line`); the rest goes to the exact
`_pairs.pair`. Also the `Trace` record, the state `_search.trace_pairs` shares with its
stages, these included.

See "Method", steps 2 and 3, and "Why it is exact" in ``docs/exact-backend.md``.
"""

from libc.math cimport fabs
from libc.stdint cimport int64_t

from exactgrasp.backends.exact._constants cimport (
    DEGENERATE,
    DIST_ERR,
    FACE_D,
    FACE_EDGES,
    FACE_NORMAL,
    FACE_OWNS,
    LINE_ROUNDING,
    LINE_SLACK,
    OK,
    OVERFLOW,
    PARAM_ROUNDING,
    U,
)
from exactgrasp.backends.exact._pairs cimport corner_crossing, segment_term
from exactgrasp.backends.exact._predicates cimport sign
from exactgrasp.backends.exact._tables cimport (
    Crossings,
    HandTables,
    MeshTables,
    Workspace,
)
from exactgrasp.geometry._minmax cimport max2, min2


# The state `_search.trace_pairs` shares with its stages: the call's constants and sums, the
# object face last loaded (s: vertex indices, corners, box widened by the grid margin, unit
# normal, plane offset, tolerances), the hand face of the pair (t: vertex indices, corners,
# distances e to s's plane; distances f of s's corners to t's plane) and the pair's outcome.
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
