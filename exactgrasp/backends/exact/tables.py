"""The exact kernel's data, as named tuples: what each table holds, its shape, dtype and units.

The compiled kernels read them through the extension types of ``_tables.pxd``, one per named
tuple, field for field, made from the tuple with its arrays shared, not copied (a kernel reads
``grid.cell_faces`` as Python does, never ``grid[5]``). Lengths are in the meshes' units, local
coordinates (about the centre of the hand's bounds, see `intersector.ExactIntersector`). The
tables are built by `prepare` and `grids`.

Long because every table of the kernels is declared here, each field with its shape, dtype and
units: one place to read what the kernels take.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: Per-pose result codes (`_kernel.pose_volumes`): a certified volume, a pose culled whole (volume
#: exactly 0), an uncertain sign or an inconsistent sum, a full crossing buffer (the caller
#: recomputes the last two with a boolean).
OK, CULLED, DEGENERATE, OVERFLOW = 0, 1, 2, 3
#: A per-pose scratch table was too small: the driver enlarges it and computes the pose again
#: (never returned by `_kernel.pose_volumes`).
GROW = 4
#: A volume the kernel read within its bound of zero, computed again in exact arithmetic
#: (`arranged`; set by the intersector, never by the kernel).
ARRANGED = 5
#: Columns of the per-pose statistics array: face pairs evaluated, crossing pairs, hand parts
#: classified vertex by vertex, parts classified whole inside, and outside.
STAT_PAIRS, STAT_CROSSING, STAT_CELLS_TOUCHED, STAT_CELLS_INSIDE, STAT_CELLS_OUTSIDE = range(5)
N_STATS = 5
#: Seed edges are tested in runs of this many consecutive edges first, one bounding sphere per
#: run (`ObjectTables.edge_runs`, `HandTables.cotree_runs`, `_seeds.near_runs`).
CHUNK, COTREE_CHUNK = 16, 8
#: The co-tree's runs are first tested in blocks of this many runs (`HandTables.cotree_blocks`).
COTREE_BLOCK = 8
#: A cell's list of faces is tested in groups of this many entries, each with its common box
#: (`CellGrid.groups`; entries ordered along a Morton curve within the cell).
LIST_GROUP = 8


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


#: Columns of a box row (`CellGrid.boxes`, ``groups``, `HandTables.boxes`): its lower corner
#: (3: x, y, z) from `BOX_MIN`, its upper corner (3) from `BOX_MAX`.
BOX_MIN, BOX_MAX = 0, 3
#: Columns of a cell's bounds row (`CellGrid.bounds`, 11): the unit axis (3) from `CELL_AXIS`,
#: the faces' extent along it from `CELL_SLAB_LOW` to `CELL_SLAB_HIGH`, their clipped common
#: box's lower corner (3) from `CELL_BOX_MIN` and upper corner (3) from `CELL_BOX_MAX`.
CELL_AXIS, CELL_SLAB_LOW, CELL_SLAB_HIGH, CELL_BOX_MIN, CELL_BOX_MAX = 0, 3, 4, 5, 8
#: Columns of `CellGrid.bounds`.
CELL_BOUNDS_COLUMNS = 11


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
    #: (listed,) int64: the faces touching each cell (closed, grown by `GRID_MARGIN`), in each
    #: cell along a Morton curve of their clipped boxes' centres (`grids.list_groups`).
    cell_faces: np.ndarray
    #: ((shape + 1).prod(),) int64: summed-volume table of the surface cells, flat, so that a
    #: box of cells' count takes 8 reads (`_cells.surface_cells_box`).
    surface_table: np.ndarray
    #: (listed, 6) float32 (`BOX_MIN`, `BOX_MAX`): the listed faces' bounding boxes, in the order
    #: of `cell_faces`, each clipped to its cell (grown by `GRID_MARGIN`, rounded outwards): a
    #: crossing in that cell lies in that box.
    boxes: np.ndarray
    #: (cells + 1,) int64: CSR start of each cell's groups in `groups`; group k of cell c holds
    #: its list's entries ``cell_start[c] + LIST_GROUP * (k - group_start[c])`` onwards (at most
    #: `LIST_GROUP`, up to the cell's end).
    group_start: np.ndarray
    #: (groups, 6) float32: the common box of each group of `boxes` (rounded outwards; columns
    #: `BOX_MIN`, `BOX_MAX`).
    groups: np.ndarray
    #: (cells, `CELL_BOUNDS_COLUMNS`) float64: per cell (columns `CELL_AXIS` ...), a unit axis (its
    #: faces' area-weighted mean normal), their extent along it (min, max; widened by
    #: `GRID_MARGIN`) and their common bounding box clipped to the cell (min xyz, max xyz): what
    #: the cell holds of the surface lies in that slab and box (`grids.cell_patches`).
    bounds: np.ndarray


#: Columns of a face's plane (`HandTables.planes`, the first `PLANE_COLUMNS` of
#: `HandTables.face_records`): the unit normal (3) from `FACE_NORMAL`, the plane's offset
#: ``n · a`` (`FACE_OFFSET`), `_search.plane_err_coef` of its conditioning times the coordinate
#: bound (`FACE_ERR_COEF`), what its rounded ``D`` can cost (`FACE_D_COST`, volume units).
FACE_NORMAL, FACE_OFFSET, FACE_ERR_COEF, FACE_D_COST = 0, 3, 4, 5
PLANE_COLUMNS = 6
#: Further columns of a face's record (`HandTables.face_records`, `FACE_RECORD_COLUMNS`):
#: corner k's coordinates (3) from ``FACE_CORNERS + 3 k``, ``D`` (3) from `FACE_D`, the link
#: the face comes from (`FACE_LINK`, as a float; `MomentTables.face_link`), then zeros.
FACE_CORNERS, FACE_D, FACE_LINK = 6, 15, 18
FACE_RECORD_COLUMNS = 24
#: Columns of a face's links (`HandTables.face_links`, int32, `FACE_LINKS_COLUMNS`): per
#: corner k, its vertex at ``FACE_VERTICES + k``, the edge k -> k + 1 at ``FACE_EDGES + k``,
#: the face across that edge at ``FACE_ACROSS + k``, whether the face owns that edge (1) or
#: not (0) at ``FACE_OWNS + k``; then zeros.
FACE_VERTICES, FACE_EDGES, FACE_ACROSS, FACE_OWNS = 0, 3, 6, 9
FACE_LINKS_COLUMNS = 16
#: Columns of a face's filter row (`HandTables.filters`, `ObjectTables.filters`, float32,
#: `FILTER_COLUMNS`): the unit normal (3) from `FILTER_NORMAL` and the plane's offset
#: (`FILTER_OFFSET`), then per corner k, from ``FILTER_SIDES + FILTER_SIDE_COLUMNS k``, the
#: unit normal (3) of its edge k -> k + 1 in the face's plane, pointing into the face, and that
#: edge's offset (at ``+ FILTER_SIDE_OFFSET``).
FILTER_NORMAL, FILTER_OFFSET, FILTER_SIDES = 0, 3, 4
FILTER_SIDE_COLUMNS, FILTER_SIDE_OFFSET = 4, 3
FILTER_COLUMNS = 16
#: Columns of a bounding sphere (`HandTables.cotree_runs`, ``cotree_blocks``,
#: `ObjectTables.edge_runs`): the centre (3) from `SPHERE_CENTRE`, the radius (`SPHERE_RADIUS`).
SPHERE_CENTRE, SPHERE_RADIUS = 0, 3
#: Columns of a part row (`HandTables.parts`): its flat cell index (`PART_CELL`) and first
#: vertex (`PART_FIRST_VERTEX`).
PART_CELL, PART_FIRST_VERTEX = 0, 1
#: Columns of a weight row (`HandTables.edge_weights`, ``part_weights``): the weight
#: (`WEIGHT`) and a bound on its error (`WEIGHT_ERR`), volume units.
WEIGHT, WEIGHT_ERR = 0, 1


class HandTables(NamedTuple):
    """The fixed hand's per-face, per-edge, per-part and per-cell terms (`prepare.hand_tables`).

    ``m`` faces, ``e`` edges, ``parts`` hand-grid cells holding a vertex, ``cells`` hand-grid
    cells, ``listed`` entries of the grid's cell lists.
    """

    #: (m, 3) float64: ``D_t = (n_t · a) n_t`` (extended precision, rounded once), length units.
    D: np.ndarray
    #: (m, 3) float64: the normals ``(b - a) × (c - a)`` as the kernels compute them (area units).
    normals: np.ndarray
    #: (m, 6) float64: each face's bounding box (columns `BOX_MIN`, `BOX_MAX`).
    boxes: np.ndarray
    #: (m, `PLANE_COLUMNS`) float64: unit normal (3), plane offset, `_search.plane_err_coef` of
    #: its conditioning (times the coordinate bound: a plane distance's error), what its rounded
    #: ``D`` can cost (absolute, volume units); columns `FACE_NORMAL` to `FACE_D_COST`.
    planes: np.ndarray
    #: (parts + 1, 2) int64: per part its flat cell index and first vertex. A part is a piece of
    #: the surface in one cell: the vertices of one hand-grid cell joined by edges inside it.
    #: The vertices being numbered part by part (cell by cell), part k holds vertices
    #: ``parts[k, 1]`` to ``parts[k + 1, 1] - 1``. The last row is (-1, number of vertices).
    #: Columns `PART_CELL`, `PART_FIRST_VERTEX`.
    parts: np.ndarray
    #: (e, 2) float64: ``W_e`` and a bound on its error (volume units; `WEIGHT`, `WEIGHT_ERR`).
    edge_weights: np.ndarray
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
    #: (k,) int64: the co-tree edges (`prepare.cotree_edges`), in runs of `COTREE_CHUNK` close
    #: together.
    cotree: np.ndarray
    #: (runs, 4) float64: bounding sphere (`SPHERE_CENTRE`, `SPHERE_RADIUS`) of each run of
    #: `cotree`.
    cotree_runs: np.ndarray
    #: (blocks, 4) float64: bounding sphere of each block of `COTREE_BLOCK` runs.
    cotree_blocks: np.ndarray
    #: (m, `FILTER_COLUMNS`) float32: per face its unit normal and plane offset, then per corner k
    #: the unit normal of its edge k -> k + 1 in the face's plane, pointing into the face, and its
    #: offset (`prepare.face_filters`): what the seeds' filters read, one cache line per face.
    filters: np.ndarray
    #: (m,) float32: `_search.plane_err_coef` of each face (rounded up).
    filter_err: np.ndarray
    #: (m, `FACE_RECORD_COLUMNS`) float64: per face, what the pair evaluation reads
    #: (`_search.trace_pairs`) in three cache lines: `planes` (6), its corners' coordinates (9),
    #: ``D`` (3), the index of the link it comes from (`MomentTables.face_link`, set with them),
    #: five zeros.
    face_records: np.ndarray
    #: (m, `FACE_LINKS_COLUMNS`) int32: per face its vertices (3), the edges of its corners k -> k
    #: + 1 (3), the faces across those edges (3), whether it owns those edges (3, 0 or 1), four
    #: zeros.
    face_links: np.ndarray


class ObjectTables(NamedTuple):
    """The object's pose-independent terms (`prepare.object_tables`), in its own frame.

    ``m`` faces, ``n`` vertices, ``e`` edges, ``runs`` runs of `CHUNK` edges.
    """

    #: (e,) int64: the edges in runs of `CHUNK` close together.
    edge_order: np.ndarray
    #: (runs, 4) float64: bounding sphere (`SPHERE_CENTRE`, `SPHERE_RADIUS`) of each run of
    #: `edge_order`.
    edge_runs: np.ndarray
    #: (m, 16) float32: the faces' planes and edge normals in the object's frame (as
    #: `HandTables.filters`).
    filters: np.ndarray
    #: (m,) float32: `_search.plane_err_coef` of each face (rounded up).
    filter_err: np.ndarray
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
    #: per pose (`_sums.edge_weight`).
    edge_weights: np.ndarray
    #: (0,) int64: empty: the object's edges are not split by part.
    edge_part: np.ndarray
    #: (0, 2) float64: empty: no part of the object is summed whole.
    part_weights: np.ndarray


#: Columns of a row of moments (`MomentTables`): ``∫ n dA`` (3) from `MOMENT_FORCE`, then
#: ``∫ x × n dA`` (3) from `MOMENT_TORQUE`; `MOMENT_COLUMNS` in all.
MOMENT_FORCE, MOMENT_TORQUE, MOMENT_COLUMNS = 0, 3, 6
#: Columns of `MomentTables.edge_moments`: the whole edge's share of ``t1``'s moments from
#: `EDGE_MOMENTS_T1`, of ``t2``'s from `EDGE_MOMENTS_T2` (`MOMENT_COLUMNS` each).
EDGE_MOMENTS_T1, EDGE_MOMENTS_T2 = 0, 6


class MomentTables(NamedTuple):
    """What the volume's derivatives read of the fixed hand (`moment_layout.moment_tables`):
    which link each face comes from, and the moments of whole edges and parts; with moments
    per face, the object's edges' too (in its own frame). Empty (no rows) when a call wants
    volumes only.

    ``m`` faces, ``e`` edges, ``parts`` as in `HandTables`, ``k`` (part, link) entries; the
    moments are ``(∫ n dA, ∫ x × n dA)`` of a face's piece (`moments`), local coordinates.
    """

    #: (m,) int64: the link (index into the hand's links) of each face.
    face_link: np.ndarray
    #: (e, 2) int64: the links of each edge's faces ``t1`` and ``t2``.
    edge_links: np.ndarray
    #: (e, 12) float64: the whole edge's share of ``t1``'s moments (6), then of ``t2``'s (6):
    #: `EDGE_MOMENTS_T1`, `EDGE_MOMENTS_T2`.
    edge_moments: np.ndarray
    #: (n,) int64: the one link of the faces around each vertex, -1 where they come from
    #: several (a seam between links); with a marker per vertex
    #: (`moment_layout.vertex_markers`), each vertex's marker row.
    vertex_link: np.ndarray
    #: (n, 6) float64: the summed moments of the whole edges from each vertex to
    #: higher-numbered ones (where `vertex_link` is not -1).
    vertex_moments: np.ndarray
    #: (parts + 1,) int64: CSR start of each part's entries in `part_link`; with a marker per
    #: vertex, (parts + n + 1,): the vertices' entries after the parts'.
    part_start: np.ndarray
    #: (k,) int64: the link of each entry.
    part_link: np.ndarray
    #: (k, 6) float64: the summed moments, on that link's faces, of the whole edges from the
    #: part's vertices to higher-numbered ones.
    part_moments: np.ndarray
    #: (1,) int64: the row from which the moments hold one row per object face (the object's
    #: boundary inside the hand, face by face, ``_object_moments.pxd``), or -1: none.
    object_from: np.ndarray
    #: (1,) int64: the rows of a pose's `MomentRows`: the moments' ``L`` (links, or faces of
    #: both meshes), then with `part_from` one marker per part (and per hand vertex,
    #: `moment_layout.vertex_markers`); 0: none (volumes only).
    row_count: np.ndarray
    #: (1,) int64: the row of part 0's marker, or -1: none. With markers a part classified
    #: whole and inside lists its marker (row ``part_from + part``) instead of adding its
    #: entries (`part_moments`) to their rows: what they give is summed once, ahead
    #: (`face_gradients.vertex_tables`).
    part_from: np.ndarray
    #: (object e, 2) int64: the rows of each object edge's faces ``t1`` and ``t2`` (empty
    #: without `object_from`).
    object_edge_links: np.ndarray
    #: (object e, 12) float64: each object edge's whole share of ``t1``'s and ``t2``'s moments
    #: (as `edge_moments`), in the object's frame (local coordinates, unmoved).
    object_edge_moments: np.ndarray
    #: (object m, 3) float64: the object faces' unit normals in its frame (0: no area).
    object_normals: np.ndarray


class MomentRows(NamedTuple):
    """One pose's moments as the kernel adds them up (`_pose.pose_moments`), with the rows
    the pose touched: only those are read out and cleared, not all ``L``."""

    #: (L, `MOMENT_COLUMNS`) float64: the moments; zero outside the rows touched.
    values: np.ndarray
    #: (L,) int64: the pose that last touched each row (-1: none).
    stamp: np.ndarray
    #: (L + 1,) int64: the rows this pose touched, in the order first touched (one spare
    #: entry: `_moment_sums.touch` writes before it knows).
    touched: np.ndarray
    #: (2,) int64: how many rows this pose touched, and the pose (what `stamp` holds).
    state: np.ndarray


class Crossings(NamedTuple):
    """The edge crossings one mesh's faces record in a pose (``capacity`` long; the count is
    in `Workspace.nrec`)."""

    #: (capacity,) int64: the crossed edge.
    edge: np.ndarray
    #: (capacity,) float64: the crossing's parameter along the edge ``u → v``, in [0, 1].
    lam: np.ndarray
    #: (capacity,) float64: a bound on that parameter's error.
    err: np.ndarray


#: Columns of a crossing point (`Workspace.points`, 7): its coordinates (3) from `POINT_XYZ`,
#: their error bound (`POINT_ERR`), 1.0 where it starts the common segment, else 0.0
#: (`POINT_STARTS`), the mesh of the crossed edge, 0 hand or 1 object (`POINT_MESH`), and the
#: face corner k of that edge k -> k + 1 (`POINT_CORNER`).
POINT_XYZ, POINT_ERR, POINT_STARTS, POINT_MESH, POINT_CORNER = 0, 3, 4, 5, 6
POINT_COLUMNS = 7
#: Column of `Workspace.dists` holding its row's error bound (the corners' distances come
#: first, one per corner).
DIST_ERR = 3
#: Columns of a traced segment (`Workspace.segments`, `SEGMENT_COLUMNS`): its hand face
#: (`SEGMENT_FACE`), its start p (3) from `SEGMENT_P`, its end q (3) from `SEGMENT_Q`, the hand
#: face's unit normal (3) from `SEGMENT_NORMAL` and link (`SEGMENT_LINK`), and the object face
#: (`SEGMENT_OBJECT_FACE`).
SEGMENT_FACE, SEGMENT_P, SEGMENT_Q, SEGMENT_NORMAL, SEGMENT_LINK = 0, 1, 4, 7, 10
SEGMENT_OBJECT_FACE = 11
SEGMENT_COLUMNS = 12


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
    #: (size,) int64: the face pairs evaluated in this pose, an open-addressing hash table
    #: (`_search.trace_pairs`) of keys ``t * (object m) + s``; ``size`` is a power of two.
    pair_keys: np.ndarray
    #: (size,) int32: per slot twice the token of the call that filled it, plus 1 where that
    #: pair crosses (slots of other calls are empty).
    pair_tags: np.ndarray
    #: (capacity, 2) int64: candidate pairs (hand face, object face) from the seeds.
    seeds: np.ndarray
    #: (2, `POINT_COLUMNS`) float64: crossing points of a pair (columns `POINT_XYZ` ...):
    #: coordinates, error bound, whether it starts the common segment, the mesh of the crossed edge
    #: (0 hand, 1 object) and its face corner.
    points: np.ndarray
    #: (2, 3) int64: certain signs of each face's corners against the other's plane (0: none).
    signs: np.ndarray
    #: (2, 4) float64: those corners' signed distances and the row's error bound (`DIST_ERR`).
    dists: np.ndarray
    #: (hand parts,) bool: the hand parts one of whose own edges is crossed in this pose.
    part_crossed: np.ndarray
    #: (longest cell list of either grid,) int64: the listed faces of a cell that pass the box
    #: filters.
    survivors: np.ndarray
    #: (pair table size, `SEGMENT_COLUMNS`) float64, or (0, `SEGMENT_COLUMNS`) for volumes only:
    #: per crossing pair of the pose, in the order traced, its hand face, its segment's ends p, q
    #: (directed along ``n_t × n_s``), the hand face's unit normal and link, and the object face:
    #: what the volume's derivatives integrate over (``_moment_sums.pxd``,
    #: ``_object_moments.pxd``).
    segments: np.ndarray


class PoseScratch(NamedTuple):
    """Per-pose arrays of `_kernel.pose_volumes`, reused from pose to pose."""

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
    #: (r,) int64: the records of edges crossed more than once (`_sums.crossed_sum`); as long
    #: as the crossing records (`Workspace`), which grow up to the capacity.
    multi: np.ndarray
    #: (3,) float64: a hand vertex in the object's frame, for a point test.
    point: np.ndarray
    #: (hand m,) int64: faces already tested by a point test against the hand.
    hand_stamp: np.ndarray
    #: (object m,) int64: faces already tested by a point test against the object.
    object_stamp: np.ndarray
    #: (object runs,) bool: the runs of object edges that may come near the hand's surface.
    near: np.ndarray
    #: (cotree runs,) bool: the runs of hand co-tree edges that may come near the object's.
    near_cotree: np.ndarray
    #: (cotree blocks,) bool: the blocks of those runs that may come near it.
    near_block: np.ndarray
    #: (0,) bool: empty (no parent level for `_seeds.near_runs`).
    none: np.ndarray
    #: The search's and pair tests' scratch.
    work: Workspace
