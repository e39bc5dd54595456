# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Python's ``min`` and ``max`` of doubles, for the compiled kernels (Cython, inline): the first
of the least or of the greatest argument, compared in Python's order, so that a signed zero or
a NaN decides as it does in Python (and did in the numba kernels these replaced). One home for
every kernel: a reordered comparison would change results in the last bit.
"""


cdef inline double max2(double a, double b) noexcept nogil:
    """Python's ``max(a, b)``: ``b`` only where it is greater."""
    return b if b > a else a


cdef inline double min2(double a, double b) noexcept nogil:
    """Python's ``min(a, b)``: ``b`` only where it is smaller."""
    return b if b < a else a


cdef inline double max3(double a, double b, double c) noexcept nogil:
    """Python's ``max(a, b, c)``: the first of the greatest."""
    return max2(max2(a, b), c)


cdef inline double min3(double a, double b, double c) noexcept nogil:
    """Python's ``min(a, b, c)``: the first of the least."""
    return min2(min2(a, b), c)
