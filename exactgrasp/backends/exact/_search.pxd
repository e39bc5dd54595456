# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Stage "pairs" of the exact kernel (Cython, inline): the crossing face pairs, traced along
the curves where the surfaces cross from the seeds' candidates, and their segment terms.

See "Method", steps 2 and 3, and "Why it is exact" in ``docs/exact-backend.md``.
`trace_pairs` runs in stages (`_object_face`, `_planes`, `_common_line._on_common_line`,
`_exact_pair`, `_evaluate`, `_keep`) that share its state in one `_common_line.Trace` record:
inline stages cost no reference counts (numba's calls between its functions did).
"""

from libc.math cimport INFINITY, fabs, sqrt
from libc.stdint cimport int64_t, uint64_t
from libc.string cimport memset

from exactgrasp.backends.exact._common_line cimport Trace, _on_common_line
from exactgrasp.backends.exact._constants cimport (
    DEGENERATE,
    FACE_ACROSS,
    FACE_CORNERS,
    FACE_D_COST,
    FACE_ERR_COEF,
    FACE_LINK,
    FACE_NORMAL,
    FACE_OFFSET,
    FACE_VERTICES,
    GRID_MARGIN,
    GROW,
    KAPPA_MAX,
    OK,
    OVERFLOW,
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
from exactgrasp.backends.exact._pairs cimport pair
from exactgrasp.backends.exact._predicates cimport CROSS
from exactgrasp.backends.exact._prefetch cimport prefetch
from exactgrasp.backends.exact._tables cimport (
    HandTables,
    MeshTables,
    ObjectTables,
    Workspace,
)
from exactgrasp.geometry._minmax cimport max2, min2

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


cdef inline double plane_err_coef(double kappa) noexcept nogil:
    """Bound on the error of a plane distance with a face's unit normal, divided by the
    coordinate bound G (`PLANE_ERR`); `PLANE_ERR_NONE` beyond `KAPPA_MAX` (or no normal)."""
    if kappa <= KAPPA_MAX:
        return PLANE_ERR * U * (1.0 + kappa)
    return PLANE_ERR_NONE


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


cdef inline void _prefetch_across(HandTables hand, int64_t ft) noexcept nogil:
    """Ask for the rows of the hand faces across ft's edges (their links and their records'
    first 120 bytes: normal, offset, error, cost, corners), which the pairs after ft's
    along a curve read first: the hand's tables exceed the caches, and a curve's next face is
    anywhere in them."""
    cdef int64_t k, g
    for k in range(3):
        g = hand.face_links[ft, FACE_ACROSS + k]
        prefetch(&hand.face_links[g, 0])
        prefetch(&hand.face_records[g, 0])
        prefetch(&hand.face_records[g, FACE_CORNERS + 2])
        prefetch(&hand.face_records[g, FACE_CORNERS + 8])


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
    cdef int64_t k, ft, s, key, h, code, ed, ft_near = -1
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
            if ft != ft_near:
                _prefetch_across(hand, ft)
                ft_near = ft
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
