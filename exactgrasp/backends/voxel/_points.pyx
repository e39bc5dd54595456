# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False, embedsignature=True
"""The surface sampler's dart throwing, compiled ahead of time (Cython).
`exactgrasp.backends.voxel.points` is the module to import; it documents the sampler.

The same floating-point operations in the same order as the former numba kernel, built
without fused multiply-adds or fast-math (meson.build): the same points are accepted. The
loop runs without the GIL.
"""

import numpy as np

from libc.math cimport isnan
from libc.stdint cimport int32_t, int64_t, uint8_t

# Cells of the sampler's grid per candidate at most: the grid is dense, and cells grow beyond
# one spacing (still correct, only slower per lookup) when a sparse extent would need more.
cdef int64_t CELLS_PER_CANDIDATE = 8


cdef struct Cells:
    # The sampler's grid: the points' lower corner, the cells' side, cells along each axis.
    double lower[3]
    double side
    int64_t n[3]


cdef double _column_min(const double[:, :] P, Py_ssize_t d) noexcept nogil:
    """numpy's ``P[:, d].min()`` as numba computed it: the first of the least, a NaN first."""
    cdef double least = P[0, d], v
    cdef Py_ssize_t p
    if isnan(least):
        return least
    for p in range(1, P.shape[0]):
        v = P[p, d]
        if isnan(v):
            return v
        if v < least:
            least = v
    return least


cdef double _column_max(const double[:, :] P, Py_ssize_t d) noexcept nogil:
    """numpy's ``P[:, d].max()`` as numba computed it: the first of the greatest."""
    cdef double most = P[0, d], v
    cdef Py_ssize_t p
    if isnan(most):
        return most
    for p in range(1, P.shape[0]):
        v = P[p, d]
        if isnan(v):
            return v
        if v > most:
            most = v
    return most


cdef Cells _cells(const double[:, :] P, double spacing) noexcept nogil:
    """The sampler's grid: cells at least `spacing` wide, few enough for the points."""
    cdef Cells cells
    cdef double extent[3]
    cdef Py_ssize_t d, n = P.shape[0]
    for d in range(3):
        cells.lower[d] = _column_min(P, d)
        extent[d] = _column_max(P, d) - cells.lower[d]
    # A conflicting point lies in one of the 27 cells around a candidate's own when cells are
    # at least one spacing wide.
    cdef double side = spacing
    while (extent[0] / side + 3) * (extent[1] / side + 3) * (extent[2] / side + 3) > (
        CELLS_PER_CANDIDATE * n + 27
    ):
        side *= 1.25
    cells.side = side
    # One empty layer of cells all round, so that neighbours need no bounds test.
    for d in range(3):
        cells.n[d] = <int64_t>(extent[d] / side) + 3
    return cells


cdef bint _clashes(
    const double[:, :] P, Py_ssize_t p, int64_t cx, int64_t cy, int64_t cz, int64_t ny,
    int64_t nz, const int32_t[::1] heads, const int32_t[::1] chain, double limit2,
) noexcept nogil:
    """Whether an accepted point in the 27 cells around ``(cx, cy, cz)`` is closer than the
    spacing to point `p`."""
    cdef bint clash = False
    cdef int64_t dx, dy, dz, q, d
    cdef double d2, diff
    for dx in range(-1, 2):
        for dy in range(-1, 2):
            for dz in range(-1, 2):
                q = heads[((cx + dx) * ny + cy + dy) * nz + cz + dz]
                while q != -1 and not clash:
                    d2 = 0.0
                    for d in range(3):
                        diff = P[p, d] - P[q, d]
                        d2 += diff * diff
                    if d2 < limit2:
                        clash = True
                    q = chain[q]
    return clash


cdef void _throw(
    const double[:, :] P, double spacing, const Cells* cells, int32_t[::1] heads,
    int32_t[::1] chain, uint8_t[::1] accepted,
) noexcept nogil:
    """Accept, in order, the points not closer than `spacing` to an accepted one."""
    cdef int64_t ny = cells.n[1], nz = cells.n[2], cx, cy, cz, own
    cdef double limit2 = spacing * spacing, side = cells.side
    cdef Py_ssize_t p
    for p in range(P.shape[0]):
        cx = <int64_t>((P[p, 0] - cells.lower[0]) / side) + 1
        cy = <int64_t>((P[p, 1] - cells.lower[1]) / side) + 1
        cz = <int64_t>((P[p, 2] - cells.lower[2]) / side) + 1
        if _clashes(P, p, cx, cy, cz, ny, nz, heads, chain, limit2):
            continue
        accepted[p] = 1
        own = (cx * ny + cy) * nz + cz
        chain[p] = heads[own]
        heads[own] = <int32_t>p


def dart_throw(points, double spacing):
    """Indices of the points accepted in order when not closer than `spacing` to an accepted one.

    Parameters
    ----------
    points : numpy.ndarray, shape (n, 3), float64
        Candidates, in the order they are considered (n >= 1).
    spacing : float
        Least distance between accepted points (the points' length units).

    Returns
    -------
    numpy.ndarray, shape (k,), int64
        Increasing indices into `points`.
    """
    cdef const double[:, :] P = np.asarray(points, dtype=np.float64)
    cdef Cells cells
    if P.shape[0] == 0 or P.shape[1] != 3:
        raise ValueError(f"dart_throw needs (n >= 1, 3) points, got shape {np.shape(points)}")
    with nogil:
        cells = _cells(P, spacing)
    cdef int32_t[::1] heads = np.full(cells.n[0] * cells.n[1] * cells.n[2], -1, np.int32)
    cdef int32_t[::1] chain = np.full(P.shape[0], -1, np.int32)
    accepted = np.zeros(P.shape[0], np.uint8)
    cdef uint8_t[::1] keep = accepted
    with nogil:
        _throw(P, spacing, &cells, heads, chain, keep)
    return np.flatnonzero(accepted).astype(np.int64, copy=False)
