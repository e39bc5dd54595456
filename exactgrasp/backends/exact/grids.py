"""Cell grids of the exact backend, built once per grasp: each mesh's cell edge (`grid_cell`)
and `tables.CellGrid`, the hand's vertices numbered cell by cell, and the hand grid's per-cell
search tables.

See "Method, once per grasp" in ``docs/exact-backend.md``.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends import defaults
from exactgrasp.backends.exact._entries import raster_triangles
from exactgrasp.backends.exact.tables import (
    BOX_MAX,
    BOX_MIN,
    CELL_AXIS,
    CELL_BOUNDS_COLUMNS,
    CELL_BOX_MAX,
    CELL_BOX_MIN,
    CELL_SLAB_HIGH,
    CELL_SLAB_LOW,
    LIST_GROUP,
    CellGrid,
)
from exactgrasp.backends.exact.tolerances import GRID_MARGIN, LENGTH_FLOOR, NORMAL_FLOOR
from exactgrasp.errors import BackendError
from exactgrasp.geometry.winding import winding_number

#: Largest grid a cell option may ask for (cells per grid): about 1.6 GB of tables.
MAX_GRID_CELLS = 200_000_000


def grid_cell(vertices: np.ndarray, cell: float | None, key: str) -> float:
    """The grid cell edge for a mesh: ``cell`` if given (checked against `MAX_GRID_CELLS`),
    else 1/48 of the mesh's largest extent."""
    extent = np.ptp(vertices, axis=0)
    if cell is None:
        return float(extent.max() / defaults.EXACT_CELLS_PER_EXTENT)
    cells = float(np.prod(np.ceil(extent / cell) + 3))
    if cells > MAX_GRID_CELLS:
        raise BackendError(
            f"{key}={cell:g} lays {cells:.3g} grid cells over a mesh of extent "
            f"{extent.max():.4g}, more than {MAX_GRID_CELLS:,}; use a {key} of at least "
            f"{extent.max() / (MAX_GRID_CELLS ** (1 / 3) - 3):.3g}, or None for the default."
        )
    return float(cell)


def grid_frame(V: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Origin (3,) and cell counts (3,) of the grid `build_grid` lays over vertices V (n, 3)
    with cubic cells of edge ``cell``: one cell of padding on every side."""
    lo = V.min(0) - cell
    return lo, np.ceil((V.max(0) + cell - lo) / cell).astype(np.int64) + 1


def vertex_cells(V: np.ndarray, cell: float) -> np.ndarray:
    """Flat index of the `build_grid` cell holding each vertex of V (n, 3): shape (n,), int64.
    (`_cells.cell_index` multiplies by 1 / cell instead, so a vertex within rounding of a cell
    boundary may get the neighbouring cell there; both cells, grown by the grid's margin, hold
    it.)"""
    lo, n = grid_frame(V, cell)
    ijk = np.clip(np.floor((V - lo) / cell).astype(np.int64), 0, n - 1)
    return (ijk[:, 0] * n[1] + ijk[:, 1]) * n[2] + ijk[:, 2]


def morton_codes(q: np.ndarray) -> np.ndarray:
    """Morton (Z-order) codes of integer points q (k, 3), 10 bits per axis: shape (k,), int64."""
    code = np.zeros(len(q), np.int64)
    for bit in range(10):
        for ax in range(3):
            code |= ((q[:, ax] >> bit) & 1) << (3 * bit + ax)
    return code


def morton_order(X: np.ndarray) -> np.ndarray:
    """An order of points X (k, 3) along a Morton (Z-order) curve over their bounds, 10 bits per
    axis: consecutive points are mostly close together. Shape (k,), int64."""
    if len(X) == 0:
        return np.zeros(0, np.int64)
    lo, hi = X.min(0), X.max(0)
    q = np.floor((X - lo) / np.maximum(hi - lo, LENGTH_FLOOR) * 1023).astype(np.int64)
    return np.argsort(morton_codes(q), kind="stable").astype(np.int64)


def cell_order(V: np.ndarray, F: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """The same mesh with its vertices renumbered in the order of their `build_grid` cells
    (stable), so that each cell's vertices are consecutive, and its faces in the order of their
    centres along a Morton curve, so that faces close together have close indices (the
    kernels' reads of per-face tables then hit the same cache lines): (V (n, 3), F (m, 3))."""
    order = np.argsort(vertex_cells(V, cell), kind="stable")
    rank = np.empty(len(V), np.int64)
    rank[order] = np.arange(len(V))
    F = rank[F][morton_order(V[F].mean(1))]
    return np.ascontiguousarray(V[order]), np.ascontiguousarray(F)


def build_grid(V: np.ndarray, F: np.ndarray, cell: float) -> CellGrid:
    """A cubic-cell grid over a closed mesh, one cell of padding on every side.

    Parameters
    ----------
    V, F : numpy.ndarray
        The mesh, shapes (n, 3) and (m, 3).
    cell : float
        Edge length of a cell, in the mesh's units.

    Returns
    -------
    CellGrid
        Cells touched by a face (closed, grown by `GRID_MARGIN` of a cell) list it; the others
        are labelled inside or outside by flood fill plus one winding number per region.
    """
    from scipy import ndimage

    lo, n = grid_frame(V, cell)
    margin = GRID_MARGIN * cell
    cells, tris = raster_triangles(V, F, lo, float(cell), n, margin)
    # Sorted by cell here (stable), by numpy: the kernel emits the pairs in triangle order.
    order = np.argsort(cells, kind="stable")
    cells, tris = cells[order], tris[order]
    ncell = int(np.prod(n))
    cell_start = np.zeros(ncell + 1, np.int64)
    np.cumsum(np.bincount(cells, minlength=ncell), out=cell_start[1:])
    surface = np.zeros(ncell, bool)
    surface[cells] = True
    labels, nlab = ndimage.label(~surface.reshape(tuple(n)))
    status = np.full(ncell, -1, np.int64)
    flat = labels.reshape(-1)
    outside = set(
        np.unique(
            np.concatenate(
                [
                    labels[0].ravel(),
                    labels[-1].ravel(),
                    labels[:, 0].ravel(),
                    labels[:, -1].ravel(),
                    labels[:, :, 0].ravel(),
                    labels[:, :, -1].ravel(),
                ]
            )
        ).tolist()
    ) - {0}
    for lab in range(1, nlab + 1):
        idx = np.flatnonzero(flat == lab)
        if lab in outside:
            inside = 0
        else:
            i, j, k = np.unravel_index(idx[0], tuple(n))
            centre = lo + (np.array([i, j, k]) + 0.5) * cell
            inside = round(winding_number(centre, V, F)) & 1
        status[idx] = inside
    # Summed-volume table of the surface cells: how many a box of cells holds, in 8 reads.
    table = np.zeros(tuple(n + 1), np.int64)
    table[1:, 1:, 1:] = surface.reshape(tuple(n)).cumsum(0).cumsum(1).cumsum(2)
    grid = CellGrid(
        lo, float(cell), n, status, cell_start, tris, table.reshape(-1),
        np.empty((0, 6), np.float32), np.zeros(ncell + 1, np.int64),
        np.empty((0, 6), np.float32), np.empty((0, 11)),
    )  # fmt: skip
    T = V[F]
    N = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    boxes = np.hstack([T.min(1), T.max(1)])
    grid = list_groups(grid, cell_boxes(grid, boxes))
    return grid._replace(bounds=cell_patches(grid, V, F, N, boxes))


def list_groups(grid: CellGrid, clipped: np.ndarray) -> CellGrid:
    """The grid with each cell's list in the order of its boxes' centres along a Morton curve
    within the cell, cut into groups of `LIST_GROUP` consecutive entries with their common box
    (`tables.CellGrid.group_start`, ``groups``), and the clipped boxes ``clipped`` (listed, 6;
    `cell_boxes`) in single precision, rounded outwards (``boxes``)."""
    cs, h = grid.cell_start, grid.cell
    counts = np.diff(cs)
    ncell = len(counts)
    cell_of = np.repeat(np.arange(ncell), counts)
    local = ((clipped[:, :3] + clipped[:, 3:]) / 2 - cell_corners(grid)[cell_of]) / h
    q = np.clip(np.floor(local * 1024), 0, 1023).astype(np.int64)
    order = np.lexsort((morton_codes(q), cell_of))
    clipped = clipped[order]
    ngroups = -(-counts // LIST_GROUP)
    group_start = np.zeros(ncell + 1, np.int64)
    np.cumsum(ngroups, out=group_start[1:])
    # Each group's first entry: its cell's start plus LIST_GROUP per group before it.
    gcell = np.repeat(np.arange(ncell), ngroups)
    first = cs[gcell] + LIST_GROUP * (np.arange(len(gcell)) - group_start[gcell])
    groups = np.empty((len(first), 6))
    if len(first):
        groups[:, :3] = np.minimum.reduceat(clipped[:, :3], first, axis=0)
        groups[:, 3:] = np.maximum.reduceat(clipped[:, 3:], first, axis=0)
    return grid._replace(
        cell_faces=np.ascontiguousarray(grid.cell_faces[order]),
        boxes=outward_f32(clipped),
        group_start=group_start,
        groups=outward_f32(groups),
    )


def outward_f32(boxes: np.ndarray) -> np.ndarray:
    """Boxes (k, 6: min xyz, max xyz) in single precision, each bound rounded outwards, so that
    every box still holds the one it came from."""
    out = boxes.astype(np.float32)
    low, high = out[:, :3], out[:, 3:]
    out[:, :3] = np.where(low > boxes[:, :3], np.nextafter(low, np.float32(-np.inf)), low)
    out[:, 3:] = np.where(high < boxes[:, 3:], np.nextafter(high, np.float32(np.inf)), high)
    return np.ascontiguousarray(out)


def part_order(V: np.ndarray, F: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """The hand's parts: in each `build_grid` cell, the pieces of surface its vertices form
    when joined by the edges with both ends in that cell.

    Returns (order (n,), part (n,)): the vertices renumbered so that each part's vertices are
    consecutive, parts in the order of their cells (`cell_order` keeps its cell by cell
    order), and each renumbered vertex's part. A part is connected through its own edges, so
    that where none of them is crossed, all its vertices share one status."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    cells = vertex_cells(V, cell)
    u = F.reshape(-1)
    v = F[:, [1, 2, 0]].reshape(-1)
    same = cells[u] == cells[v]
    graph = coo_matrix((np.ones(same.sum()), (u[same], v[same])), shape=(len(V), len(V)))
    _, label = connected_components(graph, directed=False)
    order = np.lexsort((np.arange(len(V)), label, cells))
    key = cells[order] * (len(V) + 1) + label[order]
    part = np.concatenate([[0], np.cumsum(key[1:] != key[:-1])]).astype(np.int64)
    return order.astype(np.int64), part


def cell_reps(V: np.ndarray, cell: float, part: np.ndarray) -> np.ndarray:
    """The hand's parts (`part_order`; ``part`` (n,) each vertex's, nondecreasing), their
    cells and first vertices: `tables.HandTables.parts`, shape (parts + 1, 2)."""
    first = np.flatnonzero(np.diff(part, prepend=-1))
    cells = vertex_cells(V, cell)
    if np.any(np.diff(cells) < 0) or len(first) != part[-1] + 1:
        raise AssertionError("hand vertices are not numbered part by part")
    return np.ascontiguousarray(
        np.stack([np.append(cells[first], -1), np.append(first, len(V))], axis=1).astype(np.int64)
    )


def cell_corners(grid: CellGrid) -> np.ndarray:
    """Lower corner of every grid cell, shape (cells, 3)."""
    lo, h, n = grid.corner, grid.cell, grid.shape
    return lo + np.stack(np.unravel_index(np.arange(np.prod(n)), tuple(n)), axis=1) * h


def clip_to_cells(boxes: np.ndarray, corner: np.ndarray, h: float) -> None:
    """Clip boxes (k, 6: min xyz, max xyz) in place to the cells of edge h whose lower
    corners are ``corner`` (k, 3), grown by `GRID_MARGIN` of a cell."""
    boxes[:, :3] = np.maximum(boxes[:, :3], corner - GRID_MARGIN * h)
    boxes[:, 3:] = np.minimum(boxes[:, 3:], corner + h + GRID_MARGIN * h)


def cell_boxes(grid: CellGrid, ABB: np.ndarray) -> np.ndarray:
    """The faces' bounding boxes ``ABB`` (m, 6) in the order of the grid's cell lists, each
    clipped to its cell grown by `GRID_MARGIN`: `tables.CellGrid.boxes` (only the grid's frame
    and lists are read)."""
    cs, ct = grid.cell_start, grid.cell_faces
    out = np.ascontiguousarray(ABB[ct])
    clip_to_cells(out, np.repeat(cell_corners(grid), np.diff(cs), axis=0), grid.cell)
    return out


def _per_cell(values: np.ndarray, cs: np.ndarray, op, empty: float) -> np.ndarray:
    """``op.reduceat`` of the rows of values (listed, ...) over each cell's range of its list
    (``cs``: `tables.CellGrid.cell_start`), ``empty`` where a cell lists nothing."""
    ncell = len(cs) - 1
    out = np.full((ncell, *values.shape[1:]), empty)
    full = np.flatnonzero(cs[1:] > cs[:-1])
    if len(full):
        out[full] = op.reduceat(values, cs[full], axis=0)
    return out


def cell_patches(grid: CellGrid, AV, AF, AN, ABB) -> np.ndarray:
    """Per grid cell, bounds of the faces it lists: `tables.CellGrid.bounds`, shape (cells,
    `CELL_BOUNDS_COLUMNS`), from the mesh (AV, AF), its normals AN and face boxes ABB (only the
    grid's frame and lists are read)."""
    h, cs, ct = grid.cell, grid.cell_start, grid.cell_faces
    ncell = len(cs) - 1
    cell = np.repeat(np.arange(ncell), np.diff(cs))
    axis = _per_cell(AN[ct], cs, np.add, 0.0)
    norm = np.linalg.norm(axis, axis=1)
    good = norm > NORMAL_FLOOR * max(1.0, norm.max())
    axis[good] /= norm[good, None]
    axis[~good] = (1.0, 0.0, 0.0)
    proj = np.einsum("qkj,qj->qk", AV[AF[ct]], axis[cell])
    out = np.zeros((ncell, CELL_BOUNDS_COLUMNS))
    out[:, CELL_AXIS : CELL_AXIS + 3] = axis
    out[:, CELL_SLAB_LOW] = _per_cell(proj.min(1), cs, np.minimum, np.inf) - GRID_MARGIN * h
    out[:, CELL_SLAB_HIGH] = _per_cell(proj.max(1), cs, np.maximum, -np.inf) + GRID_MARGIN * h
    low, high = ABB[ct, BOX_MIN : BOX_MIN + 3], ABB[ct, BOX_MAX : BOX_MAX + 3]
    out[:, CELL_BOX_MIN : CELL_BOX_MIN + 3] = _per_cell(low, cs, np.minimum, np.inf)
    out[:, CELL_BOX_MAX : CELL_BOX_MAX + 3] = _per_cell(high, cs, np.maximum, -np.inf)
    # Clipped to the cell (grown by the kernel's margin): the part of the faces that the
    # cell holds lies in this box, which the search tests each object face against.
    clip_to_cells(out[:, CELL_BOX_MIN : CELL_BOX_MAX + 3], cell_corners(grid), h)
    return out
