# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Filtered orientation predicates for the compiled kernels (Cython, inline): the crossings
kernel (``_pair_tests.pxd``) and the exact backend's kernel (``backends/exact/_pairs.pxd``,
``_classify.pxd``, ``_predicates.pxd``) cimport them.

`orient_det` is the determinant of Shewchuk's orientation test evaluated in one fixed order,
`orient_bound` its static error bound: a sign whose magnitude exceeds the bound is certain
(`certain_sign`). The arithmetic is the numba predicates' it replaced, operation for operation,
so the kernels that use it give their predecessors' bits (``tests/test_kernel_goldens.py``,
``tests/test_exact_kernel_goldens.py``).
"""

from libc.math cimport fabs


cdef inline double orient_bound(double extent) noexcept nogil:
    """Error bound of `orient_det` for points whose coordinates span at most ``extent``:
    Shewchuk's (7 + 56 eps) eps times the permanent, at most 6 L^3, with a margin of two."""
    return 1e-14 * extent * extent * extent


cdef inline double orient_det(
    double ax, double ay, double az, double bx, double by, double bz,
    double cx, double cy, double cz, double dx, double dy, double dz,
) noexcept nogil:
    """Six times the signed volume of tetrahedron abcd (sign > 0: d below abc's plane)."""
    cdef double adx = ax - dx, ady = ay - dy, adz = az - dz
    cdef double bdx = bx - dx, bdy = by - dy, bdz = bz - dz
    cdef double cdx = cx - dx, cdy = cy - dy, cdz = cz - dz
    cdef double det = adz * (bdx * cdy - cdx * bdy) + bdz * (cdx * ady - adx * cdy)
    det += cdz * (adx * bdy - bdx * ady)
    return det


cdef inline double orient(
    double ax, double ay, double az, double bx, double by, double bz,
    double cx, double cy, double cz, double dx, double dy, double dz,
    double bound, bint *certain,
) noexcept nogil:
    """`orient_det`, and in ``certain`` whether its sign is certain (beyond ``bound``)."""
    cdef double det = orient_det(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz)
    certain[0] = fabs(det) > bound
    return det


cdef inline int certain_sign(double det, double bound) noexcept nogil:
    """+1 or -1 when ``det`` is beyond ``bound``, else 0 (uncertain)."""
    if det > bound:
        return 1
    if det < -bound:
        return -1
    return 0
