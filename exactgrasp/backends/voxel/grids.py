"""Inside/outside grids of closed triangle shells (the voxel estimator's grids).

A grid is a regular lattice of nodes ``origin + spacing * (i, j, k)``. A node is inside when the
winding number of the shells around it is at least 1, so shells that overlap each other (the
separate links of a hand) give the inside of their union, and the several bodies of an object
need no merging first.

The winding number is counted column by column: a ray leaves every node upwards (+z) and each
triangle it crosses adds the sign of that triangle's normal z component. Rays that pass exactly
through an edge or a vertex are resolved by a symbolic perturbation of the ray (as if it were
moved by an infinitesimal ``(eps, eps**2)`` in x and y), computed with the same floating-point
operations for both triangles that share an edge, so such a ray is counted by exactly one of
them and never twice or not at all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exactgrasp.backends.defaults import VOXEL_GRID_RULE, VOXEL_GRID_RULES
from exactgrasp.errors import BackendError
from exactgrasp.geometry.winding import winding_inside_lattice

# Keeps floor(resolution * side / longest) from losing a voxel to rounding when the ratio is
# an integer in exact arithmetic (a 2:1 box at resolution 50 gets 25 voxels, not 24).
_RATIO_TOLERANCE = 1e-9


@dataclass(frozen=True)
class Grid:
    """A regular lattice of nodes with one value per node.

    Attributes
    ----------
    values : numpy.ndarray, shape (nx, ny, nz), uint8
        1 where the node is inside the shells, 0 elsewhere.
    origin : numpy.ndarray, shape (3,), float64
        Position of node (0, 0, 0), in the units of the meshes.
    spacing : float
        Distance between neighbouring nodes along every axis (cubic voxels), same units.
    """

    values: np.ndarray
    origin: np.ndarray
    spacing: float

    @property
    def shape(self) -> tuple[int, int, int]:
        """Number of nodes along x, y and z."""
        return tuple(int(n) for n in self.values.shape)

    def node_positions(self, mask: np.ndarray | None = None) -> np.ndarray:
        """Positions of the nodes (all, or those where `mask` is true), shape (n, 3)."""
        index = np.argwhere(np.ones(self.shape, bool) if mask is None else mask)
        return self.origin + self.spacing * index.astype(np.float64)


def stack_triangles(shells: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """Gather the triangles of several shells into one array.

    Parameters
    ----------
    shells : list of (V, F)
        Closed, outward-oriented shells: V (n, 3) float vertices, F (m, 3) integer faces.

    Returns
    -------
    numpy.ndarray, shape (total faces, 3, 3), float64
        Corner coordinates of every triangle.
    """
    if len(shells) == 0:
        raise BackendError("no shells were given; pass at least one (vertices, faces) pair.")
    parts = []
    for number, (vertices, faces) in enumerate(shells):
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
            raise BackendError(
                f"shell {number}: expected vertices (n, 3) and faces (m, 3), got "
                f"{vertices.shape} and {faces.shape}."
            )
        if len(faces) == 0 or not np.all(np.isfinite(vertices)):
            raise BackendError(f"shell {number} has no faces or non-finite vertices.")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise BackendError(f"shell {number} has face indices outside its vertex array.")
        parts.append(vertices[faces])
    return np.concatenate(parts, axis=0)


#: How many cubic voxels a shorter side gets: "floor" (the authors' code) or "round".
GRID_RULES = VOXEL_GRID_RULES


def grid_layout(
    lower: np.ndarray, upper: np.ndarray, resolution: int, pad: int, rule: str = VOXEL_GRID_RULE
) -> tuple[np.ndarray, float, tuple[int, int, int]]:
    """Place voxel centres over a bounding box.

    The longest side gets `resolution` voxels of size ``longest / resolution``. With
    ``rule="floor"`` (the authors' code) another side gets
    ``max(1, floor(resolution * side / longest))`` voxels of the same size, centred on the box,
    so up to one voxel of that side is left out (up to half at either end): a flat object
    loses interior volume (the cereal box: 12 %). With ``rule="round"`` it gets the nearest
    whole number of voxels, ``floor(resolution * side / longest + 1/2)``, centred, so a box's
    interior is off by at most half a voxel per side. `pad` more nodes are added at each end
    of every axis.

    Parameters
    ----------
    lower, upper : numpy.ndarray, shape (3,)
        Corners of the bounding box.
    resolution : int
        Voxels along the longest side.
    pad : int
        Extra nodes on each side (0 or more).
    rule : {"floor", "round"}
        Voxel count of the shorter sides, see above.

    Returns
    -------
    origin : numpy.ndarray, shape (3,)
        Position of node (0, 0, 0).
    spacing : float
        Voxel size.
    shape : tuple of int
        Nodes along each axis, padding included.
    """
    sides = np.asarray(upper, np.float64) - np.asarray(lower, np.float64)
    longest = float(sides.max())
    if not longest > 0:
        raise BackendError("the shells have an empty bounding box; pass solids with volume.")
    spacing = longest / resolution
    ratio = resolution * sides / longest
    if rule == "floor":
        counts = np.floor(ratio + _RATIO_TOLERANCE)
    elif rule == "round":
        counts = np.floor(ratio + 0.5)
    else:
        raise BackendError(f"grid rule {rule!r} is unknown; use one of {GRID_RULES}.")
    counts = np.maximum(1, counts).astype(int)
    centre = 0.5 * (np.asarray(lower, np.float64) + np.asarray(upper, np.float64))
    origin = centre - spacing * (0.5 * (counts - 1) + pad)
    shape = tuple(int(n) + 2 * pad for n in counts)
    return origin, spacing, shape


def occupancy_grid(
    shells: list[tuple[np.ndarray, np.ndarray]],
    resolution: int,
    pad: int = 1,
    rule: str = VOXEL_GRID_RULE,
) -> Grid:
    """Inside/outside grid of the union of closed shells.

    Parameters
    ----------
    shells : list of (V, F)
        Closed, outward-oriented shells (they may overlap); V (n, 3), F (m, 3).
    resolution : int
        Voxels along the longest side of the shells' bounding box (see `grid_layout`).
    pad : int
        Layers of outside nodes added around the box (1 makes interpolation at the border
        well defined).
    rule : {"floor", "round"}
        Voxel count of the shorter sides (see `grid_layout`).

    Returns
    -------
    Grid
        Node values 1 inside the union, 0 outside.
    """
    triangles = stack_triangles(shells)
    flat = triangles.reshape(-1, 3)
    # Column by column: numpy reduces a long (n, 3) array along axis 0 several times slower.
    lower = np.array([flat[:, axis].min() for axis in range(3)])
    upper = np.array([flat[:, axis].max() for axis in range(3)])
    origin, spacing, shape = grid_layout(lower, upper, resolution, pad, rule)
    # Node (i, j, k) sits at integer coordinates in index space, so column positions are exact.
    local = (triangles - origin) / spacing
    values = winding_inside_lattice(local, shape[0], shape[1], shape[2])
    return Grid(values=values, origin=origin, spacing=spacing)


@dataclass(frozen=True)
class HandOccupancy:
    """A hand's occupancy grid with the tables that let whole blocks of points be decided.

    Attributes
    ----------
    grid : Grid
        Padded inside/outside grid of the union of the hand's links.
    cell_codes : numpy.ndarray, shape (nx - 1, ny - 1, nz - 1), uint8
        For each grid cell, its 8 corner values as bits (bit ``dx + 2 dy + 4 dz`` is corner
        ``(i + dx, j + dy, k + dz)``), so interpolation reads one byte instead of eight.
    tiles : numpy.ndarray, shape (tx + 1, ty + 1, tz + 1), uint64
        Two summed tables of tiles (``2**tile_shift`` cells per axis) in one: the low 32 bits
        of ``tiles[i, j, k]`` count the tiles with indices below ``(i, j, k)`` that hold a
        cell with an inside corner, the high 32 bits those whose cells all have 8 inside
        corners (code 255). One read gives both.
    tile_shift : int
        Cell ``i`` lies in tile ``i >> tile_shift`` along each axis.
    """

    grid: Grid
    cell_codes: np.ndarray
    tiles: np.ndarray
    tile_shift: int


# Tiles per axis at most: with finer hand grids several cells share a tile, which keeps the
# two tables small; the block test stays conservative either way.
_TABLE_TILES = 128


def hand_occupancy(
    links: list[tuple[np.ndarray, np.ndarray]], resolution: int, rule: str = VOXEL_GRID_RULE
) -> HandOccupancy:
    """Occupancy grid of the union of a hand's links, padded by one layer of outside nodes.

    Parameters
    ----------
    links : list of (V, F)
        Closed, outward-oriented link shells, V (n, 3) float, F (m, 3) int; they may overlap.
    resolution : int
        Voxels along the longest side of the links' bounding box.
    rule : {"floor", "round"}
        Voxel count of the shorter sides (see `grid_layout`).

    Returns
    -------
    HandOccupancy
    """
    grid = occupancy_grid(links, resolution, pad=1, rule=rule)
    codes = cell_codes(grid.values)
    shift = 0
    while -(-max(codes.shape) >> shift) > _TABLE_TILES:
        shift += 1
    occupied = tile_any(codes != 0, 1 << shift).astype(np.uint64)
    full = ~tile_any(codes != 255, 1 << shift)
    # Summing the packed counts sums both halves at once: the low half never carries over.
    packed = occupied + (full.astype(np.uint64) << np.uint64(32))
    return HandOccupancy(grid=grid, cell_codes=codes, tiles=summed_table(packed), tile_shift=shift)


def tile_any(mask: np.ndarray, tile: int) -> np.ndarray:
    """Whether each tile of `tile` cells per axis holds a true cell; cells past the end count true.

    Parameters
    ----------
    mask : numpy.ndarray, shape (nx, ny, nz), bool
    tile : int

    Returns
    -------
    numpy.ndarray, shape (ceil(nx / tile), ceil(ny / tile), ceil(nz / tile)), bool
    """
    if tile == 1:
        return mask
    tiles = [-(-n // tile) for n in mask.shape]
    padded = np.ones([t * tile for t in tiles], bool)
    padded[: mask.shape[0], : mask.shape[1], : mask.shape[2]] = mask
    return padded.reshape(tiles[0], tile, tiles[1], tile, tiles[2], tile).any((1, 3, 5))


def summed_table(values: np.ndarray) -> np.ndarray:
    """Summed-volume table of a 3-D array: ``table[i, j, k] = values[:i, :j, :k].sum()``.

    Parameters
    ----------
    values : numpy.ndarray, shape (nx, ny, nz), bool or unsigned integers

    Returns
    -------
    numpy.ndarray, shape (nx + 1, ny + 1, nz + 1), uint64
    """
    table = np.zeros([n + 1 for n in values.shape], np.uint64)
    table[1:, 1:, 1:] = values
    for axis in range(3):
        np.cumsum(table, axis=axis, out=table)
    return table


def cell_codes(values: np.ndarray) -> np.ndarray:
    """Pack the 8 corner values of every cell of a 0/1 grid into one byte (see HandOccupancy)."""
    nx, ny, nz = values.shape
    codes = np.zeros((nx - 1, ny - 1, nz - 1), np.uint8)
    for bit in range(8):
        dx, dy, dz = bit & 1, (bit >> 1) & 1, (bit >> 2) & 1
        corner = values[dx : nx - 1 + dx, dy : ny - 1 + dy, dz : nz - 1 + dz]
        codes |= (corner != 0).astype(np.uint8) << bit
    return codes
