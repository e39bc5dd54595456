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


cdef inline void vertex_sums(
    const int64_t[::1] begin, const int64_t[::1] end, const int64_t[::1] rows,
    const double[:, ::1] values, const double[:, :, ::1] W, const double[:, ::1] D,
    const int64_t[:, ::1] T, int64_t first_object, int64_t first_part,
    const int64_t[::1] ps, const int64_t[::1] pt, const double[:, ::1] pv,
    double[:, :, ::1] out_a, double[:, :, ::1] out_b,
) noexcept nogil:
    """Each pose's moments (`moment_entries.MomentEntries`: ``begin``, ``end`` (k,), ``rows``
    (t,), ``values`` (t, 6); local coordinates, the object's in its own frame) summed onto
    the vertices, added to ``out_a`` (k, n_a, 3) (the hand's rows) and ``out_b`` (k, n_b, 3)
    (the object's), squared length units. ``W``, ``D``, ``T``, ``first_object`` (its
    ``object_from[0]``), ``first_part`` (``part_from[0]``), ``ps``, ``pt``, ``pv``: the
    `face_gradients.VertexTables` ``weights`` (L, 3, 6), ``directions`` (L, 3), ``targets``
    (L, 3), ``part_start``, ``part_targets``, ``part_vectors``. A row whose ``F`` is 0 is a
    face not met: skipped; a part's marker adds that part's sums. Only the vertices of faces
    met are written: fresh zeros (``numpy.zeros``) stay unmapped elsewhere."""
    cdef int64_t i, e, r, p, q, d, j, v
    cdef double w
    for i in range(begin.shape[0]):
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
            for j in range(3):
                w = 0.0
                for d in range(6):
                    w += W[r, j, d] * values[e, d]
                v = T[r, j]
                # Two loops rather than one view chosen per row: no memoryview to acquire.
                if r >= first_object:
                    for d in range(3):
                        out_b[i, v, d] += w * D[r, d]
                else:
                    for d in range(3):
                        out_a[i, v, d] += w * D[r, d]
