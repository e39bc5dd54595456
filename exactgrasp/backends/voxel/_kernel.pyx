# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False, embedsignature=True
"""The voxel estimator's counting kernel, compiled ahead of time (Cython).
`exactgrasp.backends.voxel.kernel` is the module to import; it documents the estimator.

Each point is moved and interpolated with the floating-point operations of the numpy baseline
(and of the former numba kernel), in the same order; the extension is built without fused
multiply-adds or fast-math (meson.build), so the counts are the same. `count_inside` counts
its poses without the GIL: threads count different poses at once.
"""

import numpy as np

from libc.math cimport fabs, nextafter
from libc.stdint cimport int64_t, uint8_t, uint64_t

# Every moved point lies within its box's moved bounds up to rounding, a few units in the last
# place of the largest term; this relative margin covers that many times over.
cdef double MARGIN = 1e-9

# Masks of the packed summed table (`HandOccupancy.tiles`): occupied tiles low, full ones high.
cdef uint64_t LOW = 0xFFFFFFFF
cdef uint64_t HIGH = 32

# What a box of points is worth to a pose (`_box_verdict`).
cdef enum:
    SKIP = 0    # no point can land on an inside corner
    WHOLE = 1   # every point lands in a full cell inside the grid
    OPEN = 2    # test the children, or the points


cdef struct Affine:
    # A pose in grid index space: point x lands at a @ x + b.
    double a[3][3]
    double b[3]


cdef struct Hand:
    # The hand's tables: cells per axis, tiles per axis (y, z) and the tile shift.
    int64_t nx, ny, nz, ty, tz, shift


cdef inline double _max(double a, double b) noexcept nogil:
    """Python's ``max(a, b)``."""
    return b if b > a else a


cdef inline double _min(double a, double b) noexcept nogil:
    """Python's ``min(a, b)``."""
    return b if b < a else a


cdef inline double _interpolate(double fx, double fy, double fz, int64_t code) noexcept nogil:
    """Trilinear interpolation in a cell whose corner values are the bits of `code` (0 gives
    exactly 0, 255 gives 1 within rounding)."""
    cdef double ex = 1.0 - fx, ey = 1.0 - fy, ez = 1.0 - fz
    cdef int64_t c000 = code & 1, c100 = code >> 1 & 1, c010 = code >> 2 & 1
    cdef int64_t c110 = code >> 3 & 1, c001 = code >> 4 & 1, c101 = code >> 5 & 1
    cdef int64_t c011 = code >> 6 & 1, c111 = code >> 7
    return ez * (ey * (ex * c000 + fx * c100) + fy * (ex * c010 + fx * c110)) + fz * (
        ey * (ex * c001 + fx * c101) + fy * (ex * c011 + fx * c111)
    )


cdef inline void _move_boxes(
    const Affine* m, double margin, const double[:, ::1] boxes, Py_ssize_t first,
    Py_ssize_t last, double[:, ::1] bounds,
) noexcept nogil:
    """Moved bounds of the boxes ``first:last`` (centres and half sides by coordinate, (6, m))
    into ``bounds[:, :last - first]``: low x, high x, low y, high y, low z, high z, widened by
    `margin`."""
    cdef Py_ssize_t q, r
    cdef double c0, c1, c2, h0, h1, h2, mid, reach
    for q in range(last - first):
        c0, c1, c2 = boxes[0, first + q], boxes[1, first + q], boxes[2, first + q]
        h0, h1, h2 = boxes[3, first + q], boxes[4, first + q], boxes[5, first + q]
        for r in range(3):
            mid = m.a[r][0] * c0 + m.a[r][1] * c1 + m.a[r][2] * c2 + m.b[r]
            reach = fabs(m.a[r][0]) * h0 + fabs(m.a[r][1]) * h1 + fabs(m.a[r][2]) * h2 + margin
            bounds[2 * r, q], bounds[2 * r + 1, q] = mid - reach, mid + reach


cdef inline int64_t _count_leaf(
    const Affine* m, const double[:, ::1] coords, Py_ssize_t start, Py_ssize_t end,
    const uint8_t[::1] codes, const Hand* hand, int64_t[::1] cell, double[:, ::1] frac,
) noexcept nogil:
    """How many points ``start:end`` land where the interpolated occupancy exceeds 0.5.

    Moving the points and finding their cells, reading the cells' codes, interpolating: no
    loop branches on a point. A point outside the grid is moved onto its outer layer of nodes,
    all outside the hand, so it never counts, as in the numpy baseline.
    """
    cdef double top_x = nextafter(<double>hand.nx, 0.0), top_y = nextafter(<double>hand.ny, 0.0)
    cdef double top_z = nextafter(<double>hand.nz, 0.0), x, y, z, gx, gy, gz
    cdef int64_t i, j, k, inside = 0
    cdef Py_ssize_t p
    for p in range(end - start):
        x, y, z = coords[0, start + p], coords[1, start + p], coords[2, start + p]
        gx = m.a[0][0] * x + m.a[0][1] * y + m.a[0][2] * z + m.b[0]
        gy = m.a[1][0] * x + m.a[1][1] * y + m.a[1][2] * z + m.b[1]
        gz = m.a[2][0] * x + m.a[2][1] * y + m.a[2][2] * z + m.b[2]
        gx, gy = _min(_max(gx, 0.0), top_x), _min(_max(gy, 0.0), top_y)
        gz = _min(_max(gz, 0.0), top_z)
        i, j, k = <int64_t>gx, <int64_t>gy, <int64_t>gz
        cell[p] = (i * hand.ny + j) * hand.nz + k
        frac[0, p], frac[1, p], frac[2, p] = gx - i, gy - j, gz - k
    for p in range(end - start):
        cell[p] = codes[cell[p]]
    for p in range(end - start):
        inside += _interpolate(frac[0, p], frac[1, p], frac[2, p], cell[p]) > 0.5
    return inside


cdef inline int _box_verdict(
    const double[:, ::1] bounds, Py_ssize_t q, const Hand* hand, const uint64_t[::1] tiles
) noexcept nogil:
    """`SKIP`, `WHOLE` or `OPEN` for box `q` of `bounds`, from the hand's summed tables."""
    cdef double lx = bounds[0, q], hx = bounds[1, q], ly = bounds[2, q], hy = bounds[3, q]
    cdef double lz = bounds[4, q], hz = bounds[5, q]
    cdef int64_t nx = hand.nx, ny = hand.ny, nz = hand.nz, shift = hand.shift
    # Points outside the grid (below 0, or at n and above) never count.
    if hx < 0.0 or lx >= nx or hy < 0.0 or ly >= ny or hz < 0.0 or lz >= nz:
        return SKIP
    # Tiles [x0, x1) x [y0, y1) x [z0, z1) hold every cell the points can reach.
    cdef int64_t x0 = (<int64_t>lx) >> shift if lx >= 0.0 else 0
    cdef int64_t y0 = (<int64_t>ly) >> shift if ly >= 0.0 else 0
    cdef int64_t z0 = (<int64_t>lz) >> shift if lz >= 0.0 else 0
    cdef int64_t x1 = ((<int64_t>hx if hx < nx else nx - 1) >> shift) + 1
    cdef int64_t y1 = ((<int64_t>hy if hy < ny else ny - 1) >> shift) + 1
    cdef int64_t z1 = ((<int64_t>hz if hz < nz else nz - 1) >> shift) + 1
    cdef uint64_t i00 = <uint64_t>((x0 * hand.ty + y0) * hand.tz)
    cdef uint64_t i01 = <uint64_t>((x0 * hand.ty + y1) * hand.tz)
    cdef uint64_t i10 = <uint64_t>((x1 * hand.ty + y0) * hand.tz)
    cdef uint64_t i11 = <uint64_t>((x1 * hand.ty + y1) * hand.tz)
    cdef uint64_t u0 = <uint64_t>z0, u1 = <uint64_t>z1
    # Unsigned wrap-around leaves both packed counts exact: each final count fits.
    cdef uint64_t total = (
        tiles[i11 + u1] - tiles[i01 + u1] - tiles[i10 + u1] - tiles[i11 + u0]
        + tiles[i00 + u1] + tiles[i01 + u0] + tiles[i10 + u0] - tiles[i00 + u0]
    )
    if (total & LOW) == 0:
        return SKIP
    cdef bint within = lx >= 0.0 and ly >= 0.0 and lz >= 0.0 and hx < nx and hy < ny and hz < nz
    if within and <int64_t>(total >> HIGH) == (x1 - x0) * (y1 - y0) * (z1 - z0):
        return WHOLE
    return OPEN


cdef struct Points:
    # The object's points and their tree (`ObjectPoints`), as the kernel reads them.
    int64_t n_roots, first_leaf, n_interior


cdef void _count_pose(
    const Affine* m, double margin, const double[:, ::1] coords, const double[:, ::1] boxes,
    const int64_t[:, ::1] ranges, const Points* tree, const uint8_t[::1] codes,
    const uint64_t[::1] tiles, const Hand* hand, int64_t[::1] stack, double[:, ::1] bounds,
    int64_t[::1] cell, double[:, ::1] frac, int64_t* counts,
) noexcept nogil:
    """Interior and surface points inside the hand for one pose, into ``counts[0:2]``.

    Walks the tree of boxes depth first, the children of a node together: a box whose moved
    bounds cover no tile with an inside corner is skipped, one inside the grid covering full
    tiles only is counted whole, the points of the other leaves are tested one by one.
    """
    cdef int64_t root, inside, top, first, last, node, verdict
    cdef Py_ssize_t q
    counts[0] = counts[1] = 0
    for root in range(tree.n_roots):
        inside, top = 0, 0
        first, last = root, root + 1
        while True:
            _move_boxes(m, margin, boxes, first, last, bounds)
            for q in range(last - first):
                node = first + q
                verdict = _box_verdict(bounds, q, hand, tiles)
                if verdict == SKIP:
                    continue
                if verdict == WHOLE:
                    inside += ranges[node, 1] - ranges[node, 0]
                elif node < tree.first_leaf:
                    stack[top] = node
                    top += 1
                else:
                    inside += _count_leaf(
                        m, coords, ranges[node, 0], ranges[node, 1], codes, hand, cell, frac
                    )
            if top == 0:
                break
            top -= 1
            first, last = ranges[stack[top], 2], ranges[stack[top], 3]
        # A root holds one kind of point.
        counts[0 if ranges[root, 0] < tree.n_interior else 1] += inside


cdef inline double _pose(
    const double[:, :, ::1] linear, const double[:, ::1] offset, Py_ssize_t p, double extent,
    Affine* m,
) noexcept nogil:
    """Pose `p` into `m`; returns its margin for the moved boxes (relative to the largest
    coordinate a moved point can have)."""
    cdef double largest = 0.0, row
    cdef Py_ssize_t r, c
    for r in range(3):
        for c in range(3):
            m.a[r][c] = linear[p, r, c]
        m.b[r] = offset[p, r]
    for r in range(3):
        row = fabs(m.a[r][0]) + fabs(m.a[r][1]) + fabs(m.a[r][2])
        largest = _max(largest, fabs(m.b[r]) + row * extent)
    return MARGIN * (1.0 + largest)


def count_inside(
    linear, offset, coords, int64_t n_interior, double extent, boxes, ranges, int64_t n_roots,
    int64_t first_leaf, codes, tiles, int64_t shift, Py_ssize_t first, Py_ssize_t last,
    int64_t[:, :] counts,
):
    """Count poses ``first:last``: interior and surface points inside the hand, into `counts`.

    Releases the GIL while it counts, so threads can count different poses at once.

    Parameters
    ----------
    linear, offset : numpy.ndarray, shapes (n, 3, 3) and (n, 3), float64
        The poses as maps into the hand grid's index space (point ``x`` lands at
        ``linear[p] @ x + offset[p]``).
    coords : numpy.ndarray, shape (3, k), float64
        The object's points by coordinate (`ObjectPoints.points` transposed).
    n_interior : int
        Points before this index are interior points, the others surface samples.
    extent : float
        Largest absolute coordinate of any point.
    boxes, ranges : numpy.ndarray
        `ObjectPoints.node_boxes` (6, m) and `ObjectPoints.node_ranges` (m, 4).
    n_roots, first_leaf : int
        `ObjectPoints.n_roots` and `ObjectPoints.first_leaf`.
    codes : numpy.ndarray, shape (nx, ny, nz), uint8
        `HandOccupancy.cell_codes`.
    tiles : numpy.ndarray, shape (tx + 1, ty + 1, tz + 1), uint64
        `HandOccupancy.tiles`.
    shift : int
        `HandOccupancy.tile_shift`.
    first, last : int
        The poses to count.
    counts : numpy.ndarray, shape (n, 2), int64
        Written at rows ``first:last``: interior points inside, surface points inside.
    """
    cdef const double[:, :, ::1] L = np.ascontiguousarray(linear, dtype=np.float64)
    cdef const double[:, ::1] O = np.ascontiguousarray(offset, dtype=np.float64)
    cdef const double[:, ::1] C = np.ascontiguousarray(coords, dtype=np.float64)
    cdef const double[:, ::1] B = np.ascontiguousarray(boxes, dtype=np.float64)
    cdef const int64_t[:, ::1] R = np.ascontiguousarray(ranges, dtype=np.int64)
    codes, tiles = np.ascontiguousarray(codes, np.uint8), np.ascontiguousarray(tiles, np.uint64)
    cdef const uint8_t[::1] flat_codes = codes.ravel()
    cdef const uint64_t[::1] flat_tiles = tiles.ravel()
    cdef Hand hand
    hand.nx, hand.ny, hand.nz = codes.shape
    hand.ty, hand.tz, hand.shift = tiles.shape[1], tiles.shape[2], shift
    cdef Points tree = Points(n_roots=n_roots, first_leaf=first_leaf, n_interior=n_interior)
    sizes = np.diff(ranges, axis=1)[:, ::2] if len(ranges) else np.zeros((0, 2), np.int64)
    leaf_size, fanout = (max(1, int(v)) for v in sizes.max(axis=0, initial=1))
    # A node is pushed at most once per root: the internal nodes bound the stack.
    cdef int64_t[::1] stack = np.empty(max(1, first_leaf), np.int64)
    cdef double[:, ::1] bounds = np.empty((6, fanout))
    cdef int64_t[::1] cell = np.empty(leaf_size, np.int64)
    cdef double[:, ::1] frac = np.empty((3, leaf_size))
    cdef Affine m
    cdef int64_t pair[2]
    cdef double margin
    cdef Py_ssize_t p
    with nogil:
        for p in range(first, last):
            margin = _pose(L, O, p, extent, &m)
            _count_pose(&m, margin, C, B, R, &tree, flat_codes, flat_tiles, &hand, stack,
                        bounds, cell, frac, pair)
            counts[p, 0], counts[p, 1] = pair[0], pair[1]
