# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False, embedsignature=True
"""Winding numbers, compiled ahead of time (Cython): of one point and of every node of a
lattice. `exactgrasp.geometry.winding` is the module to import; it documents the method.

Every floating-point operation is the one the former numba kernels did, in the same order, and
the extension is built without contraction into fused multiply-adds and without fast-math
(meson.build), so the results are the same to the bit. The loops run without the GIL.
"""

import numpy as np

from libc.math cimport atan2, ceil, floor, sqrt, M_PI
from libc.stdint cimport int8_t, int64_t, uint8_t

from exactgrasp.geometry._minmax cimport max3, min3


cdef double _winding(
    const double[:] x, const double[:, :] V, const int64_t[:, :] F
) noexcept nogil:
    """Sum of the triangles' solid angles over 4 pi (van Oosterom and Strackee)."""
    cdef double x0 = x[0], x1 = x[1], x2 = x[2], total = 0.0
    cdef double a0, a1, a2, b0, b1, b2, c0, c1, c2, la, lb, lc, num, ab, bc, ca, den
    cdef Py_ssize_t f, i, j, k
    for f in range(F.shape[0]):
        i, j, k = F[f, 0], F[f, 1], F[f, 2]
        a0, a1, a2 = V[i, 0] - x0, V[i, 1] - x1, V[i, 2] - x2
        b0, b1, b2 = V[j, 0] - x0, V[j, 1] - x1, V[j, 2] - x2
        c0, c1, c2 = V[k, 0] - x0, V[k, 1] - x1, V[k, 2] - x2
        la = sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        lb = sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        lc = sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        num = a0 * (b1 * c2 - b2 * c1)
        num += a1 * (b2 * c0 - b0 * c2)
        num += a2 * (b0 * c1 - b1 * c0)
        ab = a0 * b0 + a1 * b1 + a2 * b2
        bc = b0 * c0 + b1 * c1 + b2 * c2
        ca = c0 * a0 + c1 * a1 + c2 * a2
        den = la * lb * lc + ab * lc + bc * la + ca * lb
        total += 2.0 * atan2(num, den)
    return total / (4.0 * M_PI)


def winding_number(x, V, F):
    """Generalised winding number of a point with respect to a closed mesh (not rounded).

    Parameters
    ----------
    x : array_like, shape (3,)
        The point.
    V : array_like, shape (n, 3)
        The mesh's vertices.
    F : array_like, shape (m, 3)
        The mesh's triangles, indices into `V`.

    Returns
    -------
    float
        The sum of the triangles' signed solid angles seen from `x` over 4 pi: 1 inside a
        closed outward-oriented shell, 0 outside, fractional near or on the surface.
    """
    cdef const double[:] xv
    cdef const double[:, :] Vv
    cdef const int64_t[:, :] Fv
    cdef double total
    try:  # float64 and int64 arrays as they are: most calls, and the cheapest
        xv, Vv, Fv = x, V, F
    except (TypeError, ValueError):
        xv = np.asarray(x, dtype=np.float64)
        Vv = np.asarray(V, dtype=np.float64)
        Fv = np.asarray(F, dtype=np.int64)
    with nogil:
        total = _winding(xv, Vv, Fv)
    return total


cdef inline int _edge_side(
    double px, double py, double ax, double ay, double bx, double by
) noexcept nogil:
    """Side (+1 left, -1 right) of p for the directed edge a->b, never 0 for a != b, in one
    fixed vertex order whichever way the edge is traversed."""
    cdef int flip = 1
    if ax > bx or (ax == bx and ay > by):
        ax, ay, bx, by = bx, by, ax, ay
        flip = -1
    cdef double dx = bx - ax, dy = by - ay
    cdef double value = dx * (py - ay) - dy * (px - ax)
    if value > 0.0:
        return flip
    if value < 0.0:
        return -flip
    # Exactly on the edge's line: decide as if p were moved by (eps, eps**2).
    if dy != 0.0:
        return -flip if dy > 0.0 else flip
    if dx != 0.0:
        return flip if dx > 0.0 else -flip
    return 0


cdef inline double _edge_value(
    double px, double py, double ax, double ay, double bx, double by
) noexcept nogil:
    """Twice the signed area of (a, b, p), in the same fixed vertex order as `_edge_side`."""
    if ax > bx or (ax == bx and ay > by):
        return -((ax - bx) * (py - by) - (ay - by) * (px - bx))
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


cdef void _column_crossings(
    const double[:, :, :] T, Py_ssize_t nx, Py_ssize_t ny, bint count_only,
    int64_t[::1] starts, int64_t[::1] fill, double[::1] heights, int8_t[::1] signs,
) noexcept nogil:
    """Visit every (column, triangle) crossing; count them or write height and sign."""
    cdef Py_ssize_t t, i, j, i0, i1, j0, j1, column, slot
    cdef double ax, ay, az, bx, by, bz, cx, cy, cz, px, py, wa, wb, wc, total
    cdef int s_ab
    for t in range(T.shape[0]):
        ax, ay, az = T[t, 0, 0], T[t, 0, 1], T[t, 0, 2]
        bx, by, bz = T[t, 1, 0], T[t, 1, 1], T[t, 1, 2]
        cx, cy, cz = T[t, 2, 0], T[t, 2, 1], T[t, 2, 2]
        i0 = max(0, <int64_t>ceil(min3(ax, bx, cx)))
        i1 = min(nx - 1, <int64_t>floor(max3(ax, bx, cx)))
        j0 = max(0, <int64_t>ceil(min3(ay, by, cy)))
        j1 = min(ny - 1, <int64_t>floor(max3(ay, by, cy)))
        for i in range(i0, i1 + 1):
            px = <double>i
            for j in range(j0, j1 + 1):
                py = <double>j
                s_ab = _edge_side(px, py, ax, ay, bx, by)
                if s_ab == 0:
                    continue
                if _edge_side(px, py, bx, by, cx, cy) != s_ab:
                    continue
                if _edge_side(px, py, cx, cy, ax, ay) != s_ab:
                    continue
                column = i * ny + j
                if count_only:
                    starts[column + 1] += 1
                    continue
                # Barycentric weights all share one sign: the height stays between the
                # corners' heights even for slivers.
                wa = _edge_value(px, py, bx, by, cx, cy)
                wb = _edge_value(px, py, cx, cy, ax, ay)
                wc = _edge_value(px, py, ax, ay, bx, by)
                total = wa + wb + wc
                slot = starts[column] + fill[column]
                fill[column] += 1
                heights[slot] = (wa * az + wb * bz + wc * cz) / total
                # Counter-clockwise in xy means the outward normal points up (+z).
                signs[slot] = <int8_t>s_ab


def _crossings_by_column(triangles, Py_ssize_t nx, Py_ssize_t ny):
    """Every (column, triangle) crossing: column c's heights and signs are
    ``heights[starts[c]:starts[c + 1]]`` and ``signs[...]``, in no order."""
    cdef const double[:, :, :] T = np.asarray(triangles, dtype=np.float64)
    starts_array = np.zeros(nx * ny + 1, np.int64)
    cdef int64_t[::1] starts = starts_array
    cdef int64_t[::1] fill = np.zeros(nx * ny, np.int64)
    cdef Py_ssize_t c
    with nogil:
        _column_crossings(T, nx, ny, True, starts, fill, None, None)
        for c in range(nx * ny):
            starts[c + 1] += starts[c]
    heights = np.empty(starts[nx * ny], np.float64)
    signs = np.empty(starts[nx * ny], np.int8)
    cdef double[::1] h = heights
    cdef int8_t[::1] s = signs
    with nogil:
        _column_crossings(T, nx, ny, False, starts, fill, h, s)
    return starts_array, heights, signs


cdef inline void _insertion_order(
    const double[::1] heights, Py_ssize_t lo, Py_ssize_t hi, bint descending,
    int64_t[::1] order,
) noexcept nogil:
    """``order[:hi - lo]``: the crossings ``lo:hi`` by height (stable), by insertion: a column
    crosses the surface a few times."""
    cdef Py_ssize_t m, q
    cdef double x
    for m in range(hi - lo):
        x = heights[lo + m]
        q = m
        while q > 0 and (
            heights[lo + order[q - 1]] < x if descending else heights[lo + order[q - 1]] > x
        ):
            order[q] = order[q - 1]
            q -= 1
        order[q] = m


cdef Py_ssize_t _longest(const int64_t[::1] starts) noexcept nogil:
    """The most crossings of one column (at least 1)."""
    cdef Py_ssize_t c, most = 1
    for c in range(starts.shape[0] - 1):
        most = max(most, starts[c + 1] - starts[c])
    return most


cdef void _fill_inside(
    const int64_t[::1] starts, const double[::1] heights, const int8_t[::1] signs,
    Py_ssize_t ny, Py_ssize_t nz, int64_t[::1] order, uint8_t[:, :, ::1] inside,
) noexcept nogil:
    """Mark the nodes whose winding number (the signs of the crossings above) is >= 1."""
    cdef Py_ssize_t c, lo, hi, i, j, k, pointer
    cdef int64_t winding
    for c in range(starts.shape[0] - 1):
        lo, hi = starts[c], starts[c + 1]
        if hi == lo:
            continue
        _insertion_order(heights, lo, hi, False, order)
        i, j = c // ny, c % ny
        # Sweep down from the top.
        winding = 0
        pointer = hi - lo - 1
        for k in range(nz - 1, -1, -1):
            while pointer >= 0 and heights[lo + order[pointer]] > k:
                winding += signs[lo + order[pointer]]
                pointer -= 1
            if winding >= 1:
                inside[i, j, k] = 1


def winding_inside_lattice(triangles, Py_ssize_t nx, Py_ssize_t ny, Py_ssize_t nz):
    """Nodes of an ``nx x ny x nz`` lattice whose winding number is at least 1.

    Parameters
    ----------
    triangles : array_like, shape (m, 3, 3)
        Corners of the shells' triangles in index coordinates (node ``(i, j, k)`` at integer
        coordinates ``(i, j, k)``).
    nx, ny, nz : int
        Nodes along each axis.

    Returns
    -------
    numpy.ndarray, shape (nx, ny, nz), uint8
        1 at the nodes inside, 0 elsewhere.
    """
    starts, heights, signs = _crossings_by_column(triangles, nx, ny)
    inside = np.zeros((nx, ny, nz), np.uint8)
    cdef int64_t[::1] order = np.empty(_longest(starts), np.int64)
    cdef uint8_t[:, :, ::1] out = inside
    cdef const int64_t[::1] s = starts
    cdef const double[::1] h = heights
    cdef const int8_t[::1] w = signs
    with nogil:
        _fill_inside(s, h, w, ny, nz, order, out)
    return inside
