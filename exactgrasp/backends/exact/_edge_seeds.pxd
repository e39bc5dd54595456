# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Stage "seeds" of the exact kernel, its first search (Cython, inline): the object's edges
near the hand's surface, each walking the hand-grid cells it passes, against the hand faces
listed there (`object_edge_seeds`, in the hand's frame). The faces' plane and edge tests and
the seed buffer (`filtered_seeds`, `_append_seed`) serve the second search,
`_seeds.cotree_seeds`, too. ``_seeds.pxd``
explains why the two searches find a pair on every curve where the surfaces cross.
"""

from libc.math cimport INFINITY, fabs, floor
from libc.stdint cimport int64_t, uint8_t

from exactgrasp.backends.exact._cells cimport cell_span, surface_cells_box
from exactgrasp.backends.exact._constants cimport CHUNK, FILTER_ERR, GRID_MARGIN, PLANE_TOL
from exactgrasp.backends.exact._filters cimport (
    cell_row, cell_survivors, may_cross, piece_box, piece_meets_cell, piece_survivors,
)
from exactgrasp.backends.exact._tables cimport (
    CellGrid, MeshTables, ObjectTables, SideTables, Workspace,
)
from exactgrasp.geometry._minmax cimport max2, min2


cdef inline int64_t _append_seed(
    int64_t[:, ::1] seeds, int64_t n, int64_t t, int64_t s
) noexcept nogil:
    """Pair (hand face t, object face s) as row n of ``seeds`` unless row n - 1 holds it: the new
    count, or -1 when the buffer is full."""
    if n > 0 and seeds[n - 1, 0] == t and seeds[n - 1, 1] == s:
        return n
    if n >= seeds.shape[0]:
        return -1
    seeds[n, 0] = t
    seeds[n, 1] = s
    return n + 1


cdef inline int64_t filtered_seeds(
    SideTables side, CellGrid grid, Workspace work, int64_t kept, double px, double py,
    double pz, double qx, double qy, double qz, double gscale, double grow, double ptol,
    int64_t fixed, bint fixed_hand, int64_t n,
) noexcept nogil:
    """The faces of ``side`` at the first ``kept`` of ``work.survivors`` (entries of the
    grid's cell lists) that pass the plane and edge tests against segment p q (each face's
    tolerance grown by ``grow``), each paired with face ``fixed`` of the other mesh (the hand's
    where ``fixed_hand``) and appended to ``work.seeds`` from row n. Returns the new count, or
    -1 when the buffer is full."""
    cdef int64_t j, f
    cdef double eps
    cdef const int64_t *faces = &grid.cell_faces[0]
    cdef const int64_t *survivors = &work.survivors[0]
    cdef const float *filter_err = &side.filter_err[0]
    cdef const float *filters = &side.filters[0, 0]
    cdef int64_t columns = side.filters.shape[1]
    for j in range(kept):
        f = faces[survivors[j]]
        # Both ends beyond the tolerance on one side: no crossing. Else the crossing point
        # must not lie beyond it outside an edge of the face.
        eps = (filter_err[f] + FILTER_ERR) * gscale + grow
        if not may_cross(filters + f * columns, px, py, pz, qx, qy, qz, eps, ptol, gscale):
            continue
        if fixed_hand:
            n = _append_seed(work.seeds, n, fixed, f)
        else:
            n = _append_seed(work.seeds, n, f, fixed)
        if n < 0:
            return -1
    return n


cdef inline int64_t _clamp(int64_t i, int64_t top) noexcept nogil:
    """``min(max(i, 0), top)``."""
    if 0 > i:
        i = 0
    return top if top < i else i


cdef inline bint _edge_box_near(
    CellGrid grid, double px, double py, double pz, double qx, double qy, double qz,
    double ih, double margin,
) noexcept nogil:
    """Whether the box of cells of edge p q (grown by ``margin``, clipped to the grid) holds a
    surface cell of the grid."""
    cdef double a, b
    cdef int64_t d, lo[3]
    cdef int64_t hi[3]
    for d in range(3):
        a = px if d == 0 else (py if d == 1 else pz)
        b = qx if d == 0 else (qy if d == 1 else qz)
        lo[d], hi[d] = cell_span(
            min2(a, b) - margin, max2(a, b) + margin, grid.corner[d], ih, grid.shape[d]
        )
        if lo[d] > hi[d]:
            return False
    return surface_cells_box(
        &grid.surface_table[0], grid.shape[1], grid.shape[2], lo[0], hi[0], lo[1], hi[1],
        lo[2], hi[2],
    ) != 0


ctypedef (double, double) Span


cdef inline Span _grid_span(
    CellGrid grid, double px, double py, double pz, double dx, double dy, double dz
) noexcept nogil:
    """The parameter range (l0, l1) of the edge ``p + lambda d``, lambda in [0, 1], inside the
    grid's box (l0 > l1: outside)."""
    cdef double l0 = 0.0, l1 = 1.0, o, dd, size, ta, tb
    cdef int64_t d
    for d in range(3):
        o = (px if d == 0 else (py if d == 1 else pz)) - grid.corner[d]
        dd = dx if d == 0 else (dy if d == 1 else dz)
        size = grid.shape[d] * grid.cell
        if dd == 0.0:
            if o < 0.0 or o > size:
                l0 = 2.0
            continue
        ta, tb = -o / dd, (size - o) / dd
        l0 = max2(l0, min2(ta, tb))
        l1 = min2(l1, max2(ta, tb))
    return l0, l1


cdef inline int64_t _piece_seeds(
    SideTables hand, CellGrid grid, Workspace work, int64_t c, double ax_, double ay_,
    double az_, double bx_, double by_, double bz_, double px, double py, double pz,
    double qx, double qy, double qz, int64_t s1, double gscale, double margin, double ptol,
    int64_t n,
) noexcept nogil:
    """The pairs (hand face, object face ``s1``) of the piece a b, in cell c, of the object
    edge p q: the hand faces listed in c whose clipped boxes meet the piece and that pass the
    plane and edge tests, appended to ``work.seeds`` from row n. Returns the new count, or -1
    when the buffer is full."""
    cdef double x0, y0, z0, x1, y1, z1
    cdef int64_t m, kept
    x0, y0, z0, x1, y1, z1 = piece_box(ax_, ay_, az_, bx_, by_, bz_, margin)
    if not piece_meets_cell(
        cell_row(grid.bounds, c), ax_, ay_, az_, bx_, by_, bz_, x0, y0, z0, x1, y1, z1, margin
    ):
        return n
    m = cell_survivors(
        grid.cell_start, grid.group_start, grid.groups, grid.boxes, c, x0, y0, z0, x1, y1, z1,
        work.survivors,
    )
    kept = piece_survivors(grid.boxes, work.survivors, m, ax_, ay_, az_, bx_, by_, bz_, margin)
    return filtered_seeds(
        hand, grid, work, kept, px, py, pz, qx, qy, qz, gscale, 0.0, ptol, s1, False, n
    )


cdef inline int64_t _edge_walk(
    SideTables hand, CellGrid grid, Workspace work, double px, double py, double pz,
    double qx, double qy, double qz, double l0, double l1, int64_t s1, double gscale,
    double ih, double margin, double ptol, int64_t n,
) noexcept nogil:
    """Line walk (Amanatides and Woo) of the object edge p q over [l0, l1] (its part inside
    the grid): the cells in order, each with its piece [lam_a, lam_b] of the edge
    (consecutive pieces share their ends), through `_piece_seeds`. Returns the new count, or
    -1 when the seed buffer is full."""
    cdef double h = grid.cell, dx = qx - px, dy = qy - py, dz = qz - pz
    cdef double tx, ty, tz, gx, gy, gz, lam_a, lam_b
    cdef int64_t n0 = grid.shape[0], n1 = grid.shape[1], n2 = grid.shape[2]
    cdef int64_t ix, iy, iz, sx, sy, sz, c
    ix = _clamp(<int64_t>floor((px + l0 * dx - grid.corner[0]) * ih), n0 - 1)
    iy = _clamp(<int64_t>floor((py + l0 * dy - grid.corner[1]) * ih), n1 - 1)
    iz = _clamp(<int64_t>floor((pz + l0 * dz - grid.corner[2]) * ih), n2 - 1)
    sx = 1 if dx > 0 else -1
    sy = 1 if dy > 0 else -1
    sz = 1 if dz > 0 else -1
    tx = (grid.corner[0] + (ix + (1 if dx > 0 else 0)) * h - px) / dx if dx != 0 else INFINITY
    ty = (grid.corner[1] + (iy + (1 if dy > 0 else 0)) * h - py) / dy if dy != 0 else INFINITY
    tz = (grid.corner[2] + (iz + (1 if dz > 0 else 0)) * h - pz) / dz if dz != 0 else INFINITY
    gx = h / fabs(dx) if dx != 0 else INFINITY
    gy = h / fabs(dy) if dy != 0 else INFINITY
    gz = h / fabs(dz) if dz != 0 else INFINITY
    lam_a = l0
    while True:
        lam_b = min2(min2(min2(tx, ty), tz), l1)
        c = (ix * n1 + iy) * n2 + iz
        if grid.cell_start[c + 1] > grid.cell_start[c]:
            n = _piece_seeds(
                hand, grid, work, c, px + lam_a * dx, py + lam_a * dy, pz + lam_a * dz,
                px + lam_b * dx, py + lam_b * dy, pz + lam_b * dz, px, py, pz, qx, qy, qz,
                s1, gscale, margin, ptol, n,
            )
            if n < 0:
                return -1
        if lam_b >= l1:
            break
        lam_a = lam_b
        if tx <= ty and tx <= tz:
            ix += sx
            tx += gx
            if ix < 0 or ix >= n0:
                break
        elif ty <= tz:
            iy += sy
            ty += gy
            if iy < 0 or iy >= n1:
                break
        else:
            iz += sz
            tz += gz
            if iz < 0 or iz >= n2:
                break
    return n


cdef inline int64_t object_edge_seeds(
    MeshTables object_mesh, ObjectTables obj, SideTables hand, CellGrid hand_grid,
    const double[:, ::1] BV, const uint8_t[::1] near, double gscale, Workspace work,
    int64_t n,
) noexcept nogil:
    """Candidate pairs of the object's edges near the hand's surface (runs ``near``, see
    `near_runs`): each edge walks the hand-grid cells it passes (`_edge_walk`, moved vertices
    ``BV``), and the hand faces listed there whose cell-clipped box meets the edge's piece in
    the cell and that pass the plane and edge tests give the pair (hand face, the edge's first
    face). Appended to ``work.seeds`` from row ``n``; returns the new count, or -1 when the
    buffer is full. ``gscale`` bounds every coordinate of the pose.

    A crossing point lies in some cell the edge passes, and the face holding it is listed
    there with its box clipped to that cell (both grown by `GRID_MARGIN`, far above the walk's
    rounding)."""
    cdef double h = hand_grid.cell
    cdef double ih = 1.0 / h, margin = GRID_MARGIN * h, ptol = PLANE_TOL * h
    cdef double px, py, pz, qx, qy, qz, l0, l1
    cdef const int64_t *order = &obj.edge_order[0]
    cdef const int64_t *E = &object_mesh.edges[0, 0]
    cdef const int64_t *EF = &object_mesh.edge_faces[0, 0]
    cdef const double *P = &BV[0, 0]
    cdef int64_t nedges = obj.edge_order.shape[0], efs = object_mesh.edge_faces.shape[1]
    cdef int64_t vw = BV.shape[1], ew = object_mesh.edges.shape[1]
    cdef int64_t r, kk, top, f, u, v, s1
    for r in range(near.shape[0]):
        if not near[r]:
            continue
        top = r * CHUNK + CHUNK
        if nedges < top:
            top = nedges
        for kk in range(r * CHUNK, top):
            f = order[kk]
            u, v = E[ew * f], E[ew * f + 1]
            px, py, pz = P[vw * u], P[vw * u + 1], P[vw * u + 2]
            qx, qy, qz = P[vw * v], P[vw * v + 1], P[vw * v + 2]
            # The edge's box of cells must hold a surface cell.
            if not _edge_box_near(hand_grid, px, py, pz, qx, qy, qz, ih, margin):
                continue
            s1 = EF[efs * f]
            l0, l1 = _grid_span(hand_grid, px, py, pz, qx - px, qy - py, qz - pz)
            if l0 > l1:
                continue
            n = _edge_walk(
                hand, hand_grid, work, px, py, pz, qx, qy, qz, l0, l1, s1, gscale, ih, margin,
                ptol, n,
            )
            if n < 0:
                return -1
    return n
