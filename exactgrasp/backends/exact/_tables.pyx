# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True
"""The compiled kernels' tables, made from the named tuples of
`exactgrasp.backends.exact.tables` (see ``_tables.pxd``)."""

import numpy as np

cdef _bytes(a):
    """A boolean array as the ``uint8_t`` memoryview reads it (shared, not copied)."""
    a = np.asarray(a)
    return a.view(np.uint8) if a.dtype == np.bool_ else a

cdef class SideTables:
    pass

cdef class MeshTables:
    """`tables.MeshTables`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.vertices = tables.vertices
        self.faces = tables.faces
        self.edges = tables.edges
        self.edge_faces = tables.edge_faces
        self.face_edges = tables.face_edges
        self.face_owns = _bytes(tables.face_owns)
        self.adj_start = tables.adj_start
        self.adj_vertex = tables.adj_vertex
        self.adj_edge = tables.adj_edge

cdef class CellGrid:
    """`tables.CellGrid`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.corner = tables.corner
        self.cell = tables.cell
        self.shape = tables.shape
        self.status = tables.status
        self.cell_start = tables.cell_start
        self.cell_faces = tables.cell_faces
        self.surface_table = tables.surface_table
        self.boxes = tables.boxes
        self.group_start = tables.group_start
        self.groups = tables.groups
        self.bounds = tables.bounds

cdef class HandTables(SideTables):
    """`tables.HandTables`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.D = tables.D
        self.normals = tables.normals
        self.boxes = tables.boxes
        self.planes = tables.planes
        self.parts = tables.parts
        self.edge_weights = tables.edge_weights
        self.edge_part = tables.edge_part
        self.part_weights = tables.part_weights
        self.adj_split = tables.adj_split
        self.d_cost = tables.d_cost
        self.cotree = tables.cotree
        self.cotree_runs = tables.cotree_runs
        self.cotree_blocks = tables.cotree_blocks
        self.filters = tables.filters
        self.filter_err = tables.filter_err
        self.face_records = tables.face_records
        self.face_links = tables.face_links

cdef class ObjectTables(SideTables):
    """`tables.ObjectTables`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.edge_order = tables.edge_order
        self.edge_runs = tables.edge_runs
        self.filters = tables.filters
        self.filter_err = tables.filter_err
        self.d_cost = tables.d_cost
        self.parts = tables.parts
        self.whole = _bytes(tables.whole)
        self.adj_split = tables.adj_split
        self.edge_weights = tables.edge_weights
        self.edge_part = tables.edge_part
        self.part_weights = tables.part_weights

cdef class MomentTables:
    """`tables.MomentTables`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.face_link = tables.face_link
        self.edge_links = tables.edge_links
        self.edge_moments = tables.edge_moments
        self.vertex_link = tables.vertex_link
        self.vertex_moments = tables.vertex_moments
        self.part_start = tables.part_start
        self.part_link = tables.part_link
        self.part_moments = tables.part_moments
        self.object_from = tables.object_from
        self.row_count = tables.row_count
        self.part_from = tables.part_from
        self.object_edge_links = tables.object_edge_links
        self.object_edge_moments = tables.object_edge_moments
        self.object_normals = tables.object_normals

cdef class MomentRows:
    """`tables.MomentRows`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.values = tables.values
        self.stamp = tables.stamp
        self.touched = tables.touched
        self.state = tables.state

cdef class VertexSums:
    """`face_gradients.VertexTables`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.weights = tables.weights
        self.directions = tables.directions
        self.targets = tables.targets
        self.object_from = tables.object_from
        self.part_from = tables.part_from
        self.part_start = tables.part_start
        self.part_targets = tables.part_targets
        self.part_vectors = tables.part_vectors

cdef class Crossings:
    """`tables.Crossings`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.edge = tables.edge
        self.lam = tables.lam
        self.err = tables.err

cdef class Workspace:
    """`tables.Workspace`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.hand_count = tables.hand_count
        self.object_count = tables.object_count
        self.hand_rec = Crossings(tables.hand_rec)
        self.object_rec = Crossings(tables.object_rec)
        self.nrec = tables.nrec
        self.pair_keys = tables.pair_keys
        self.pair_tags = tables.pair_tags
        self.seeds = tables.seeds
        self.points = tables.points
        self.signs = tables.signs
        self.dists = tables.dists
        self.part_crossed = _bytes(tables.part_crossed)
        self.survivors = tables.survivors
        self.segments = tables.segments

cdef class PoseScratch:
    """`tables.PoseScratch`, compiled; made from that named tuple."""

    def __init__(self, tables):
        self.object_V = tables.object_V
        self.object_D = tables.object_D
        self.object_N = tables.object_N
        self.hand_status = tables.hand_status
        self.object_status = tables.object_status
        self.uniform = _bytes(tables.uniform)
        self.queue = tables.queue
        self.multi = tables.multi
        self.point = tables.point
        self.hand_stamp = tables.hand_stamp
        self.object_stamp = tables.object_stamp
        self.near = _bytes(tables.near)
        self.near_cotree = _bytes(tables.near_cotree)
        self.near_block = _bytes(tables.near_block)
        self.none = _bytes(tables.none)
        # The driver builds the search's scratch compiled already (it may replace it).
        work = tables.work
        self.work = work if isinstance(work, Workspace) else Workspace(work)
