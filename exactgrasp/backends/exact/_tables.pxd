# cython: language_level=3
"""The exact kernel's tables as the compiled kernels read them: one extension type per named
tuple of `exactgrasp.backends.exact.tables`, field for field, each array a typed memoryview
(C-contiguous; a boolean array is read as ``uint8_t``). A kernel indexes them as the named
tuples are indexed (``hand.planes[f, FACE_NORMAL]``). `HandTables` and `ObjectTables` share
`SideTables`, the fields a stage reads on either mesh. Each type is made from its named tuple
(``MeshTables(named_tuple)``), the arrays shared, not copied; `VertexSums` is
`face_gradients.VertexTables`, what the vertex derivatives' sums read."""

from libc.stdint cimport int8_t, int32_t, int64_t, uint8_t

cdef class SideTables:
    cdef readonly float[:, ::1] filters
    cdef readonly float[::1] filter_err
    cdef readonly double[::1] d_cost
    cdef readonly int64_t[:, ::1] parts
    cdef readonly int64_t[::1] adj_split
    cdef readonly double[:, ::1] edge_weights
    cdef readonly int64_t[::1] edge_part
    cdef readonly double[:, ::1] part_weights

cdef class MeshTables:
    cdef readonly double[:, ::1] vertices
    cdef readonly int64_t[:, ::1] faces
    cdef readonly int64_t[:, ::1] edges
    cdef readonly int64_t[:, ::1] edge_faces
    cdef readonly int64_t[:, ::1] face_edges
    cdef readonly uint8_t[:, ::1] face_owns
    cdef readonly int64_t[::1] adj_start
    cdef readonly int64_t[::1] adj_vertex
    cdef readonly int64_t[::1] adj_edge

cdef class CellGrid:
    cdef readonly double[::1] corner
    cdef readonly double cell
    cdef readonly int64_t[::1] shape
    cdef readonly int64_t[::1] status
    cdef readonly int64_t[::1] cell_start
    cdef readonly int64_t[::1] cell_faces
    cdef readonly int64_t[::1] surface_table
    cdef readonly float[:, ::1] boxes
    cdef readonly int64_t[::1] group_start
    cdef readonly float[:, ::1] groups
    cdef readonly double[:, ::1] bounds

cdef class HandTables(SideTables):
    cdef readonly double[:, ::1] D
    cdef readonly double[:, ::1] normals
    cdef readonly double[:, ::1] boxes
    cdef readonly double[:, ::1] planes
    cdef readonly int64_t[::1] cotree
    cdef readonly double[:, ::1] cotree_runs
    cdef readonly double[:, ::1] cotree_blocks
    cdef readonly double[:, ::1] face_records
    cdef readonly int32_t[:, ::1] face_links

cdef class ObjectTables(SideTables):
    cdef readonly int64_t[::1] edge_order
    cdef readonly double[:, ::1] edge_runs
    cdef readonly uint8_t[::1] whole

cdef class MomentTables:
    cdef readonly int64_t[::1] face_link
    cdef readonly int64_t[:, ::1] edge_links
    cdef readonly double[:, ::1] edge_moments
    cdef readonly int64_t[::1] vertex_link
    cdef readonly double[:, ::1] vertex_moments
    cdef readonly int64_t[::1] part_start
    cdef readonly int64_t[::1] part_link
    cdef readonly double[:, ::1] part_moments
    cdef readonly int64_t[::1] object_from
    cdef readonly int64_t[::1] row_count
    cdef readonly int64_t[::1] part_from
    cdef readonly int64_t[:, ::1] object_edge_links
    cdef readonly double[:, ::1] object_edge_moments
    cdef readonly double[:, ::1] object_normals

cdef class MomentRows:
    cdef readonly double[:, ::1] values
    cdef readonly int64_t[::1] stamp
    cdef readonly int64_t[::1] touched
    cdef readonly int64_t[::1] state

cdef class VertexSums:
    cdef readonly double[:, :, ::1] weights
    cdef readonly double[:, ::1] directions
    cdef readonly int64_t[:, ::1] targets
    cdef readonly int64_t[::1] object_from
    cdef readonly int64_t[::1] part_from
    cdef readonly int64_t[::1] part_start
    cdef readonly int64_t[::1] part_targets
    cdef readonly double[:, ::1] part_vectors

cdef class Crossings:
    cdef readonly int64_t[::1] edge
    cdef readonly double[::1] lam
    cdef readonly double[::1] err

cdef class Workspace:
    cdef readonly int64_t[::1] hand_count
    cdef readonly int64_t[::1] object_count
    cdef readonly Crossings hand_rec
    cdef readonly Crossings object_rec
    cdef readonly int64_t[::1] nrec
    cdef readonly int64_t[::1] pair_keys
    cdef readonly int32_t[::1] pair_tags
    cdef readonly int64_t[:, ::1] seeds
    cdef readonly double[:, ::1] points
    cdef readonly int64_t[:, ::1] signs
    cdef readonly double[:, ::1] dists
    cdef readonly uint8_t[::1] part_crossed
    cdef readonly int64_t[::1] survivors
    cdef readonly double[:, ::1] segments

cdef class PoseScratch:
    cdef readonly double[:, ::1] object_V
    cdef readonly double[:, ::1] object_D
    cdef readonly double[:, ::1] object_N
    cdef readonly int8_t[::1] hand_status
    cdef readonly int8_t[::1] object_status
    cdef readonly uint8_t[::1] uniform
    cdef readonly int64_t[::1] queue
    cdef readonly int64_t[::1] multi
    cdef readonly double[::1] point
    cdef readonly int64_t[::1] hand_stamp
    cdef readonly int64_t[::1] object_stamp
    cdef readonly uint8_t[::1] near
    cdef readonly uint8_t[::1] near_cotree
    cdef readonly uint8_t[::1] near_block
    cdef readonly uint8_t[::1] none
    cdef readonly Workspace work
