# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Stage "seeds" of the exact kernel (Cython, inline): candidate face pairs from which
`_search.trace_pairs` traces the curves where the two surfaces cross.

Every such curve is closed. Either it crosses an edge of the object, or it lies in one object
face; then it is a plane's section of the hand, visits each hand face once (a plane cuts a
triangle in one segment) and moves from face to face across hand edges: a cycle of the hand's
dual graph, so it crosses a co-tree edge of the hand (`prepare.cotree_edges`). Two searches
therefore find a pair on every curve: each object edge near the hand's surface against the
hand faces listed in the hand-grid cells it passes (`object_edge_seeds`, in the hand's frame),
and each co-tree edge near the object's surface against the object faces listed in the
object-grid cells it touches (`cotree_seeds`, in the object's frame); runs of edges far from
the other surface are skipped first (`near_runs`). Both searches pass what they meet through
the seeds' filters (`_filters`), whose tolerances exceed their rounding (and, in the object's
frame, the pose's departure from a rotation): they may keep a pair that does not cross, which
its evaluation rejects, and never drop one that does. See "Method", step 2, in
``docs/exact-backend.md``.

The first search's stages are ``_edge_seeds.pxd`` (`object_edge_seeds` and the faces' tests
and seed buffer both searches share, `filtered_seeds`, are cimported here, so that a kernel
cimports every stage of the seeds from this module).
"""

from libc.math cimport fabs
from libc.stdint cimport int64_t, uint8_t

from exactgrasp.backends.exact._cells cimport cell_span, surface_cells_box
from exactgrasp.backends.exact._constants cimport (
    COTREE_CHUNK, GRID_MARGIN, PLANE_TOL, SPHERE_CENTRE, SPHERE_RADIUS,
)
from exactgrasp.backends.exact._edge_seeds cimport filtered_seeds, object_edge_seeds
from exactgrasp.backends.exact._filters cimport (
    cell_row, cell_survivors, piece_box, piece_meets_cell, sphere_meets_cell,
)
from exactgrasp.backends.exact._prefetch cimport prefetch
from exactgrasp.backends.exact._tables cimport (
    CellGrid, HandTables, MeshTables, SideTables, Workspace,
)
from exactgrasp.geometry._minmax cimport max2, max3

# `near_runs` scans the cells of a run's box only up to this many (long edges make big runs).
cdef enum:
    SCAN_CELLS = 27


cdef inline double frame_defect(const double[:, :] R) noexcept nogil:
    """How far R (3, 3) is from a rotation: the largest entry of ``|R^T R - I|``. Moving a
    point back by ``R^T`` instead of the inverse errs by at most about this times its length."""
    cdef double worst = 0.0, dot
    cdef int64_t i, j
    for i in range(3):
        for j in range(3):
            dot = R[0, i] * R[0, j] + R[1, i] * R[1, j] + R[2, i] * R[2, j]
            worst = max2(worst, fabs(dot - (1.0 if i == j else 0.0)))
    return worst


cdef inline bint _scan_cells(
    CellGrid grid, const int64_t *lo, const int64_t *hi, double m0, double m1, double m2,
    double r, double margin,
) noexcept nogil:
    """Whether the sphere of centre (m0, m1, m2) and radius r may meet what one of the surface
    cells of the box of cells [lo, hi] (3 inclusive index ranges) holds (`sphere_meets_cell`)."""
    cdef int64_t n1 = grid.shape[1], n2 = grid.shape[2]
    cdef const int64_t *start = &grid.cell_start[0]
    cdef int64_t i, j, kk, c
    for i in range(lo[0], hi[0] + 1):
        for j in range(lo[1], hi[1] + 1):
            for kk in range(lo[2], hi[2] + 1):
                c = (i * n1 + j) * n2 + kk
                if start[c + 1] == start[c]:
                    continue
                if sphere_meets_cell(cell_row(grid.bounds, c), m0, m1, m2, r, margin):
                    return True
    return False


cdef inline bint _run_near(
    const double[:, ::1] runs, int64_t k, const double *R, const double *t, bint inverse,
    double stretch, double grow, bint scan, CellGrid grid, double ih, double margin,
) noexcept nogil:
    """Whether run k of ``runs`` may come near the grid's surface (`near_runs`; ``R`` the 9
    entries of the pose's matrix row by row, ``t`` its 3 of translation)."""
    cdef double c0 = runs[k, SPHERE_CENTRE], c1 = runs[k, SPHERE_CENTRE + 1]
    cdef double c2 = runs[k, SPHERE_CENTRE + 2]
    cdef double r, m, m0 = 0.0, m1 = 0.0, m2 = 0.0
    cdef int64_t d, cells
    cdef int64_t lo[3]
    cdef int64_t hi[3]
    if inverse:
        c0, c1, c2 = c0 - t[0], c1 - t[1], c2 - t[2]
    r = (
        runs[k, SPHERE_RADIUS] * stretch
        + margin
        + grow
        + (stretch - 1.0) * (fabs(c0) + fabs(c1) + fabs(c2))
    )
    for d in range(3):
        if inverse:
            m = R[d] * c0 + R[3 + d] * c1 + R[6 + d] * c2
        else:
            m = R[3 * d] * c0 + R[3 * d + 1] * c1 + R[3 * d + 2] * c2 + t[d]
        if d == 0:
            m0 = m
        elif d == 1:
            m1 = m
        else:
            m2 = m
        lo[d], hi[d] = cell_span(m - r, m + r, grid.corner[d], ih, grid.shape[d])
        if lo[d] > hi[d]:
            return False
    if surface_cells_box(
        &grid.surface_table[0], grid.shape[1], grid.shape[2], lo[0], hi[0], lo[1], hi[1],
        lo[2], hi[2],
    ) <= 0:
        return False
    cells = (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1)
    if scan and cells <= SCAN_CELLS:
        return _scan_cells(grid, lo, hi, m0, m1, m2, r, margin)
    return True


cdef inline void near_runs(
    const double[:, ::1] runs, const double[:, :] R, const double[:] t, bint inverse,
    double stretch, double grow, bint scan, CellGrid grid, const uint8_t[::1] parent,
    int64_t per, uint8_t[::1] near,
) noexcept nogil:
    """Which runs of segments may come near a grid's surface (``near``, one per run): the
    bounding sphere of each run (``runs`` (k, 4): centre, radius), moved by ``x -> R x + t``
    (or by ``x -> R^T (x - t)`` with ``inverse``) into the grid's frame, its radius times
    ``stretch`` (at least 1: R may stretch lengths a little) and grown by ``stretch - 1`` times
    the centre's distance and by ``grow``, must hold a surface cell in its bounding box and,
    with ``scan``, meet the box and the slab of what one of them holds
    (`tables.CellGrid.bounds`; worth it where runs are small against the cells, and done where
    the box spans at most `SCAN_CELLS` cells). Where ``parent`` is not empty, run k is tested
    only if ``parent[k // per]`` (its block is near)."""
    cdef double ih = 1.0 / grid.cell
    cdef double margin = GRID_MARGIN * grid.cell
    cdef bint levels = parent.shape[0] > 0
    cdef double Rl[9]
    cdef double tl[3]
    cdef int64_t k, i, j
    for i in range(3):
        tl[i] = t[i]
        for j in range(3):
            Rl[3 * i + j] = R[i, j]
    for k in range(runs.shape[0]):
        if levels and not parent[k // per]:
            near[k] = False
            continue
        near[k] = _run_near(runs, k, Rl, tl, inverse, stretch, grow, scan, grid, ih, margin)


cdef inline int64_t _cotree_cell(
    SideTables obj, CellGrid grid, Workspace work, int64_t c, double ax_, double ay_,
    double az_, double bx_, double by_, double bz_, double x0, double y0, double z0,
    double x1, double y1, double z1, double px, double py, double pz, double qx, double qy,
    double qz, int64_t t1f, double gscale, double ferr, double grow, double ptol, int64_t n,
) noexcept nogil:
    """The pairs (hand face ``t1f``, object face) of the piece a b (its box (x0, y0, z0, x1,
    y1, z1), grown by ``grow``) of the co-tree edge p q in object-grid cell c: the piece
    against what the cell holds, then the listed faces' clipped boxes, each with one branch,
    then the plane and edge tests. Appended to ``work.seeds`` from row n; returns the new
    count, or -1 when the buffer is full."""
    cdef int64_t m
    if grid.cell_start[c + 1] == grid.cell_start[c]:
        return n
    if not piece_meets_cell(
        cell_row(grid.bounds, c), ax_, ay_, az_, bx_, by_, bz_, x0, y0, z0, x1, y1, z1, grow
    ):
        return n
    m = cell_survivors(
        grid.cell_start, grid.group_start, grid.groups, grid.boxes, c, x0, y0, z0, x1, y1, z1,
        work.survivors,
    )
    return filtered_seeds(
        obj, grid, work, m, px, py, pz, qx, qy, qz, gscale, ferr, ptol, t1f, True, n
    )


cdef inline int64_t _cotree_piece(
    SideTables obj, CellGrid grid, Workspace work, double la, double lb, double px,
    double py, double pz, double qx, double qy, double qz, int64_t t1f, double gscale,
    double ferr, double grow, double ptol, int64_t n,
) noexcept nogil:
    """The pairs of the piece [la, lb] of the co-tree edge p q: the object-grid cells its box
    (grown by ``grow``) touches, each through `_cotree_cell` (a cell two pieces share is
    tested twice). Returns the new count, or -1 when the seed buffer is full."""
    cdef double ih = 1.0 / grid.cell
    cdef double ax_ = px + la * (qx - px), ay_ = py + la * (qy - py), az_ = pz + la * (qz - pz)
    cdef double bx_ = px + lb * (qx - px), by_ = py + lb * (qy - py), bz_ = pz + lb * (qz - pz)
    cdef double x0, y0, z0, x1, y1, z1
    cdef int64_t n1 = grid.shape[1], n2 = grid.shape[2]
    cdef int64_t i0, i1, j0, j1, k0, k1, i, j, k
    x0, y0, z0, x1, y1, z1 = piece_box(ax_, ay_, az_, bx_, by_, bz_, grow)
    # An axis whose span holds no cell leaves its loop empty.
    i0, i1 = cell_span(x0, x1, grid.corner[0], ih, grid.shape[0])
    j0, j1 = cell_span(y0, y1, grid.corner[1], ih, n1)
    k0, k1 = cell_span(z0, z1, grid.corner[2], ih, n2)
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            for k in range(k0, k1 + 1):
                n = _cotree_cell(
                    obj, grid, work, (i * n1 + j) * n2 + k, ax_, ay_, az_, bx_, by_, bz_, x0,
                    y0, z0, x1, y1, z1, px, py, pz, qx, qy, qz, t1f, gscale, ferr, grow, ptol,
                    n,
                )
                if n < 0:
                    return -1
    return n


cdef inline int64_t _next_near(const uint8_t[::1] near, int64_t r) noexcept nogil:
    """The first run from r on that is near (``near.shape[0]`` where none is)."""
    while r < near.shape[0] and not near[r]:
        r += 1
    return r


cdef inline void _prefetch_run(
    const int64_t *cotree, const int64_t *E, const int64_t *EF, const double *V, int64_t ew,
    int64_t efs, int64_t vw, int64_t r, int64_t ncotree, bint ends,
) noexcept nogil:
    """Ask for the rows the co-tree edges of run r read: their ends' coordinates (``ends``;
    their edges' rows asked for before) or their edges' rows (ends, first face). Both are
    scattered over tables larger than the caches; the pieces of one run take long enough to
    bring the next run's in."""
    cdef int64_t kk, e, top = r * COTREE_CHUNK + COTREE_CHUNK
    if ncotree < top:
        top = ncotree
    for kk in range(r * COTREE_CHUNK, top):
        e = cotree[kk]
        if ends:
            prefetch(&V[vw * E[ew * e]])
            prefetch(&V[vw * E[ew * e + 1]])
        else:
            prefetch(&E[ew * e])
            prefetch(&EF[efs * e])


cdef inline int64_t cotree_seeds(
    MeshTables hand_mesh, HandTables hand, SideTables obj, CellGrid object_grid,
    const double[:, :] R, const double[:] t, const uint8_t[::1] near, double gscale,
    double ferr, double hcell, Workspace work, int64_t n,
) noexcept nogil:
    """Candidate pairs of the hand's co-tree edges near the object's surface (runs ``near``,
    see `near_runs`): each edge, moved into the object's frame by ``x -> R^T (x - t)`` and cut
    into pieces of at most a cell along every axis (a long edge visits few cells, not its whole
    box), against the object faces listed in the object-grid cells each piece's box touches
    (`_cotree_piece`), giving the pair (the edge's first face, object face). Appended to
    ``work.seeds`` from row ``n``; returns the new count, or -1 when the buffer is full.

    ``ferr`` bounds how far a point moved back differs from where the pose's inverse puts it
    (rounding and `frame_defect`): it widens the box and every plane tolerance. ``gscale``
    bounds every coordinate, ``hcell`` is the hand grid's cell (the least plane tolerance is
    the kernel's, `PLANE_TOL` of it)."""
    cdef double h = object_grid.cell
    cdef double ih = 1.0 / h, grow = GRID_MARGIN * h + ferr
    cdef double ptol = PLANE_TOL * max2(h, hcell) + 2.0 * ferr
    cdef double a0, a1, a2, b0, b1, b2, px, py, pz, qx, qy, qz
    # The pose and the tables' rows read once, not per edge (stores to the seed buffer could
    # alias them for the compiler).
    cdef double r00 = R[0, 0], r01 = R[0, 1], r02 = R[0, 2], r10 = R[1, 0], r11 = R[1, 1]
    cdef double r12 = R[1, 2], r20 = R[2, 0], r21 = R[2, 1], r22 = R[2, 2]
    cdef double t0 = t[0], t1 = t[1], t2 = t[2]
    cdef const double *V = &hand_mesh.vertices[0, 0]
    cdef const int64_t *E = &hand_mesh.edges[0, 0]
    cdef const int64_t *EF = &hand_mesh.edge_faces[0, 0]
    cdef const int64_t *cotree = &hand.cotree[0]
    cdef int64_t ncotree = hand.cotree.shape[0], efs = hand_mesh.edge_faces.shape[1]
    cdef int64_t vw = hand_mesh.vertices.shape[1], ew = hand_mesh.edges.shape[1]
    cdef int64_t r, kk, top, e, u, v, t1f, pieces, w, ahead
    r = _next_near(near, 0)
    if r < near.shape[0]:
        _prefetch_run(cotree, E, EF, V, ew, efs, vw, r, ncotree, False)
    while r < near.shape[0]:
        ahead = _next_near(near, r + 1)
        _prefetch_run(cotree, E, EF, V, ew, efs, vw, r, ncotree, True)
        if ahead < near.shape[0]:
            _prefetch_run(cotree, E, EF, V, ew, efs, vw, ahead, ncotree, False)
        top = r * COTREE_CHUNK + COTREE_CHUNK
        if ncotree < top:
            top = ncotree
        for kk in range(r * COTREE_CHUNK, top):
            e = cotree[kk]
            u, v = E[ew * e], E[ew * e + 1]
            a0 = V[vw * u] - t0
            a1 = V[vw * u + 1] - t1
            a2 = V[vw * u + 2] - t2
            b0 = V[vw * v] - t0
            b1 = V[vw * v + 1] - t1
            b2 = V[vw * v + 2] - t2
            px = r00 * a0 + r10 * a1 + r20 * a2
            py = r01 * a0 + r11 * a1 + r21 * a2
            pz = r02 * a0 + r12 * a1 + r22 * a2
            qx = r00 * b0 + r10 * b1 + r20 * b2
            qy = r01 * b0 + r11 * b1 + r21 * b2
            qz = r02 * b0 + r12 * b1 + r22 * b2
            t1f = EF[efs * e]
            pieces = <int64_t>(max3(fabs(qx - px), fabs(qy - py), fabs(qz - pz)) * ih)
            if pieces < 1:
                pieces = 1
            for w in range(pieces):
                n = _cotree_piece(
                    obj, object_grid, work, <double>w / <double>pieces,
                    <double>(w + 1) / <double>pieces, px, py, pz, qx, qy, qz, t1f, gscale,
                    ferr, grow, ptol, n,
                )
                if n < 0:
                    return -1
        r = ahead
    return n
