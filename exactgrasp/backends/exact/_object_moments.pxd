# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""The object's side of the volume's derivatives, compiled (Cython, inline): per object face,
the moments ``(∫ n dA, ∫ x × n dA)`` of its part inside the hand, summed from what the
volume's pass leaves behind, in the object's own frame (local coordinates, unmoved); the
arithmetic of the numba stage it replaced, operation for operation.

They are the same sums as the hand's (`_moment_sums`), made of the same pieces: an object
face's boundary inside the hand runs along the pieces of its edges inside the hand and along
the traced segments, which run ``q → p`` on the object face. Taken in the object's frame, the
edges' whole shares do not change with the pose: they are tabled
(`tables.MomentTables.object_edge_moments`), and only the traced segments are moved there, by
the pose's inverse.

The directives above are this file's own: those of a ``.pyx`` that cimports it do not reach
its inline functions (bounds and division checks would stay).
"""

from libc.stdint cimport int8_t, int64_t

from exactgrasp.backends.exact._constants cimport SEGMENT_OBJECT_FACE, SEGMENT_P, SEGMENT_Q
from exactgrasp.backends.exact._moment_sums cimport (
    add_edge,
    add_piece,
    crossed_edge_moments,
    touch,
)
from exactgrasp.backends.exact._tables cimport MeshTables, MomentRows, MomentTables


cdef inline void _segment_piece(
    double[:, ::1] values, int64_t r, double[:, ::1] unit, int64_t s,
    const double[:, ::1] R, const double[::1] t, double[:, ::1] segs, int64_t k,
) noexcept nogil:
    """Add segment ``k`` (``segs``, local coordinates) to row ``r`` of ``values``: the piece
    ``q → p`` of object face ``s`` (unit normal ``unit[s]`` in the object's frame), both ends
    taken into the object's frame, ``x -> R^T (x - t)``."""
    cdef double nx = unit[s, 0], ny = unit[s, 1], nz = unit[s, 2]
    cdef int64_t p = SEGMENT_Q, q = SEGMENT_P  # the object face runs q → p
    cdef double ax = segs[k, p] - t[0], ay = segs[k, p + 1] - t[1], az = segs[k, p + 2] - t[2]
    cdef double bx = segs[k, q] - t[0], by = segs[k, q + 1] - t[1], bz = segs[k, q + 2] - t[2]
    cdef double px = R[0, 0] * ax + R[1, 0] * ay + R[2, 0] * az
    cdef double py = R[0, 1] * ax + R[1, 1] * ay + R[2, 1] * az
    cdef double pz = R[0, 2] * ax + R[1, 2] * ay + R[2, 2] * az
    cdef double qx = R[0, 0] * bx + R[1, 0] * by + R[2, 0] * bz
    cdef double qy = R[0, 1] * bx + R[1, 1] * by + R[2, 1] * bz
    cdef double qz = R[0, 2] * bx + R[1, 2] * by + R[2, 2] * bz
    add_piece(values, r, nx, ny, nz, px, py, pz, qx, qy, qz)


cdef inline void object_moments(
    MeshTables object_mesh, MomentTables mom, const double[:, ::1] R, const double[::1] t,
    int8_t[::1] S, int64_t[::1] cnt, int64_t[::1] rec_e, double[::1] rec_l, int64_t nrec,
    int64_t[::1] multi, double[:, ::1] segs, int64_t ncross, MomentRows G,
) noexcept nogil:
    """Moments ``(∫ n dA, ∫ x × n dA)`` of each object face's part inside the hand, in the
    object's frame, added to its row (``mom.object_edge_links``, from ``mom.object_from``) of
    ``G`` after a pose's volume pass: the traced segments, the whole edges from every inside
    vertex to higher-numbered ones, then the crossed edges' corrections
    (`_moment_sums.crossed_edge_moments`, as the hand's).

    ``object_mesh``: the object's mesh (local coordinates, unmoved); ``R`` (3, 3), ``t`` (3,):
    the pose, local coordinates (``x -> R x + t`` moves the object); ``S``
    (object n,) int8: the object's vertex statuses (1 inside the hand); ``cnt`` (object e,):
    crossings recorded per object edge (`tables.Workspace.object_count`), written to and put
    back; ``rec_e``, ``rec_l``, ``nrec``: the object records' edges and parameters along
    ``u → v`` and their number; ``multi`` (>= nrec,): scratch; ``segs`` (>= ncross,
    `tables.SEGMENT_COLUMNS`): the pose's traced segments; ``G``: the moments' rows, each
    row touched listed there.
    """
    cdef double[:, ::1] V = object_mesh.vertices, values = G.values
    cdef int64_t[::1] adj_start = object_mesh.adj_start, adj_vert = object_mesh.adj_vertex
    cdef int64_t[::1] stamp = G.stamp, touched = G.touched, state = G.state
    cdef int64_t row0 = mom.object_from[0], listed = state[0], pose = state[1], k, s, u, j
    for k in range(ncross):
        s = <int64_t>segs[k, SEGMENT_OBJECT_FACE]
        listed = touch(stamp, touched, listed, pose, row0 + s)
        _segment_piece(values, row0 + s, mom.object_normals, s, R, t, segs, k)
    for u in range(V.shape[0]):
        if S[u] != 1:
            continue
        for j in range(adj_start[u], adj_start[u + 1]):
            if u >= adj_vert[j]:
                continue
            listed = add_edge(
                values, stamp, touched, listed, pose, mom.object_edge_links,
                mom.object_edge_moments, object_mesh.adj_edge[j],
            )
    state[0] = listed
    crossed_edge_moments(
        V, object_mesh.edges, mom.object_edge_links, mom.object_edge_moments, S, cnt, rec_e,
        rec_l, nrec, multi, G,
    )
