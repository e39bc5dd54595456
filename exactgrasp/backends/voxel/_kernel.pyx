# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False, embedsignature=True
"""The voxel estimator's counting kernel, compiled ahead of time (Cython).
`exactgrasp.backends.voxel.kernel` is the module to import; it documents the estimator.

Each point is moved and interpolated with the floating-point operations of the numpy baseline
(and of the former numba kernel), in the same order; the extension is built without fused
multiply-adds or fast-math (meson.build), so the counts are the same. `count_inside` takes
typed memoryviews and counts its poses without the GIL (threads count different poses at
once); the stages inside take plain pointers, gathered in `Points`, `Hand` and `Scratch`.

``_kernel_avx2.pyx`` compiles this same source for x86-64 CPUs with AVX2, where the leaves'
loops vectorise 4 wide; `kernel` picks the one this CPU runs (`exactgrasp.backends._builds`).
The results are the same: no multiply-add is fused and no sum reordered in either.
"""

import numpy as np

from libc.math cimport fabs, nextafter
from libc.stdint cimport int32_t, int64_t, uint8_t, uint64_t

from exactgrasp.geometry._minmax cimport max2, min2

# Output pointers that alias nothing else in the leaf's loops: without `restrict` GCC cannot
# vectorise the loop that moves the points.
cdef extern from *:
    """
    typedef double *__restrict exactgrasp_double_out;
    typedef int32_t *__restrict exactgrasp_int32_out;
    """
    ctypedef double* double_out "exactgrasp_double_out"
    ctypedef int32_t* int32_out "exactgrasp_int32_out"


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


cdef struct Points:
    # The object's points by coordinate (3, n), their tree's boxes (6, m) and ranges (m, 4)
    # (`ObjectPoints`).
    const double* coords
    Py_ssize_t n
    const double* boxes
    Py_ssize_t m
    const int64_t* ranges
    int64_t n_roots, first_leaf, n_interior


cdef struct Hand:
    # The hand's cell codes (nx, ny, nz) and packed summed tables (tx + 1, ty, tz), raveled.
    const uint8_t* codes
    const uint64_t* tiles
    int64_t nx, ny, nz, ty, tz, shift


cdef struct Scratch:
    # One thread's work space: the stack of nodes to open, the moved bounds of a node's
    # children (6, fanout), a leaf's cells and fractions (3, leaf).
    int64_t* stack
    double* bounds
    Py_ssize_t fanout
    int32_t* cell
    double* frac
    Py_ssize_t leaf


cdef inline double _interpolate(double fx, double fy, double fz, int code) noexcept nogil:
    """Trilinear interpolation in a cell whose corner values are the bits of `code` (0 gives
    exactly 0, 255 gives 1 within rounding)."""
    cdef double ex = 1.0 - fx, ey = 1.0 - fy, ez = 1.0 - fz
    cdef int c000 = code & 1, c100 = code >> 1 & 1, c010 = code >> 2 & 1, c110 = code >> 3 & 1
    cdef int c001 = code >> 4 & 1, c101 = code >> 5 & 1, c011 = code >> 6 & 1, c111 = code >> 7
    return ez * (ey * (ex * c000 + fx * c100) + fy * (ex * c010 + fx * c110)) + fz * (
        ey * (ex * c001 + fx * c101) + fy * (ex * c011 + fx * c111)
    )


cdef inline void _move_boxes(
    const Affine* pose, double margin, const Points* pts, Py_ssize_t first, Py_ssize_t last,
    Scratch* s,
) noexcept nogil:
    """Moved bounds of the boxes ``first:last`` (centres and half sides by coordinate) into
    ``s.bounds[:, :last - first]``: low x, high x, low y, high y, low z, high z, widened by
    `margin`."""
    cdef Py_ssize_t q, r, m = pts.m, f = s.fanout
    cdef const double* box = pts.boxes
    cdef double c0, c1, c2, h0, h1, h2, mid, reach
    for q in range(last - first):
        c0, c1, c2 = box[first + q], box[m + first + q], box[2 * m + first + q]
        h0, h1, h2 = box[3 * m + first + q], box[4 * m + first + q], box[5 * m + first + q]
        for r in range(3):
            mid = pose.a[r][0] * c0 + pose.a[r][1] * c1 + pose.a[r][2] * c2 + pose.b[r]
            reach = fabs(pose.a[r][0]) * h0 + fabs(pose.a[r][1]) * h1 + fabs(pose.a[r][2]) * h2
            reach = reach + margin
            s.bounds[2 * r * f + q], s.bounds[(2 * r + 1) * f + q] = mid - reach, mid + reach


cdef inline void _move_points(
    const Affine* pose, const double* xs, const double* ys, const double* zs, int32_t n,
    const Hand* hand, int32_out cells, double_out fx, double_out fy, double_out fz,
) noexcept nogil:
    """Move points ``(xs, ys, zs)[:n]`` into the grid: each one's cell (raveled) and its
    fractions within the cell. A point outside the grid is moved onto its outer layer of
    nodes, all outside the hand, so it never counts, as in the numpy baseline."""
    cdef double a00 = pose.a[0][0], a01 = pose.a[0][1], a02 = pose.a[0][2], b0 = pose.b[0]
    cdef double a10 = pose.a[1][0], a11 = pose.a[1][1], a12 = pose.a[1][2], b1 = pose.b[1]
    cdef double a20 = pose.a[2][0], a21 = pose.a[2][1], a22 = pose.a[2][2], b2 = pose.b[2]
    cdef double top_x = nextafter(<double>hand.nx, 0.0), top_y = nextafter(<double>hand.ny, 0.0)
    cdef double top_z = nextafter(<double>hand.nz, 0.0), x, y, z, gx, gy, gz
    cdef int32_t ny = <int32_t>hand.ny, nz = <int32_t>hand.nz, i, j, k, p
    for p in range(n):
        x, y, z = xs[p], ys[p], zs[p]
        # The numpy baseline's operations, in its order.
        gx = a00 * x + a01 * y + a02 * z + b0
        gy = a10 * x + a11 * y + a12 * z + b1
        gz = a20 * x + a21 * y + a22 * z + b2
        gx, gy = min2(max2(gx, 0.0), top_x), min2(max2(gy, 0.0), top_y)
        gz = min2(max2(gz, 0.0), top_z)
        i, j, k = <int32_t>gx, <int32_t>gy, <int32_t>gz
        cells[p] = (i * ny + j) * nz + k
        fx[p], fy[p], fz[p] = gx - i, gy - j, gz - k


cdef inline int64_t _count_leaf(
    const Affine* pose, const Points* pts, Py_ssize_t start, Py_ssize_t end, const Hand* hand,
    Scratch* s,
) noexcept nogil:
    """How many points ``start:end`` land where the interpolated occupancy exceeds 0.5.

    Moving the points and finding their cells, reading the cells' codes, interpolating: no
    loop branches on a point, and the first and last vectorise. Cell indices are 32-bit
    (`count_inside` checks that they fit).
    """
    cdef int32_t n = <int32_t>(end - start), p
    cdef const double* xs = pts.coords + start
    cdef int32_t* cells = s.cell
    cdef double* fx = s.frac
    cdef double* fy = s.frac + s.leaf
    cdef double* fz = s.frac + 2 * s.leaf
    cdef const uint8_t* codes = hand.codes
    cdef int64_t inside = 0
    _move_points(pose, xs, xs + pts.n, xs + 2 * pts.n, n, hand, cells, fx, fy, fz)
    for p in range(n):
        cells[p] = codes[cells[p]]
    for p in range(n):
        inside += _interpolate(fx[p], fy[p], fz[p], cells[p]) > 0.5
    return inside


cdef inline int _box_verdict(const Scratch* s, Py_ssize_t q, const Hand* hand) noexcept nogil:
    """`SKIP`, `WHOLE` or `OPEN` for the box of moved bounds `q`, from the hand's tables."""
    cdef const double* bounds = s.bounds + q
    cdef Py_ssize_t f = s.fanout
    cdef double lx = bounds[0], hx = bounds[f], ly = bounds[2 * f], hy = bounds[3 * f]
    cdef double lz = bounds[4 * f], hz = bounds[5 * f]
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
    cdef const uint64_t* t = hand.tiles
    cdef uint64_t i00 = <uint64_t>((x0 * hand.ty + y0) * hand.tz)
    cdef uint64_t i01 = <uint64_t>((x0 * hand.ty + y1) * hand.tz)
    cdef uint64_t i10 = <uint64_t>((x1 * hand.ty + y0) * hand.tz)
    cdef uint64_t i11 = <uint64_t>((x1 * hand.ty + y1) * hand.tz)
    cdef uint64_t u0 = <uint64_t>z0, u1 = <uint64_t>z1
    # Unsigned wrap-around leaves both packed counts exact: each final count fits.
    cdef uint64_t total = (
        t[i11 + u1] - t[i01 + u1] - t[i10 + u1] - t[i11 + u0]
        + t[i00 + u1] + t[i01 + u0] + t[i10 + u0] - t[i00 + u0]
    )
    if (total & LOW) == 0:
        return SKIP
    cdef bint within = lx >= 0.0 and ly >= 0.0 and lz >= 0.0 and hx < nx and hy < ny and hz < nz
    if within and <int64_t>(total >> HIGH) == (x1 - x0) * (y1 - y0) * (z1 - z0):
        return WHOLE
    return OPEN


cdef void _count_pose(
    const Affine* pose, double margin, const Points* pts, const Hand* hand, Scratch* s,
    int64_t* counts,
) noexcept nogil:
    """Interior and surface points inside the hand for one pose, into ``counts[0:2]``.

    Walks the tree of boxes depth first, the children of a node together: a box whose moved
    bounds cover no tile with an inside corner is skipped, one inside the grid covering full
    tiles only is counted whole, the points of the other leaves are tested one by one.
    """
    cdef const int64_t* ranges = pts.ranges
    cdef int64_t root, inside, top, first, last, node, verdict
    cdef Py_ssize_t q
    counts[0] = counts[1] = 0
    for root in range(pts.n_roots):
        inside, top = 0, 0
        first, last = root, root + 1
        while True:
            _move_boxes(pose, margin, pts, first, last, s)
            for q in range(last - first):
                node = first + q
                verdict = _box_verdict(s, q, hand)
                if verdict == SKIP:
                    continue
                if verdict == WHOLE:
                    inside += ranges[4 * node + 1] - ranges[4 * node]
                elif node < pts.first_leaf:
                    s.stack[top] = node
                    top += 1
                else:
                    inside += _count_leaf(
                        pose, pts, ranges[4 * node], ranges[4 * node + 1], hand, s
                    )
            if top == 0:
                break
            top -= 1
            first, last = ranges[4 * s.stack[top] + 2], ranges[4 * s.stack[top] + 3]
        # A root holds one kind of point.
        counts[0 if ranges[4 * root] < pts.n_interior else 1] += inside


cdef inline double _pose(
    const double[:, :, ::1] linear, const double[:, ::1] offset, Py_ssize_t p, double extent,
    Affine* pose,
) noexcept nogil:
    """Pose `p` into `pose`; returns its margin for the moved boxes (relative to the largest
    coordinate a moved point can have)."""
    cdef double largest = 0.0, row
    cdef Py_ssize_t r, c
    for r in range(3):
        for c in range(3):
            pose.a[r][c] = linear[p, r, c]
        pose.b[r] = offset[p, r]
    for r in range(3):
        row = fabs(pose.a[r][0]) + fabs(pose.a[r][1]) + fabs(pose.a[r][2])
        largest = max2(largest, fabs(pose.b[r]) + row * extent)
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
    cdef const int64_t[:, ::1] R = np.ascontiguousarray(ranges, dtype=np.int64).reshape(-1, 4)
    codes, tiles = np.ascontiguousarray(codes, np.uint8), np.ascontiguousarray(tiles, np.uint64)
    if codes.size >= 2**31:
        raise ValueError(f"a hand grid of {codes.size:,} cells is too large (2**31 at most)")
    cdef const uint8_t[::1] flat_codes = codes.ravel()
    cdef const uint64_t[::1] flat_tiles = tiles.ravel()
    sizes = np.diff(R, axis=1)[:, ::2] if len(R) else np.zeros((0, 2), np.int64)
    leaf, fanout = (max(1, int(v)) for v in sizes.max(axis=0, initial=1))
    # A node is pushed at most once per root: the internal nodes bound the stack.
    cdef int64_t[::1] stack = np.empty(max(1, first_leaf), np.int64)
    cdef double[:, ::1] bounds = np.empty((6, fanout))
    cdef int32_t[::1] cell = np.empty(leaf, np.int32)
    cdef double[:, ::1] frac = np.empty((3, leaf))
    cdef Points pts
    pts.coords, pts.n = (&C[0, 0] if C.shape[1] else NULL), C.shape[1]
    pts.boxes, pts.m = (&B[0, 0] if B.shape[1] else NULL), B.shape[1]
    pts.ranges = &R[0, 0] if R.shape[0] else NULL
    pts.n_roots, pts.first_leaf, pts.n_interior = n_roots, first_leaf, n_interior
    cdef Hand hand
    hand.codes, hand.tiles = (&flat_codes[0] if codes.size else NULL), &flat_tiles[0]
    hand.nx, hand.ny, hand.nz = codes.shape[0], codes.shape[1], codes.shape[2]
    hand.ty, hand.tz, hand.shift = tiles.shape[1], tiles.shape[2], shift
    cdef Scratch s
    s.stack, s.bounds, s.fanout = &stack[0], &bounds[0, 0], fanout
    s.cell, s.frac, s.leaf = &cell[0], &frac[0, 0], leaf
    cdef Affine pose
    cdef int64_t pair[2]
    cdef double margin
    cdef Py_ssize_t p
    with nogil:
        for p in range(first, last):
            margin = _pose(L, O, p, extent, &pose)
            _count_pose(&pose, margin, &pts, &hand, &s, pair)
            counts[p, 0], counts[p, 1] = pair[0], pair[1]
