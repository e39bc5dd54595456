"""The exact kernel's data, as named tuples: what each table holds, its shape, dtype and units.

numba compiles a `typing.NamedTuple` as a tuple whose fields it reads by name, so the kernels
take these as they are (``grid.cell_faces``, not ``grid[5]``). In hot loops a kernel unpacks
the fields it needs once, into locals: reading a field inside a loop over faces would update
the arrays' reference counts there. Lengths are in the meshes' units, local coordinates (about
the centre of the hand's bounds, see `intersector.ExactIntersector`). The tables are built by
`prepare` and `grids`. Imports numpy and typing only.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: Per-pose result codes (`pose.pose_volumes`): a certified volume, a pose culled whole (volume
#: exactly 0), an uncertain sign or an inconsistent sum, a full crossing buffer (the caller
#: recomputes the last two with a boolean).
OK, CULLED, DEGENERATE, OVERFLOW = 0, 1, 2, 3
#: Columns of the per-pose statistics array: face pairs tried, crossing pairs, hand parts whose
#: cell the object's surface reached, parts classified whole inside, and outside.
STAT_PAIRS, STAT_CROSSING, STAT_CELLS_TOUCHED, STAT_CELLS_INSIDE, STAT_CELLS_OUTSIDE = range(5)
N_STATS = 5
#: Object faces are tested in runs of this many consecutive faces first
#: (`ObjectTables.face_runs`, `search.near_chunks`).
CHUNK = 16


class MeshTables(NamedTuple):
    """A closed, outward-oriented triangle mesh with its edge topology (`prepare.prepare_mesh`).

    ``n`` vertices, ``m`` faces, ``e = 3 m / 2`` edges.
    """

    #: (n, 3) float64: vertex coordinates.
    vertices: np.ndarray
    #: (m, 3) int64: vertex indices, counter-clockwise seen from outside.
    faces: np.ndarray
    #: (e, 2) int64: the undirected edges ``u < v``.
    edges: np.ndarray
    #: (e, 2) int64: each edge's faces ``t1`` (holding the directed edge ``u → v``) and ``t2``.
    edge_faces: np.ndarray
    #: (m, 3) int64: the edge of each face corner ``k → k + 1``.
    face_edges: np.ndarray
    #: (m, 3) bool: whether the face is that edge's ``t1`` (its owner, which records crossings).
    face_owns: np.ndarray
    #: (n + 1,) int64: vertex adjacency in CSR form, vertex u's entries from ``adj_start[u]``.
    adj_start: np.ndarray
    #: (2 e,) int64: the neighbour of each adjacency entry.
    adj_vertex: np.ndarray
    #: (2 e,) int64: the edge of each adjacency entry.
    adj_edge: np.ndarray


class CellGrid(NamedTuple):
    """A grid of cubic cells over a closed mesh, one cell of padding on every side
    (`grids.build_grid`). Cells are flat-indexed ``(i * shape[1] + j) * shape[2] + k``."""

    #: (3,) float64: lower corner of cell (0, 0, 0).
    corner: np.ndarray
    #: float: edge length of a cell.
    cell: float
    #: (3,) int64: cells per axis.
    shape: np.ndarray
    #: (cells,) int64: 1 inside the mesh, 0 outside, -1 touched by its surface.
    status: np.ndarray
    #: (cells + 1,) int64: CSR start of each cell's list in `cell_faces`.
    cell_start: np.ndarray
    #: (listed,) int64: the faces touching each cell (closed, grown by `GRID_MARGIN`).
    cell_faces: np.ndarray
    #: ((shape + 1).prod(),) int64: summed-volume table of the surface cells, flat, so that a
    #: box of cells' count takes 8 reads (`cells.surface_cells_in`).
    surface_table: np.ndarray


class HandTables(NamedTuple):
    """The fixed hand's per-face, per-edge, per-part and per-cell terms (`prepare.hand_tables`).

    ``m`` faces, ``e`` edges, ``parts`` hand-grid cells holding a vertex, ``cells`` hand-grid
    cells, ``listed`` entries of the grid's cell lists.
    """

    #: (m, 3) float64: ``D_t = (n_t · a) n_t`` (extended precision, rounded once), length units.
    D: np.ndarray
    #: (m, 3) float64: the normals ``(b - a) × (c - a)`` as the kernels compute them (area units).
    normals: np.ndarray
    #: (m, 6) float64: each face's bounding box (min xyz, max xyz).
    boxes: np.ndarray
    #: (m, 6) float64: unit normal (3), plane offset, `search.plane_err_coef` of its conditioning
    #: (times the coordinate bound: a plane distance's error), what its rounded ``D`` can cost
    #: (absolute, volume units).
    planes: np.ndarray
    #: (parts + 1, 2) int64: per part its flat cell index and first vertex; the vertices being
    #: numbered cell by cell, part k holds vertices ``parts[k, 1]`` to ``parts[k + 1, 1] - 1``.
    #: The last row is (-1, number of vertices).
    parts: np.ndarray
    #: (e, 2) float64: ``W_e`` and a bound on its error (volume units).
    edge_weights: np.ndarray
    #: (listed, 6) float64: `boxes` in the order of the grid's cell lists, each clipped to its
    #: cell (grown by `GRID_MARGIN`): a crossing in that cell lies in the clipped box.
    cell_boxes: np.ndarray
    #: (3, cells) int64: per axis d and cell, the index along d of the first cell at or after
    #: it, in its line of cells along d, that lists a face (the line's length if none).
    next_listed: np.ndarray
    #: (cells, 11) float64: per cell, a unit axis (its faces' area-weighted mean normal), their
    #: extent along it (min, max; widened by `GRID_MARGIN`) and their common bounding box clipped
    #: to the cell (min xyz, max xyz).
    cell_bounds: np.ndarray
    #: (e,) int64: the part of each edge, -1 where its ends lie in two parts.
    edge_part: np.ndarray
    #: (parts, 2) float64: the summed weight of each part's own edges and its error bound.
    part_weights: np.ndarray
    #: (n,) int64: where each vertex's adjacency entries to other parts end (they come first,
    #: see `prepare.part_edges`).
    adj_split: np.ndarray
    #: (0,) float64: empty; what the hand faces' rounded ``D`` costs is in `planes` and
    #: `edge_weights` (the object's is per face, `ObjectTables.d_cost`).
    d_cost: np.ndarray


class ObjectTables(NamedTuple):
    """The object's pose-independent terms (`prepare.object_tables`), in its own frame.

    ``m`` faces, ``n`` vertices, ``runs`` runs of `CHUNK` faces.
    """

    #: (runs, 4) float64: bounding sphere (centre, radius) of each run of consecutive faces.
    face_runs: np.ndarray
    #: (m,) float64: what each face's rounded ``D`` can cost its terms, over the coordinate
    #: bound (`prepare.face_d_coefs`; rigid motions keep it).
    d_cost: np.ndarray
    #: (2, 2) int64: the object as one part, in the layout of `HandTables.parts`.
    parts: np.ndarray
    #: (1,) bool: that part is never classified whole.
    whole: np.ndarray
    #: (n,) int64: end of each vertex's adjacency (no entries go to another part).
    adj_split: np.ndarray
    #: (0, 2) float64: empty; the object's edge weights change with the pose and are computed
    #: per pose (`sums.edge_weight`).
    edge_weights: np.ndarray
    #: (0,) int64: empty: the object's edges are not split by part.
    edge_part: np.ndarray
    #: (0, 2) float64: empty: no part of the object is summed whole.
    part_weights: np.ndarray


class Crossings(NamedTuple):
    """The edge crossings one mesh's faces record in a pose (``capacity`` long; the count is
    in `Workspace.nrec`)."""

    #: (capacity,) int64: the crossed edge.
    edge: np.ndarray
    #: (capacity,) float64: the crossing's parameter along the edge ``u → v``, in [0, 1].
    lam: np.ndarray
    #: (capacity,) float64: a bound on that parameter's error.
    err: np.ndarray


class Workspace(NamedTuple):
    """Scratch arrays of the face search and the pair tests, reused from pose to pose."""

    #: (hand e,) int64: crossings recorded per hand edge.
    hand_count: np.ndarray
    #: (object e,) int64: crossings recorded per object edge.
    object_count: np.ndarray
    #: The hand edges' crossings.
    hand_rec: Crossings
    #: The object edges' crossings.
    object_rec: Crossings
    #: (2,) int64: records so far in `hand_rec` and `object_rec`.
    nrec: np.ndarray
    #: (hand m,) int64: per hand face, the last object face it was paired with (a unique stamp
    #: per pose and object face).
    stamp: np.ndarray
    #: (2, 5) float64: crossing points of a pair: coordinates, error bound, whether it starts
    #: the common segment.
    points: np.ndarray
    #: (2, 3) int64: certain signs of each face's corners against the other's plane (0: none).
    signs: np.ndarray
    #: (2, 4) float64: those corners' signed distances and the row's error bound.
    dists: np.ndarray
    #: (3, 2) int64: a box of grid cells (inclusive index ranges per axis).
    cell_range: np.ndarray
    #: (hand cells,) bool: the hand cells some object face reached in this pose.
    cell_reached: np.ndarray
    #: (longest cell list,) int64: the listed faces of a cell that pass the box filters.
    survivors: np.ndarray


class PoseScratch(NamedTuple):
    """Per-pose arrays of `pose.pose_volumes`, reused from pose to pose."""

    #: (object n, 3) float64: the moved object's vertices.
    object_V: np.ndarray
    #: (object m, 3) float64: its faces' ``D``.
    object_D: np.ndarray
    #: (object m, 3) float64: its faces' normals ``(b - a) × (c - a)``.
    object_N: np.ndarray
    #: (hand n,) int8: hand vertex statuses, 1 inside the object, 0 outside, -1 unknown (one
    #: byte: the edge walks read them at random).
    hand_status: np.ndarray
    #: (object n,) int8: object vertex statuses in the hand.
    object_status: np.ndarray
    #: (parts,) bool: the hand parts classified whole in this pose.
    uniform: np.ndarray
    #: (max(hand n, object n),) int64: the breadth-first queue of the status walks.
    queue: np.ndarray
    #: (capacity,) int64: the records of edges crossed more than once (`sums.crossed_sum`).
    multi: np.ndarray
    #: (3,) float64: a hand vertex in the object's frame, for a point test.
    point: np.ndarray
    #: (hand m,) int64: faces already tested by a point test against the hand.
    hand_stamp: np.ndarray
    #: (object m,) int64: faces already tested by a point test against the object.
    object_stamp: np.ndarray
    #: (runs,) bool: the object's face runs that may come near the hand's surface.
    near: np.ndarray
    #: The search's and pair tests' scratch.
    work: Workspace
