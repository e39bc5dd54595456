"""Blue-noise (Poisson-disk-like) sample points on triangle surfaces.

The voxel estimator adds points on the object's surface so that thin parts, which may hold no
interior voxel centre, still register (the paper used MeshLab's Poisson-disk resampling). Here
candidates are drawn uniformly by area from a seeded generator and accepted greedily, in the
order drawn, when no accepted point lies closer than the spacing: a dart-throwing Poisson-disk
set that is deterministic for a fixed seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from exactgrasp.errors import BackendError

#: Median number of samples in the authors' published ``*_P.ply`` files (14 objects).
AUTHORS_SAMPLE_COUNT = 7300

# Candidates drawn per expected sample. Dart throwing stops adding points once the surface is
# nearly covered; 10 candidates per final point reaches within a few per cent of that.
_CANDIDATES_PER_SAMPLE = 10

# Accepted points per (area / spacing**2) for this sampler with the oversampling above,
# measured on the 14 authors' objects (12 of them within 2 % of it; objects whose bodies
# overlap get fewer). Used to pick the spacing that gives a wanted number of samples.
_DENSITY = 0.565


def spacing_for_count(area: float, count: int) -> float:
    """Disk spacing that gives about `count` samples on a surface of `area`.

    Parameters
    ----------
    area : float
        Surface area (length units squared).
    count : int
        Wanted number of samples.

    Returns
    -------
    float
        Minimum distance between samples, in length units.
    """
    return float(np.sqrt(_DENSITY * area / count))


def surface_area(triangles: np.ndarray) -> float:
    """Total area of triangles of shape (m, 3, 3)."""
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return float(0.5 * np.linalg.norm(cross, axis=1).sum())


def poisson_disk_surface(triangles: np.ndarray, spacing: float, seed: int = 0) -> np.ndarray:
    """Sample a surface so that no two samples are closer than `spacing`.

    Parameters
    ----------
    triangles : numpy.ndarray, shape (m, 3, 3)
        Corner coordinates of the surface's triangles.
    spacing : float
        Minimum distance between two samples, in the triangles' length units.
    seed : int
        Seed of the candidate generator; the same seed gives the same points.

    Returns
    -------
    numpy.ndarray, shape (k, 3), float64
        Sample points on the surface, about ``0.565 * area / spacing**2`` of them.
    """
    triangles = np.asarray(triangles, dtype=np.float64)
    if not (np.isfinite(spacing) and spacing > 0):
        raise BackendError(f"surface spacing must be a positive finite length, got {spacing!r}.")
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    areas = 0.5 * np.linalg.norm(cross, axis=1)
    total = float(areas.sum())
    if not total > 0:
        return np.zeros((0, 3))
    expected = _DENSITY * total / spacing**2
    n_candidates = int(np.ceil(_CANDIDATES_PER_SAMPLE * expected)) + 16
    if n_candidates > 50_000_000:
        raise BackendError(
            f"surface spacing {spacing:g} would need {n_candidates:,} candidate points on a "
            f"surface of area {total:g}; use a larger surface_spacing."
        )
    rng = np.random.default_rng(seed)
    cumulative = np.cumsum(areas)
    picked = np.searchsorted(cumulative, rng.random(n_candidates) * total, side="right")
    picked = np.minimum(picked, len(areas) - 1)
    u, v = rng.random((2, n_candidates))
    # Folding the unit square onto the triangle keeps the density uniform over its area.
    outside = u + v > 1.0
    u[outside], v[outside] = 1.0 - u[outside], 1.0 - v[outside]
    corners = triangles[picked]
    candidates = (
        corners[:, 0]
        + u[:, None] * (corners[:, 1] - corners[:, 0])
        + v[:, None] * (corners[:, 2] - corners[:, 0])
    )
    keep = _dart_throw(candidates, float(spacing))
    return candidates[keep]


@numba.njit(cache=True)
def _dart_throw(points, spacing):
    """Indices of points accepted in order when farther than `spacing` from all accepted."""
    n = points.shape[0]
    lower = np.empty(3)
    for d in range(3):
        lower[d] = points[:, d].min()
    # Open-addressing hash of cells of side `spacing`: a conflicting point can only be in the
    # 27 cells around a candidate's own.
    size = 1
    while size < 2 * n:
        size *= 2
    keys = np.full((size, 3), -1, np.int64)
    heads = np.full(size, -1, np.int64)
    chain = np.full(n, -1, np.int64)
    cells = np.empty((n, 3), np.int64)
    for p in range(n):
        for d in range(3):
            cells[p, d] = int((points[p, d] - lower[d]) / spacing)
    accepted = np.zeros(n, np.bool_)
    limit2 = spacing * spacing
    for p in range(n):
        clash = False
        for dx in range(-1, 2):
            for dy in range(-1, 2):
                for dz in range(-1, 2):
                    q = heads[
                        _find_slot(keys, cells[p, 0] + dx, cells[p, 1] + dy, cells[p, 2] + dz)
                    ]
                    while q != -1 and not clash:
                        d2 = 0.0
                        for d in range(3):
                            diff = points[p, d] - points[q, d]
                            d2 += diff * diff
                        if d2 < limit2:
                            clash = True
                        q = chain[q]
        if clash:
            continue
        accepted[p] = True
        slot = _find_slot(keys, cells[p, 0], cells[p, 1], cells[p, 2])
        keys[slot, 0], keys[slot, 1], keys[slot, 2] = cells[p, 0], cells[p, 1], cells[p, 2]
        chain[p] = heads[slot]
        heads[slot] = p
    return np.nonzero(accepted)[0]


@numba.njit(cache=True)
def _find_slot(keys, cx, cy, cz):
    """Slot of cell (cx, cy, cz) in the open-addressing table, or the empty slot it would take.

    Empty slots hold -1 keys (cell indices are never negative except for the lookups of
    neighbours beyond the lower edge, which find an empty slot and hence no points).
    """
    mask = keys.shape[0] - 1
    slot = ((cx * 73856093) ^ (cy * 19349663) ^ (cz * 83492791)) & mask
    while keys[slot, 0] != -1 and not (
        keys[slot, 0] == cx and keys[slot, 1] == cy and keys[slot, 2] == cz
    ):
        slot = (slot + 1) & mask
    return slot


@dataclass(frozen=True)
class ObjectPoints:
    """The points that stand for an object in the voxel estimator.

    Attributes
    ----------
    points : numpy.ndarray, shape (n, 3), float64
        Interior voxel centres first (`n_interior` of them), then surface samples; each kind
        ordered block by block.
    n_interior : int
        Number of interior voxel centres.
    voxel_volume : float
        ``V_o``, the volume of one object voxel (length units cubed).
    surface_weight : float
        ``w_s``, the volume counted for one surface sample inside the hand.
    block_starts : numpy.ndarray, shape (b + 1,), int64
        Block ``i`` holds ``points[block_starts[i]:block_starts[i + 1]]``.
    block_centres : numpy.ndarray, shape (b, 3)
        Centre of each block's bounding box.
    block_radii : numpy.ndarray, shape (b,)
        Distance from a block's centre to its farthest point.
    group_starts, group_centres, group_radii
        The same for groups of neighbouring blocks: group ``g`` holds blocks
        ``group_starts[g]:group_starts[g + 1]``.
    """

    points: np.ndarray
    n_interior: int
    voxel_volume: float
    surface_weight: float
    block_starts: np.ndarray
    block_centres: np.ndarray
    block_radii: np.ndarray
    group_starts: np.ndarray
    group_centres: np.ndarray
    group_radii: np.ndarray

    @property
    def n_surface(self) -> int:
        """Number of surface samples."""
        return len(self.points) - self.n_interior


# Object voxels per block side, and blocks per group side. Blocks are small so that one near
# the hand drags in few far points; groups let a pose reject many blocks with one test.
_BLOCK_VOXELS = 4
_GROUP_BLOCKS = 4


def object_points(
    bodies: list[tuple[np.ndarray, np.ndarray]],
    resolution: int,
    *,
    surface_samples: np.ndarray | None = None,
    surface_mode: str = "generate",
    surface_count: int | None = None,
    surface_spacing: float | None = None,
    surface_weight: str = "paper",
    seed: int = 0,
    grid_rule: str = "floor",
) -> ObjectPoints:
    """Interior voxel centres and surface samples of an object.

    Parameters
    ----------
    bodies : list of (V, F)
        Closed, outward-oriented shells of the object (several bodies allowed).
    resolution : int
        Voxels along the longest side of the object's bounding box; ``V_o`` is
        ``(longest / resolution) ** 3``.
    surface_samples : numpy.ndarray, shape (k, 3), optional
        Given surface points (same frame as `bodies`); used as they are when given.
    surface_mode : {"generate", "none"}
        Without given samples: sample the surface, or use no surface points.
    surface_count : int, optional
        Wanted number of generated samples (sets the spacing from the area).
    surface_spacing : float, optional
        Spacing of generated samples in object voxels. Without it or `surface_count`, the
        spacing gives about `AUTHORS_SAMPLE_COUNT` samples.
    surface_weight : {"paper", "area"}
        ``V_o / 32`` or ``(A / n) ** 1.5 / 2``.
    seed : int
        Seed of the surface sampler.
    grid_rule : {"floor", "round"}
        Voxel count of the shorter sides of the object grid (see
        `exactgrasp.backends.voxel.grids.grid_layout`).

    Returns
    -------
    ObjectPoints
    """
    from exactgrasp.backends.voxel.grids import occupancy_grid, stack_triangles

    grid = occupancy_grid(bodies, resolution, pad=0, rule=grid_rule)
    interior = grid.node_positions(grid.values.astype(bool))
    voxel_volume = grid.spacing**3
    triangles = stack_triangles(bodies)
    area = surface_area(triangles)
    if surface_samples is not None:
        surface = np.asarray(surface_samples, dtype=np.float64).reshape(-1, 3)
        if not np.all(np.isfinite(surface)):
            raise BackendError("surface samples contain NaN or infinite coordinates.")
    elif surface_mode == "none":
        surface = np.zeros((0, 3))
    else:
        if surface_count is not None:
            spacing = spacing_for_count(area, surface_count)
        elif surface_spacing is not None:
            spacing = surface_spacing * grid.spacing
        else:
            spacing = spacing_for_count(area, AUTHORS_SAMPLE_COUNT)
        surface = poisson_disk_surface(triangles, spacing, seed)
    if surface_weight == "paper":
        weight = voxel_volume / 2.0 / 16.0
    else:
        weight = (area / len(surface)) ** 1.5 / 2.0 if len(surface) else 0.0
    hierarchy = _hierarchy([interior, surface], grid.origin, _BLOCK_VOXELS * grid.spacing)
    return ObjectPoints(
        n_interior=len(interior),
        voxel_volume=float(voxel_volume),
        surface_weight=float(weight),
        **hierarchy,
    )


def _spheres(points: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bounding-box centres and enclosing radii of consecutive runs of points."""
    sizes = np.diff(starts)
    lower = np.minimum.reduceat(points, starts[:-1], axis=0)
    upper = np.maximum.reduceat(points, starts[:-1], axis=0)
    centres = 0.5 * (lower + upper)
    offsets = np.linalg.norm(points - np.repeat(centres, sizes, axis=0), axis=1)
    return np.ascontiguousarray(centres), np.maximum.reduceat(offsets, starts[:-1])


def _hierarchy(kinds: list[np.ndarray], origin: np.ndarray, side: float) -> dict:
    """Order points into cubic blocks of `side` and groups of blocks, one kind after another.

    Each block and group holds one kind only, so counts per kind need no per-point label.
    """
    ordered, block_starts, group_starts = [], [0], [0]
    for points in kinds:
        if len(points) == 0:
            continue
        cell = np.floor((points - origin) / side).astype(np.int64)
        group = cell // _GROUP_BLOCKS
        order = np.lexsort(
            (cell[:, 2], cell[:, 1], cell[:, 0], group[:, 2], group[:, 1], group[:, 0])
        )
        cell, group = cell[order], group[order]
        new_block = np.r_[True, np.any(cell[1:] != cell[:-1], axis=1)]
        new_group = np.r_[True, np.any(group[1:] != group[:-1], axis=1)]
        offset = sum(len(p) for p in ordered)
        first_blocks = np.flatnonzero(new_block)
        n_blocks = len(block_starts) - 1
        block_starts.extend(offset + first_blocks[1:])
        block_starts.append(offset + len(points))
        # A group starts at the block that holds the group's first point.
        group_first_block = np.searchsorted(first_blocks, np.flatnonzero(new_group))
        group_starts.extend(n_blocks + group_first_block[1:])
        group_starts.append(n_blocks + len(first_blocks))
        ordered.append(points[order])
    points = np.concatenate(ordered) if ordered else np.zeros((0, 3))
    block_starts = np.asarray(block_starts, np.int64)
    group_starts = np.asarray(group_starts, np.int64)
    block_centres, block_radii = (
        _spheres(points, block_starts) if len(points) else (np.zeros((0, 3)), np.zeros(0))
    )
    # Group spheres enclose their points (not their block spheres) to stay tight.
    group_point_starts = block_starts[group_starts]
    group_centres, group_radii = (
        _spheres(points, group_point_starts) if len(points) else (np.zeros((0, 3)), np.zeros(0))
    )
    return {
        "points": np.ascontiguousarray(points),
        "block_starts": block_starts,
        "block_centres": block_centres,
        "block_radii": block_radii,
        "group_starts": group_starts,
        "group_centres": group_centres,
        "group_radii": group_radii,
    }
