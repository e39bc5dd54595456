"""Cell-grid kernels of the exact backend (numba): which cell holds a point, which cells a
triangle touches, how many surface cells a box of cells holds.

The grids themselves (`tables.CellGrid`) are built by `grids.build_grid`; these kernels take
their fields one by one, so that hot loops pass scalars and arrays, never the tuple.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.predicates import tri_box
from exactgrasp.compiling import inner, kernel


@inner(nogil=True, error_model="numpy")
def cell_index(x, y, z, l0, l1, l2, ih, n0, n1, n2):
    """Flat index of the grid cell holding (x, y, z), or -1 outside the grid (lower corner
    (l0, l1, l2), inverse cell edge ih, n* cells per axis). Scalars only, so that per-vertex
    loops can inline it without reference counting the grid's arrays. A point within rounding
    of a cell's boundary may get either cell: a cell of known status lies at least the
    rasterisation margin away from the surface, so either answer is right."""
    i = int(np.floor((x - l0) * ih))
    j = int(np.floor((y - l1) * ih))
    k = int(np.floor((z - l2) * ih))
    if i < 0 or j < 0 or k < 0 or i >= n0 or j >= n1 or k >= n2:
        return -1
    return (i * n1 + j) * n2 + k


@inner(nogil=True, error_model="numpy")
def point_status(x, lo, h, n, status):
    """Inside (1) / outside (0) from the grid's cell statuses; -1 when x is in a surface cell.

    ``lo, h, n, status`` are the grid's first four fields (`tables.CellGrid`)."""
    c = cell_index(x[0], x[1], x[2], lo[0], lo[1], lo[2], 1.0 / h, n[0], n[1], n[2])
    return 0 if c < 0 else status[c]


@inner(nogil=True, error_model="numpy")
def tri_cell_range(V, F, f, lo, h, n, margin, rng):
    """Grid-index range of triangle f's bounding box (clipped); False when outside the grid.
    (Products with 1 / h, not quotients: the margin dwarfs the difference in rounding.)"""
    ih = 1.0 / h
    for ax in range(3):
        x0 = min(V[F[f, 0], ax], V[F[f, 1], ax], V[F[f, 2], ax]) - margin
        x1 = max(V[F[f, 0], ax], V[F[f, 1], ax], V[F[f, 2], ax]) + margin
        i0 = int(np.floor((x0 - lo[ax]) * ih))
        i1 = int(np.floor((x1 - lo[ax]) * ih))
        if i1 < 0 or i0 >= n[ax]:
            return False
        rng[ax, 0] = max(i0, 0)
        rng[ax, 1] = min(i1, n[ax] - 1)
    return True


@kernel(nogil=True, error_model="numpy")
def raster_triangles(V, F, lo, h, n, margin):
    """(cell, triangle) pairs of every triangle touching a grid cell (closed, grown by margin).

    Returns flat cell indices and triangle indices, in triangle order (the caller sorts).
    """
    cells = []
    tris = []
    rng = np.empty((3, 2), np.int64)
    hh = 0.5 * h + margin
    for f in range(F.shape[0]):
        if not tri_cell_range(V, F, f, lo, h, n, margin, rng):
            continue
        for i in range(rng[0, 0], rng[0, 1] + 1):
            for j in range(rng[1, 0], rng[1, 1] + 1):
                for k in range(rng[2, 0], rng[2, 1] + 1):
                    cx = lo[0] + (i + 0.5) * h
                    cy = lo[1] + (j + 0.5) * h
                    cz = lo[2] + (k + 0.5) * h
                    if tri_box(cx, cy, cz, hh, V[F[f, 0]], V[F[f, 1]], V[F[f, 2]]):
                        cells.append((i * n[1] + j) * n[2] + k)
                        tris.append(f)
    return np.array(cells, np.int64), np.array(tris, np.int64)


@inner(nogil=True, error_model="numpy")
def surface_cells_in(table, n, rng):
    """Number of surface cells in the box of cells ``rng`` (3, 2) (inclusive index ranges),
    from the grid's summed-volume table (`tables.CellGrid.surface_table`)."""
    s1 = n[2] + 1
    s0 = (n[1] + 1) * s1
    a0, a1 = rng[0, 0] * s0, (rng[0, 1] + 1) * s0
    b0, b1 = rng[1, 0] * s1, (rng[1, 1] + 1) * s1
    c0, c1 = rng[2, 0], rng[2, 1] + 1
    return (
        table[a1 + b1 + c1]
        - table[a0 + b1 + c1]
        - table[a1 + b0 + c1]
        - table[a1 + b1 + c0]
        + table[a0 + b0 + c1]
        + table[a0 + b1 + c0]
        + table[a1 + b0 + c0]
        - table[a0 + b0 + c0]
    )
