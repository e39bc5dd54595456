# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Cell-grid kernels of the exact backend (Cython, inline): which cell holds a point, which
cells a triangle touches, how many surface cells a box of cells holds.

The grids themselves (`tables.CellGrid`) are built by `grids.build_grid`; these kernels take
their fields one by one, as the numba kernels did. `raster_triangles` is the rasterisation's
loop: its Python entry allocates the outputs and calls it (again with larger ones where they
were too small).
"""

from libc.math cimport floor
from libc.stdint cimport int64_t

from exactgrasp.backends.exact._predicates cimport tri_box
from exactgrasp.geometry._minmax cimport max3, min3


cdef inline int64_t cell_index(
    double x, double y, double z, double l0, double l1, double l2, double ih,
    int64_t n0, int64_t n1, int64_t n2,
) noexcept nogil:
    """Flat index of the grid cell holding (x, y, z), or -1 outside the grid (lower corner
    (l0, l1, l2), inverse cell edge ih, n* cells per axis). A point within rounding of a
    cell's boundary may get either cell: a cell of known status lies at least the
    rasterisation margin away from the surface, so either answer is right."""
    cdef int64_t i = <int64_t>floor((x - l0) * ih)
    cdef int64_t j = <int64_t>floor((y - l1) * ih)
    cdef int64_t k = <int64_t>floor((z - l2) * ih)
    if i < 0 or j < 0 or k < 0 or i >= n0 or j >= n1 or k >= n2:
        return -1
    return (i * n1 + j) * n2 + k


ctypedef (int64_t, int64_t) CellSpan


cdef inline CellSpan cell_span(
    double low, double high, double corner, double ih, int64_t n
) noexcept nogil:
    """The cells (first, last) along one axis of a grid (lower corner ``corner``, inverse
    cell edge ``ih``, ``n`` cells) that hold [low, high], clipped to the grid; first > last
    where none does."""
    cdef int64_t i0 = <int64_t>floor((low - corner) * ih)
    cdef int64_t i1 = <int64_t>floor((high - corner) * ih)
    if i1 < 0 or i0 >= n:
        return 1, 0
    return (i0 if i0 > 0 else 0), (n - 1 if n - 1 < i1 else i1)


cdef inline int64_t point_status(
    const double[::1] x, const double[::1] lo, double h, const int64_t[::1] n,
    const int64_t[::1] status,
) noexcept nogil:
    """Inside (1) / outside (0) from the grid's cell statuses; -1 when x (3,) is in a surface
    cell. ``lo, h, n, status`` are the grid's first four fields (`tables.CellGrid`)."""
    cdef int64_t c = cell_index(
        x[0], x[1], x[2], lo[0], lo[1], lo[2], 1.0 / h, n[0], n[1], n[2]
    )
    return 0 if c < 0 else status[c]


cdef inline bint tri_cell_range(
    const double[:, ::1] V, const int64_t[:, ::1] F, int64_t f, const double[::1] lo,
    double h, const int64_t[::1] n, double margin, int64_t[:, ::1] rng,
) noexcept nogil:
    """Grid-index range of triangle f's bounding box (clipped) into ``rng`` (3, 2); False when
    outside the grid. (Products with 1 / h, not quotients: the margin dwarfs the difference in
    rounding.)"""
    cdef double ih = 1.0 / h
    cdef double x0, x1
    cdef int64_t ax
    for ax in range(3):
        x0 = min3(V[F[f, 0], ax], V[F[f, 1], ax], V[F[f, 2], ax]) - margin
        x1 = max3(V[F[f, 0], ax], V[F[f, 1], ax], V[F[f, 2], ax]) + margin
        rng[ax, 0], rng[ax, 1] = cell_span(x0, x1, lo[ax], ih, n[ax])
        if rng[ax, 0] > rng[ax, 1]:
            return False
    return True


cdef inline int64_t raster_triangles(
    const double[:, ::1] V, const int64_t[:, ::1] F, const double[::1] lo, double h,
    const int64_t[::1] n, double margin, int64_t[:, ::1] rng, int64_t[::1] cells,
    int64_t[::1] tris,
) noexcept nogil:
    """(cell, triangle) pairs of every triangle of V (n, 3), F (m, 3) touching a grid cell
    (closed, grown by ``margin``), in triangle order (the caller sorts): flat cell indices into
    ``cells``, triangle indices into ``tris``, as many as they hold. Returns how many pairs
    there are (more than they hold: call again with outputs that long). ``rng``: scratch
    (3, 2)."""
    cdef int64_t count = 0, room = cells.shape[0]
    cdef int64_t f, i, j, k, a, b, c
    cdef double cx, cy, cz
    cdef double hh = 0.5 * h + margin
    for f in range(F.shape[0]):
        if not tri_cell_range(V, F, f, lo, h, n, margin, rng):
            continue
        a, b, c = F[f, 0], F[f, 1], F[f, 2]
        for i in range(rng[0, 0], rng[0, 1] + 1):
            for j in range(rng[1, 0], rng[1, 1] + 1):
                for k in range(rng[2, 0], rng[2, 1] + 1):
                    cx = lo[0] + (i + 0.5) * h
                    cy = lo[1] + (j + 0.5) * h
                    cz = lo[2] + (k + 0.5) * h
                    if tri_box(
                        cx, cy, cz, hh, V[a, 0], V[a, 1], V[a, 2], V[b, 0], V[b, 1], V[b, 2],
                        V[c, 0], V[c, 1], V[c, 2],
                    ):
                        if count < room:
                            cells[count] = (i * n[1] + j) * n[2] + k
                            tris[count] = f
                        count += 1
    return count


cdef inline int64_t surface_cells_box(
    const int64_t *table, int64_t n1, int64_t n2, int64_t i0, int64_t i1, int64_t j0,
    int64_t j1, int64_t k0, int64_t k1,
) noexcept nogil:
    """Number of surface cells in the box of cells [i0, i1] x [j0, j1] x [k0, k1] (inclusive
    index ranges), from the grid's summed-volume table (`tables.CellGrid.surface_table`,
    given by its first entry) in 8 reads; the grid's cells per axis by the last two (n1,
    n2)."""
    cdef int64_t s1 = n2 + 1
    cdef int64_t s0 = (n1 + 1) * s1
    cdef int64_t a0 = i0 * s0, a1 = (i1 + 1) * s0
    cdef int64_t b0 = j0 * s1, b1 = (j1 + 1) * s1
    cdef int64_t c0 = k0, c1 = k1 + 1
    return (
        table[a1 + b1 + c1]
        - table[a0 + b1 + c1]
        - table[a1 + b0 + c1]
        - table[a1 + b1 + c0]
        + table[a0 + b0 + c1]
        + table[a0 + b1 + c0]
        + table[a1 + b0 + c0]
        - table[a0 + b0 + c0]
    )
