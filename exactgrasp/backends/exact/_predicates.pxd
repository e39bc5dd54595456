# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Certified and filtered geometric tests of the exact kernel (Cython, inline): segment against
triangle with certified orientation signs, triangle against box (separating axes).

The orientation determinant and its error bound are `exactgrasp.geometry._predicates`'s.
"""

from libc.math cimport fabs
from libc.stdint cimport int64_t

from exactgrasp.backends.exact._constants cimport DEGENERATE
from exactgrasp.geometry._minmax cimport max3, min3
from exactgrasp.geometry._predicates cimport orient

# Outcomes of `edge_triangle` (and of a face pair): no crossing, a crossing, and `DEGENERATE`
# (a sign that no certified bound decides), the pose code of that name, so that a pair's
# outcome passes up unchanged.
cdef enum:
    NO = 0
    CROSS = 1


cdef inline int64_t sign(double x) noexcept nogil:
    """+1 for a positive x, else -1 (for distances already known to be non-zero)."""
    return 1 if x > 0 else -1


cdef inline (int64_t, double) edge_triangle(
    double px, double py, double pz, double qx, double qy, double qz,
    double ax, double ay, double az, double bx, double by, double bz,
    double cx, double cy, double cz,
    int64_t sp, double s1, int64_t sq, double s2, double bound,
) noexcept nogil:
    """Does segment pq cross triangle abc? Returns (code, lambda) with p + lambda (q - p).

    ``sp, s1`` and ``sq, s2`` are the certain sign (or 0) and the determinant of `orient`
    (a, b, c, p) and (a, b, c, q); code is `NO`, `CROSS` or `DEGENERATE`.
    """
    cdef bint k1, k2, k3, pos, neg
    cdef double o1, o2, o3
    if sp != 0 and sq != 0 and sp == sq:
        return NO, 0.0
    o1 = orient(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, bound, &k1)
    o2 = orient(px, py, pz, qx, qy, qz, bx, by, bz, cx, cy, cz, bound, &k2)
    o3 = orient(px, py, pz, qx, qy, qz, cx, cy, cz, ax, ay, az, bound, &k3)
    pos = (k1 and o1 > 0) or (k2 and o2 > 0) or (k3 and o3 > 0)
    neg = (k1 and o1 < 0) or (k2 and o2 < 0) or (k3 and o3 < 0)
    if pos and neg:
        return NO, 0.0
    if sp == 0 or sq == 0 or not (k1 and k2 and k3):
        return DEGENERATE, 0.0
    return CROSS, s1 / (s1 - s2)


cdef inline bint _sep(
    double ax, double ay, double az, double x0, double y0, double z0,
    double x1, double y1, double z1, double x2, double y2, double z2,
    double hx, double hy, double hz,
) noexcept nogil:
    """Is axis (ax, ay, az) separating a triangle and the box [-h*, h*] (half sizes h*)?"""
    cdef double p0 = ax * x0 + ay * y0 + az * z0
    cdef double p1 = ax * x1 + ay * y1 + az * z1
    cdef double p2 = ax * x2 + ay * y2 + az * z2
    cdef double r = hx * fabs(ax) + hy * fabs(ay) + hz * fabs(az)
    return (min3(p0, p1, p2) > r) | (max3(p0, p1, p2) < -r)


cdef inline bint _sep2(
    double a, double b, double p, double q, double r, double s, double ha, double hb
) noexcept nogil:
    """Is the axis with components (a, b) in two coordinates (0 in the third) separating a
    triangle whose corners project to a p + b q and a r + b s, and a box of half sizes
    ha, hb in those coordinates?"""
    cdef double p0 = a * p + b * q
    cdef double p1 = a * r + b * s
    cdef double rad = ha * fabs(a) + hb * fabs(b)
    cdef double lo = p1 if p1 < p0 else p0
    cdef double hi = p1 if p1 > p0 else p0
    return (lo > rad) | (hi < -rad)


cdef inline bint tri_box(
    double cx, double cy, double cz, double hh,
    double ax, double ay, double az, double bx, double by, double bz,
    double qx, double qy, double qz,
) noexcept nogil:
    """Separating-axis test: does triangle abc touch the cube of half-size hh at (cx, cy, cz)?
    (The numba kernel took the corners as rows; here their coordinates.)"""
    return tri_box_xyz(cx, cy, cz, hh, hh, hh, ax, ay, az, bx, by, bz, qx, qy, qz)


cdef inline bint tri_box_xyz(
    double cx, double cy, double cz, double hx, double hy, double hz,
    double ax, double ay, double az, double bx, double by, double bz,
    double qx, double qy, double qz,
) noexcept nogil:
    """Does the triangle with corners (ax, ay, az), (bx, by, bz), (qx, qy, qz) touch the box of
    centre (cx, cy, cz) and half sizes hx, hy, hz? The cross-product axes and the normal are
    tested together, with one branch: alone, their outcomes are hard to predict."""
    cdef double x0 = ax - cx, y0 = ay - cy, z0 = az - cz
    cdef double x1 = bx - cx, y1 = by - cy, z1 = bz - cz
    cdef double x2 = qx - cx, y2 = qy - cy, z2 = qz - cz
    cdef double e0x, e0y, e0z, e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz
    cdef bint out
    if min3(x0, x1, x2) > hx or max3(x0, x1, x2) < -hx:
        return False
    if min3(y0, y1, y2) > hy or max3(y0, y1, y2) < -hy:
        return False
    if min3(z0, z1, z2) > hz or max3(z0, z1, z2) < -hz:
        return False
    e0x, e0y, e0z = x1 - x0, y1 - y0, z1 - z0
    e1x, e1y, e1z = x2 - x1, y2 - y1, z2 - z1
    e2x, e2y, e2z = x0 - x2, y0 - y2, z0 - z2
    # Edge k × a coordinate axis: edge k's two ends project to one value, so its start
    # and the opposite corner suffice.
    out = _sep2(-e0z, e0y, y0, z0, y2, z2, hy, hz) | _sep2(e0z, -e0x, x0, z0, x2, z2, hx, hz)
    out |= _sep2(-e0y, e0x, x0, y0, x2, y2, hx, hy) | _sep2(-e1z, e1y, y1, z1, y0, z0, hy, hz)
    out |= _sep2(e1z, -e1x, x1, z1, x0, z0, hx, hz) | _sep2(-e1y, e1x, x1, y1, x0, y0, hx, hy)
    out |= _sep2(-e2z, e2y, y2, z2, y1, z1, hy, hz) | _sep2(e2z, -e2x, x2, z2, x1, z1, hx, hz)
    out |= _sep2(-e2y, e2x, x2, y2, x1, y1, hx, hy)
    nx = e0y * e1z - e0z * e1y
    ny = e0z * e1x - e0x * e1z
    nz = e0x * e1y - e0y * e1x
    return not (out | _sep(nx, ny, nz, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz))
