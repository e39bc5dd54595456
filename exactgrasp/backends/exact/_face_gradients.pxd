# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""The exact volume's derivatives by every vertex, summed from per-face moments, compiled
(Cython, inline): from a call's entries (`vertex_sums`, through `_entries.vertex_sums`), or
in the kernel from each pose's rows as it ends (`pose_sums`, `_kernel.pose_volumes` with
``sums``); either the arithmetic of the numba `vertex_sums` it replaced, operation for
operation, each pose's rows in the order first touched.

A vertex ``i`` moves each face ``f`` around it with velocity ``φ_i δ``, so
``dV/dx_i = Σ_f (∫_{f ∩ other} φ_i dA) n_f``; per face and corner ``∫ φ_j dA`` is a fixed
weight row (`face_gradients.VertexTables.weights`) against the face's moments ``(F, M)``.

The directives above are this file's own: those of a ``.pyx`` that cimports it do not reach
its inline functions (bounds and division checks would stay).
"""

from libc.stdint cimport int64_t

from exactgrasp.backends.exact._tables cimport MomentRows, VertexSums


cdef inline void zero_pose(
    double[:, :, ::1] out_a, double[:, :, ::1] out_b, int64_t i
) noexcept nogil:
    """Pose ``i``'s rows of ``out_a`` (k, n_a, 3) and ``out_b`` (k, n_b, 3) set to zeros,
    just before its sums go in: they are then in the cache when the sums read them (zeros
    made beforehand, ``numpy.zeros``, 9.8 MB for a box's 256 poses, were out of it by then,
    and each vertex's sums read them back from memory)."""
    cdef int64_t v
    for v in range(out_a.shape[1]):
        out_a[i, v, 0] = 0.0
        out_a[i, v, 1] = 0.0
        out_a[i, v, 2] = 0.0
    for v in range(out_b.shape[1]):
        out_b[i, v, 0] = 0.0
        out_b[i, v, 1] = 0.0
        out_b[i, v, 2] = 0.0


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
    """Moments ``values[e]`` (6,) of row ``r`` added to pose ``i``'s derivatives ``out``
    (k, n, 3) at its three corners (`VertexSums` ``weights``, ``directions``, ``targets``).
    The moments and the direction are read into locals first: ``out``'s stores could
    otherwise alias them, and each corner would read them again after the last one's
    stores."""
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


cdef inline void add_row(
    VertexSums S, const double[:, ::1] values, int64_t e, int64_t r,
    double[:, :, ::1] out_a, double[:, :, ::1] out_b, int64_t i,
) noexcept nogil:
    """Row ``r``'s moments ``values[e]`` (6,) added to pose ``i``'s derivatives: a marker's
    (``r`` from ``S.part_from[0]``) sums onto the hand's vertices (``S.part_start`` ...), a
    face's onto its corners (of the object's from ``S.object_from[0]``, into ``out_b``). A
    row whose ``F`` is 0 is a face not met: skipped."""
    cdef int64_t p, q, v, d
    if r >= S.part_from[0]:
        p = r - S.part_from[0]
        for q in range(S.part_start[p], S.part_start[p + 1]):
            v = S.part_targets[q]
            for d in range(3):
                out_a[i, v, d] += S.part_vectors[q, d]
        return
    if values[e, 0] == 0.0 and values[e, 1] == 0.0 and values[e, 2] == 0.0:
        return
    if r >= S.object_from[0]:
        _face_row(S.weights, S.directions, S.targets, values, e, r, out_b, i)
    else:
        _face_row(S.weights, S.directions, S.targets, values, e, r, out_a, i)


cdef inline void vertex_sums(
    const int64_t[::1] begin, const int64_t[::1] end, const int64_t[::1] rows,
    const double[:, ::1] values, VertexSums S, double[:, :, ::1] out_a,
    double[:, :, ::1] out_b,
) noexcept nogil:
    """Each pose's moments (`moment_entries.MomentEntries`: ``begin``, ``end`` (k,), ``rows``
    (t,), ``values`` (t, 6); local coordinates, the object's in its own frame) summed onto
    the vertices (`add_row`, by ``S``), written to ``out_a`` (k, n_a, 3) (the hand's) and
    ``out_b`` (k, n_b, 3) (the object's), every element; squared length units."""
    cdef int64_t i, e
    for i in range(begin.shape[0]):
        zero_pose(out_a, out_b, i)
        for e in range(begin[i], end[i]):
            add_row(S, values, e, rows[e], out_a, out_b, i)


cdef inline void pose_sums(
    MomentRows G, VertexSums S, double[:, :, ::1] out_a, double[:, :, ::1] out_b, int64_t i
) noexcept nogil:
    """A pose's rows (``G``, as the kernel left them: each row touched listed) summed onto
    the vertices (`add_row`) into row ``i`` of ``out_a`` and ``out_b`` (zeroed by the
    caller), in the order first touched, and cleared in ``G``: what `vertex_sums` gives from
    the entries the kernel would have copied out (`_pose.copy_rows`), without them."""
    cdef int64_t k, r, d
    for k in range(G.state[0]):
        r = G.touched[k]
        add_row(S, G.values, r, r, out_a, out_b, i)
        for d in range(6):
            G.values[r, d] = 0.0
    G.state[0] = 0
