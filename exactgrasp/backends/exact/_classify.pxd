# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Stage "classify" of the exact kernel (Cython, inline): the in/out status of every vertex of
either mesh against the other, from the grids' cell statuses, the crossings' parities along
edges and, for a shell with no classified vertex, one exact point test.

The arithmetic of the numba stage it replaced, operation for operation. See "Method", steps
1, 4 and 5, and "Culling rules" in ``docs/exact-backend.md``.
"""

from libc.math cimport floor
from libc.stdint cimport int8_t, int64_t, uint8_t

from exactgrasp.backends.exact._cells cimport cell_index
from exactgrasp.backends.exact._constants cimport DEGENERATE, OK, PART_FIRST_VERTEX
from exactgrasp.backends.exact._constants cimport GRID_MARGIN, ROUNDING_PAD
from exactgrasp.backends.exact._predicates cimport edge_triangle
from exactgrasp.backends.exact._tables cimport CellGrid, HandTables, MeshTables
from exactgrasp.backends.exact._tables cimport ObjectTables, PoseScratch
from exactgrasp.geometry._minmax cimport max2, min2
from exactgrasp.geometry._predicates cimport orient, orient_bound


cdef inline void spread(
    int8_t[::1] S, int64_t[::1] adj_start, int64_t[::1] adj_vert, int64_t[::1] adj_edge,
    int64_t[::1] cnt, int64_t[::1] queue, int64_t tail,
) noexcept nogil:
    """Breadth-first from the ``tail`` vertices in ``queue``: every unknown (-1) neighbour
    takes the status of the vertex it is reached from, flipped by the parity of the crossings
    on the edge between them."""
    cdef int64_t head = 0, u, k, w
    while head < tail:
        u = queue[head]
        head += 1
        for k in range(adj_start[u], adj_start[u + 1]):
            w = adj_vert[k]
            if S[w] == -1:
                S[w] = <int8_t>(S[u] ^ (cnt[adj_edge[k]] & 1))
                queue[tail] = w
                tail += 1


cdef inline int64_t next_unknown(
    int8_t[::1] S, int64_t start, int64_t[:, ::1] reps, uint8_t[::1] uniform
) noexcept nogil:
    """The first vertex at or after ``start`` whose status is unknown (-1), or -1. Parts
    classified whole (``uniform``, see `hand_statuses`) are known and skipped."""
    cdef int64_t k, u, first
    for k in range(reps.shape[0] - 1):
        if uniform[k] or reps[k + 1, PART_FIRST_VERTEX] <= start:
            continue
        first = reps[k, PART_FIRST_VERTEX]
        for u in range(first if first > start else start, reps[k + 1, PART_FIRST_VERTEX]):
            if S[u] == -1:
                return u
    return -1


cdef inline int64_t resolve(
    int8_t[::1] S, int64_t[::1] adj_start, int64_t[::1] adj_vert, int64_t[::1] adj_edge,
    int64_t[::1] cnt, int64_t[::1] queue, int64_t[:, ::1] reps, uint8_t[::1] uniform,
) noexcept nogil:
    """Give every vertex of unknown status (-1) the status of a neighbour, flipped by the
    parity of the crossings on the edge between them. Returns the first vertex still unknown
    (its component has no vertex of known status), or -1. Only the parts (``reps`` (p + 1, 2),
    see `tables.HandTables.parts`) not classified whole (``uniform``) are searched."""
    cdef int64_t tail = 0, p, u, k, w
    for p in range(reps.shape[0] - 1):
        if uniform[p]:
            continue
        for u in range(reps[p, PART_FIRST_VERTEX], reps[p + 1, PART_FIRST_VERTEX]):
            if S[u] != -1:
                continue
            for k in range(adj_start[u], adj_start[u + 1]):
                w = adj_vert[k]
                if S[w] >= 0:
                    S[u] = <int8_t>(S[w] ^ (cnt[adj_edge[k]] & 1))
                    queue[tail] = u
                    tail += 1
                    break
    spread(S, adj_start, adj_vert, adj_edge, cnt, queue, tail)
    return next_unknown(S, 0, reps, uniform)


cdef inline void object_statuses(int8_t[::1] S, double[:, ::1] V, CellGrid grid) noexcept nogil:
    """Status of every vertex of V (n, 3) in the other mesh's grid (1 inside, 0 outside, -1 in
    a cell the other surface touches), V being in that mesh's frame."""
    cdef double ih = 1.0 / grid.cell
    cdef double l0 = grid.corner[0], l1 = grid.corner[1], l2 = grid.corner[2]
    cdef int64_t n0 = grid.shape[0], n1 = grid.shape[1], n2 = grid.shape[2]
    cdef int64_t[::1] status = grid.status
    cdef int64_t i, c
    for i in range(V.shape[0]):
        c = cell_index(V[i, 0], V[i, 1], V[i, 2], l0, l1, l2, ih, n0, n1, n2)
        S[i] = 0 if c < 0 else <int8_t>status[c]


cdef inline bint _off_centre(double u, double near) noexcept nogil:
    """Whether coordinate ``u`` (in cell units) lies within ``near`` of a cell boundary."""
    cdef double f = u - floor(u)
    return (f < near) | (f > 1.0 - near)


cdef inline void hand_statuses(
    int8_t[::1] S, double[:, ::1] V, const double[:, :] R, const double[:] t, CellGrid grid,
    int64_t[:, ::1] reps, uint8_t[::1] crossed, bint whole, uint8_t[::1] uniform, double err,
) noexcept nogil:
    """`object_statuses` of the hand's vertices V (n, 3) in the object's grid, part by part
    (``reps``, `tables.HandTables.parts`), the vertices moved by ``x -> R^T (x - t)``.

    A part none of whose own edges is crossed (``crossed[k]`` False; with ``whole``) has one
    status: the first vertex found in a cell of known status gives every vertex's status
    (``uniform[k]`` True). Other parts get a status per vertex (-1 where unknown). Where
    ``err`` (length) exceeds the cells' margin (`GRID_MARGIN`), a vertex within ``err`` of its
    cell's boundary is unknown (-1)."""
    cdef double ih = 1.0 / grid.cell
    cdef int64_t[::1] status = grid.status
    # In cell units: a fraction of a cell this close to 0 or 1 is near the cell's boundary.
    cdef double near = err * ih if err > GRID_MARGIN * grid.cell else -1.0
    cdef double l0 = grid.corner[0], l1 = grid.corner[1], l2 = grid.corner[2]
    cdef int64_t n0 = grid.shape[0], n1 = grid.shape[1], n2 = grid.shape[2]
    cdef double r00 = R[0, 0], r01 = R[0, 1], r02 = R[0, 2]
    cdef double r10 = R[1, 0], r11 = R[1, 1], r12 = R[1, 2]
    cdef double r20 = R[2, 0], r21 = R[2, 1], r22 = R[2, 2]
    cdef double t0 = t[0], t1 = t[1], t2 = t[2]
    cdef double d0, d1, d2, x, y, z
    cdef int64_t k, i, c, si, st
    cdef bint each
    for k in range(reps.shape[0] - 1):
        each = not (whole and not crossed[k])
        st = -1
        for i in range(reps[k, PART_FIRST_VERTEX], reps[k + 1, PART_FIRST_VERTEX]):
            d0, d1, d2 = V[i, 0] - t0, V[i, 1] - t1, V[i, 2] - t2
            x = r00 * d0 + r10 * d1 + r20 * d2
            y = r01 * d0 + r11 * d1 + r21 * d2
            z = r02 * d0 + r12 * d1 + r22 * d2
            c = cell_index(x, y, z, l0, l1, l2, ih, n0, n1, n2)
            si = 0 if c < 0 else status[c]
            if near > 0.0 and (_off_centre((x - l0) * ih, near) or _off_centre((y - l1) * ih, near)
                               or _off_centre((z - l2) * ih, near)):
                si = -1
            if each:
                S[i] = <int8_t>si
            elif si >= 0:
                st = si
                break
        uniform[k] = not each and st >= 0
        if not each:
            for i in range(reps[k, PART_FIRST_VERTEX], reps[k + 1, PART_FIRST_VERTEX]):
                S[i] = <int8_t>st


cdef inline int64_t _ray_face(
    double x0, double x1, double x2, double yx, double yy, double yz,
    double[:, ::1] V, int64_t[:, ::1] F, int64_t f, double xerr,
) noexcept nogil:
    """`edge_triangle`'s code for segment x y against face f of mesh (V, F), with certified
    orientation signs whose bound widens by what moving x by ``xerr`` can change them."""
    cdef int64_t a = F[f, 0], b = F[f, 1], d = F[f, 2]
    cdef double ext = 0.0, hi, lo_, y_ax, x_ax, dp, dq, bound, span, va, vb, vd
    cdef int64_t ax, sp, sq, code
    cdef bint okp, okq
    for ax in range(3):
        y_ax = yx if ax == 0 else (yy if ax == 1 else yz)
        x_ax = x0 if ax == 0 else (x1 if ax == 1 else x2)
        va, vb, vd = V[a, ax], V[b, ax], V[d, ax]
        hi = max2(max2(max2(max2(va, vb), vd), x_ax), y_ax)
        lo_ = min2(min2(min2(min2(va, vb), vd), x_ax), y_ax)
        span = hi - lo_
        if span > ext:
            ext = span
    # An orientation with x as a corner moves by at most |(p - q) x (r - q)| <= 3 ext²
    # times x's displacement.
    bound = orient_bound(ext * ROUNDING_PAD) + 4.0 * ext * ext * xerr
    dp = orient(V[a, 0], V[a, 1], V[a, 2], V[b, 0], V[b, 1], V[b, 2], V[d, 0], V[d, 1],
                V[d, 2], x0, x1, x2, bound, &okp)
    dq = orient(V[a, 0], V[a, 1], V[a, 2], V[b, 0], V[b, 1], V[b, 2], V[d, 0], V[d, 1],
                V[d, 2], yx, yy, yz, bound, &okq)
    sp = 0 if not okp else (1 if dp > 0 else -1)
    sq = 0 if not okq else (1 if dq > 0 else -1)
    code = edge_triangle(x0, x1, x2, yx, yy, yz, V[a, 0], V[a, 1], V[a, 2], V[b, 0], V[b, 1],
                         V[b, 2], V[d, 0], V[d, 1], V[d, 2], sp, dp, sq, dq, bound)[0]
    return code


cdef inline int64_t ray_status(
    double[::1] x, double[:, ::1] V, int64_t[:, ::1] F, CellGrid grid, int64_t[::1] fstamp,
    int64_t token, double xerr,
) noexcept nogil:
    """Inside (1) or outside (0) of point x (3,) against a closed mesh (V (n, 3), F (m, 3)) with
    its cell grid, exactly (-1: x on or very near a face): the status of the first known cell
    along +x, flipped by the parity of the faces crossing the segment to its centre. ``fstamp``
    (m,) marks faces tested (``token``: this test). ``xerr`` (length) bounds how far x may lie
    from the point meant: the bounds widen by it; beyond `GRID_MARGIN` the answer is -1."""
    cdef double h = grid.cell
    cdef double l0 = grid.corner[0], l1 = grid.corner[1], l2 = grid.corner[2]
    cdef int64_t n0 = grid.shape[0], n1 = grid.shape[1], n2 = grid.shape[2]
    cdef int64_t[::1] status = grid.status, cs = grid.cell_start, ct = grid.cell_faces
    cdef int64_t i, j, k, end, known, parity, ii, c, q, f, code
    cdef double yx, yy, yz
    if xerr >= GRID_MARGIN * h:
        return -1
    i = <int64_t>floor((x[0] - l0) / h)
    j = <int64_t>floor((x[1] - l1) / h)
    k = <int64_t>floor((x[2] - l2) / h)
    if i < 0 or j < 0 or k < 0 or i >= n0 or j >= n1 or k >= n2:
        return 0
    end = i
    known = -1
    while end < n0:
        known = status[(end * n1 + j) * n2 + k]
        if known >= 0:
            break
        end += 1
    if known < 0:
        return -1
    yx = l0 + (end + 0.5) * h
    yy = l1 + (j + 0.5) * h
    yz = l2 + (k + 0.5) * h
    parity = 0
    for ii in range(i, end):
        c = (ii * n1 + j) * n2 + k
        for q in range(cs[c], cs[c + 1]):
            f = ct[q]
            if fstamp[f] == token:
                continue
            fstamp[f] = token
            code = _ray_face(x[0], x[1], x[2], yx, yy, yz, V, F, f, xerr)
            if code == DEGENERATE:
                return -1
            parity ^= code
    return known ^ parity


cdef inline bint _shell_straddles(
    const double[:, ::1] V, const int64_t[::1] comp, uint8_t[:, ::1] seen,
    const double[:, :] R, const double[:] t, bint inverse, CellGrid grid,
) noexcept nogil:
    """Whether some shell of mesh V (n, 3) (vertex -> shell `comp` (n,)) has a vertex in a
    cell wholly inside the other mesh and one in a cell wholly outside it; the vertices move
    by x -> R x + t (or by the inverse transform) into the frame of the other mesh's `grid`.
    ``seen`` (shells, 2) is scratch."""
    cdef double h = grid.cell
    cdef int64_t[::1] status = grid.status
    cdef double x[3]
    cdef int64_t i, k, c, st
    seen[:, :] = 0
    for i in range(V.shape[0]):
        for k in range(3):
            if inverse:
                x[k] = (R[0, k] * (V[i, 0] - t[0]) + R[1, k] * (V[i, 1] - t[1])
                        + R[2, k] * (V[i, 2] - t[2]))
            else:
                x[k] = R[k, 0] * V[i, 0] + R[k, 1] * V[i, 1] + R[k, 2] * V[i, 2] + t[k]
        # `_cells.point_status`, on a point held in C.
        c = cell_index(x[0], x[1], x[2], grid.corner[0], grid.corner[1], grid.corner[2],
                       1.0 / h, grid.shape[0], grid.shape[1], grid.shape[2])
        st = 0 if c < 0 else status[c]
        if st < 0:
            continue
        seen[comp[i], st] = 1
        if seen[comp[i], 0] and seen[comp[i], 1]:
            return True
    return False


cdef inline void surfaces_cross(
    const double[:, :, :] poses, const double[:, ::1] AV, const int64_t[::1] acomp,
    CellGrid agrid, const double[:, ::1] BV0, const int64_t[::1] bcomp, CellGrid bgrid,
    uint8_t[::1] out, uint8_t[:, ::1] aseen, uint8_t[:, ::1] bseen,
) noexcept nogil:
    """Per pose (k, 4, 4), whether the moved object's surface certainly crosses the hand's
    (``out`` (k,)): a connected shell of either mesh has one vertex in a cell wholly inside
    the other mesh and another in a cell wholly outside it. Such a pose can never be culled
    (False means "not known", not "apart"). ``aseen``, ``bseen`` (shells, 2) are scratch."""
    cdef int64_t ip
    for ip in range(poses.shape[0]):
        out[ip] = _shell_straddles(
            BV0, bcomp, bseen, poses[ip, :3, :3], poses[ip, :3, 3], False, agrid
        ) or _shell_straddles(AV, acomp, aseen, poses[ip, :3, :3], poses[ip, :3, 3], True, bgrid)


cdef inline (int64_t, int64_t) _hand_points(
    const double[:, :] R, const double[:] t, MeshTables hand_mesh, HandTables hand,
    MeshTables object_mesh, CellGrid object_grid, PoseScratch scratch, int64_t token,
    double ferr,
) noexcept nogil:
    """The hand's unknown vertices from their neighbours, and per shell with none known one
    exact point test in the object's frame (`ray_status`). Returns (code, token)."""
    cdef int8_t[::1] AS = scratch.hand_status
    cdef int64_t[::1] queue = scratch.queue
    cdef double[::1] xq = scratch.point
    cdef double[:, ::1] AV = hand_mesh.vertices
    cdef int64_t code = OK, u, k
    u = resolve(
        AS, hand_mesh.adj_start, hand_mesh.adj_vertex, hand_mesh.adj_edge,
        scratch.work.hand_count, queue, hand.parts, scratch.uniform,
    )
    while u >= 0 and code == OK:
        # A component with no vertex of known status (a small shell wholly in cells the
        # object's surface touches): one exact point test in the object's frame.
        for k in range(3):
            xq[k] = (R[0, k] * (AV[u, 0] - t[0]) + R[1, k] * (AV[u, 1] - t[1])
                     + R[2, k] * (AV[u, 2] - t[2]))
        token += 1
        AS[u] = <int8_t>ray_status(
            xq, object_mesh.vertices, object_mesh.faces, object_grid, scratch.object_stamp,
            token, ferr,
        )
        if AS[u] < 0:
            code = DEGENERATE
        else:
            queue[0] = u
            spread(
                AS, hand_mesh.adj_start, hand_mesh.adj_vertex, hand_mesh.adj_edge,
                scratch.work.hand_count, queue, 1,
            )
            u = next_unknown(AS, u + 1, hand.parts, scratch.uniform)
    return code, token


cdef inline (int64_t, int64_t) _object_points(
    MeshTables hand_mesh, MeshTables object_mesh, ObjectTables obj, CellGrid hand_grid,
    PoseScratch scratch, int64_t token,
) noexcept nogil:
    """The object's unknown vertices from their neighbours, and per shell with none known one
    exact point test in the hand's frame (`ray_status`). Returns (code, token)."""
    cdef int8_t[::1] BS = scratch.object_status
    cdef int64_t[::1] queue = scratch.queue
    cdef double[:, ::1] BV = scratch.object_V
    cdef int64_t code = OK, u
    u = resolve(
        BS, object_mesh.adj_start, object_mesh.adj_vertex, object_mesh.adj_edge,
        scratch.work.object_count, queue, obj.parts, obj.whole,
    )
    while u >= 0 and code == OK:
        token += 1
        BS[u] = <int8_t>ray_status(
            BV[u], hand_mesh.vertices, hand_mesh.faces, hand_grid, scratch.hand_stamp, token,
            0.0,
        )
        if BS[u] < 0:
            code = DEGENERATE
        else:
            queue[0] = u
            spread(
                BS, object_mesh.adj_start, object_mesh.adj_vertex, object_mesh.adj_edge,
                scratch.work.object_count, queue, 1,
            )
            u = next_unknown(BS, u + 1, obj.parts, obj.whole)
    return code, token


cdef inline (int64_t, int64_t) classify_vertices(
    const double[:, :] R, const double[:] t, MeshTables hand_mesh, HandTables hand,
    MeshTables object_mesh, ObjectTables obj, CellGrid hand_grid, CellGrid object_grid,
    PoseScratch scratch, int64_t code, int64_t token, double ferr,
) noexcept nogil:
    """Stage "classify" of a pose (``docs/exact-backend.md``, "Method", steps 1, 4 and 5):
    every vertex's status against the other mesh, after the search (`_search.trace_pairs`) has
    recorded the crossings.

    Object vertices (moved: ``scratch.object_V``) get their status in the hand's grid, hand
    vertices theirs in the object's grid (moved by ``x -> R^T (x - t)``), parts none of whose
    own edges is crossed as a whole; then unknown vertices take a neighbour's status across an
    edge, flipped by the edge's crossings, and a shell with none known gets `ray_status`.
    With ``code`` other than `OK` (the search stopped), only the statuses from the grids are
    set. ``token`` is the last stamp the point tests used; ``ferr`` (length) bounds how far a
    hand vertex moved into the object's frame lies from where the pose's inverse puts it
    (`hand_statuses`). Returns (code, token): `DEGENERATE` where a point test is uncertain.
    """
    cdef uint8_t[::1] crossed = scratch.work.part_crossed
    cdef int64_t[::1] epart = hand.edge_part, aedge = scratch.work.hand_rec.edge
    cdef int64_t k
    object_statuses(scratch.object_status, scratch.object_V, hand_grid)
    for k in range(scratch.work.nrec[0]):
        if epart[aedge[k]] >= 0:
            crossed[epart[aedge[k]]] = True
    hand_statuses(
        scratch.hand_status, hand_mesh.vertices, R, t, object_grid, hand.parts, crossed,
        code == OK, scratch.uniform, ferr,
    )
    crossed[:] = 0
    if code == OK:
        code, token = _hand_points(
            R, t, hand_mesh, hand, object_mesh, object_grid, scratch, token, ferr
        )
    if code == OK:
        code, token = _object_points(hand_mesh, object_mesh, obj, hand_grid, scratch, token)
    return code, token
