# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""The exact volume's derivatives by every vertex, summed from per-face moments, compiled
(Cython, inline), called through `_entries.vertex_sums`: the arithmetic of the numba
`vertex_sums` it replaced, operation for operation.

A vertex ``i`` moves each face ``f`` around it with velocity ``φ_i δ``, so
``dV/dx_i = Σ_f (∫_{f ∩ other} φ_i dA) n_f``; per face and corner ``∫ φ_j dA`` is a fixed
weight row (`face_gradients.VertexTables.weights`) against the face's moments ``(F, M)``.

The directives above are this file's own: those of a ``.pyx`` that cimports it do not reach
its inline functions (bounds and division checks would stay).
"""

from libc.stdint cimport int64_t


cdef inline void _zero(double[:, :, ::1] out, int64_t i) noexcept nogil:
    """Row ``i`` of ``out`` (k, n, 3) set to zeros."""
    cdef int64_t v
    for v in range(out.shape[1]):
        out[i, v, 0] = 0.0
        out[i, v, 1] = 0.0
        out[i, v, 2] = 0.0


cdef inline double _corner(
    const double[:, :, ::1] W, int64_t r, int64_t j, double m0, double m1, double m2,
    double m3, double m4, double m5,
) noexcept nogil:
    """``∫ φ_j dA`` of row ``r``'s corner ``j``: its weights ``W[r, j]`` (6,) against the
    moments ``m`` (6,), summed in order from zero."""
    return (
        0.0 + W[r, j, 0] * m0 + W[r, j, 1] * m1 + W[r, j, 2] * m2 + W[r, j, 3] * m3
        + W[r, j, 4] * m4 + W[r, j, 5] * m5
    )


cdef inline void _face_row(
    const double[:, :, ::1] W, const double[:, ::1] D, const int64_t[:, ::1] T,
    const double[:, ::1] values, int64_t e, int64_t r, double[:, :, ::1] out, int64_t i,
) noexcept nogil:
    """Entry ``e`` (row ``r``) added to pose ``i``'s derivatives ``out`` (k, n, 3) at its
    three corners (`vertex_sums`' tables). The moments and the direction are read into
    locals first: ``out``'s stores could otherwise alias them, and each corner would read
    them again after the last one's stores."""
    cdef double m0 = values[e, 0], m1 = values[e, 1], m2 = values[e, 2]
    cdef double m3 = values[e, 3], m4 = values[e, 4], m5 = values[e, 5]
    cdef double dx = D[r, 0], dy = D[r, 1], dz = D[r, 2], w
    cdef double w0 = _corner(W, r, 0, m0, m1, m2, m3, m4, m5)
    cdef double w1 = _corner(W, r, 1, m0, m1, m2, m3, m4, m5)
    cdef double w2 = _corner(W, r, 2, m0, m1, m2, m3, m4, m5)
    cdef int64_t j, v
    for j in range(3):
        w = w0 if j == 0 else (w1 if j == 1 else w2)
        v = T[r, j]
        out[i, v, 0] += w * dx
        out[i, v, 1] += w * dy
        out[i, v, 2] += w * dz


cdef inline void vertex_sums(
    const int64_t[::1] begin, const int64_t[::1] end, const int64_t[::1] rows,
    const double[:, ::1] values, const double[:, :, ::1] W, const double[:, ::1] D,
    const int64_t[:, ::1] T, int64_t first_object, int64_t first_part,
    const int64_t[::1] ps, const int64_t[::1] pt, const double[:, ::1] pv,
    double[:, :, ::1] out_a, double[:, :, ::1] out_b,
) noexcept nogil:
    """Each pose's moments (`moment_entries.MomentEntries`: ``begin``, ``end`` (k,), ``rows``
    (t,), ``values`` (t, 6); local coordinates, the object's in its own frame) summed onto
    the vertices, written to ``out_a`` (k, n_a, 3) (the hand's rows) and ``out_b`` (k, n_b, 3)
    (the object's), squared length units. ``W``, ``D``, ``T``, ``first_object`` (its
    ``object_from[0]``), ``first_part`` (``part_from[0]``), ``ps``, ``pt``, ``pv``: the
    `face_gradients.VertexTables` ``weights`` (L, 3, 6), ``directions`` (L, 3), ``targets``
    (L, 3), ``part_start``, ``part_targets``, ``part_vectors``. A row whose ``F`` is 0 is a
    face not met: skipped; a part's marker adds that part's sums.

    Each pose's rows of ``out_a`` and ``out_b`` are zeroed just before its sums go in, so
    that they are in the cache when the sums read them: zeros made beforehand (``numpy.zeros``,
    9.8 MB for a box's 256 poses) were out of it by then, and each vertex's sums read them
    back from memory."""
    cdef int64_t i, e, r, p, q, d
    for i in range(begin.shape[0]):
        _zero(out_a, i)
        _zero(out_b, i)
        for e in range(begin[i], end[i]):
            r = rows[e]
            if r >= first_part:
                p = r - first_part
                for q in range(ps[p], ps[p + 1]):
                    for d in range(3):
                        out_a[i, pt[q], d] += pv[q, d]
                continue
            if values[e, 0] == 0.0 and values[e, 1] == 0.0 and values[e, 2] == 0.0:
                continue
            if r >= first_object:
                _face_row(W, D, T, values, e, r, out_b, i)
            else:
                _face_row(W, D, T, values, e, r, out_a, i)
