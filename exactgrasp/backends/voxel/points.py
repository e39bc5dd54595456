"""The object's points for the voxel estimator: interior voxel centres, surface samples, and
the tree of boxes the kernel walks (`ObjectPoints`, `object_points`, `point_tree`).

The estimator adds points on the object's surface so that thin parts, which may hold no
interior voxel centre, still register (the paper used MeshLab's Poisson-disk resampling). Here
candidates are drawn uniformly by area from a seeded generator and accepted greedily, in the
order drawn, when no accepted point lies closer than the spacing: a dart-throwing Poisson-disk
set that is deterministic for a fixed seed (`dart_throw`, compiled ahead of time from
``_points.pyx``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exactgrasp.backends.defaults import VOXEL_GRID_RULE, VOXEL_SEED, VOXEL_SURFACE_WEIGHT
from exactgrasp.backends.voxel._points import dart_throw
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


def poisson_disk_surface(
    triangles: np.ndarray, spacing: float, seed: int = VOXEL_SEED
) -> np.ndarray:
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
    keep = dart_throw(candidates, float(spacing))
    return candidates[keep]


@dataclass(frozen=True)
class ObjectPoints:
    """The points that stand for an object in the voxel estimator, in a tree of boxes.

    The points are grouped by nested cubes (`LEVELS`); a node of the tree holds the points
    of one cube and of one kind, contiguous in `points`, and its box bounds them. A pose can
    then skip a node whose box lands where the hand has no inside node, or count it whole
    where the hand is solid.

    Attributes
    ----------
    points : numpy.ndarray, shape (n, 3), float64
        Interior voxel centres first (`n_interior` of them), then surface samples, each kind
        ordered node by node (length units).
    n_interior : int
        Number of interior voxel centres.
    voxel_volume : float
        ``V_o``, the volume of one object voxel (length units cubed).
    surface_weight : float
        ``w_s``, the volume counted for one surface sample inside the hand.
    node_boxes : numpy.ndarray, shape (6, m), float64
        Per node, by row: the centre x, y, z of its points' bounding box and its half sides
        (length units); every point of node ``i`` lies within ``node_boxes[:3, i] +-
        node_boxes[3:, i]``.
    node_ranges : numpy.ndarray, shape (m, 4), int64
        Per node: its points ``points[r0:r1]`` and its children, nodes ``r2:r3`` (none for
        leaves). Nodes are stored level by level, coarsest first.
    n_roots : int
        Nodes ``0:n_roots`` are the coarsest level; every point lies under one of them.
    first_leaf : int
        Nodes from ``first_leaf`` on are leaves (the finest level).
    extent : float
        Largest absolute coordinate of any point (bounds the rounding of moved points).
    """

    points: np.ndarray
    n_interior: int
    voxel_volume: float
    surface_weight: float
    node_boxes: np.ndarray
    node_ranges: np.ndarray
    n_roots: int
    first_leaf: int
    extent: float

    @property
    def n_surface(self) -> int:
        """Number of surface samples."""
        return len(self.points) - self.n_interior


#: Sides of the nested cubes that group the points, in object voxels, coarsest first: leaves
#: of 4 voxels drag few points far from the hand into a test, and the roots let a pose
#: reject many leaves with one test (finer or more levels measured slower; see
#: docs/voxel-estimator.md).
LEVELS = (16, 4)


def object_points(
    bodies: list[tuple[np.ndarray, np.ndarray]],
    resolution: int,
    *,
    surface_samples: np.ndarray | None = None,
    surface_mode: str = "generate",
    surface_count: int | None = None,
    surface_spacing: float | None = None,
    surface_weight: str = VOXEL_SURFACE_WEIGHT,
    seed: int = VOXEL_SEED,
    grid_rule: str = VOXEL_GRID_RULE,
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
    return ObjectPoints(
        n_interior=len(interior),
        voxel_volume=float(voxel_volume),
        surface_weight=float(weight),
        **point_tree([interior, surface], grid.origin, grid.spacing),
    )


def _boxes(points: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Bounding boxes of consecutive runs of points: (6, runs), centres then half sides."""
    lower = np.minimum.reduceat(points, starts, axis=0)
    upper = np.maximum.reduceat(points, starts, axis=0)
    return np.concatenate([0.5 * (lower + upper), 0.5 * (upper - lower)], axis=1).T


def point_tree(
    kinds: list[np.ndarray],
    origin: np.ndarray,
    voxel: float,
    levels: tuple[int, ...] | None = None,
) -> dict:
    """Order points, one kind after another, into a tree of nested cubes (see `ObjectPoints`).

    Parameters
    ----------
    kinds : list of numpy.ndarray, each (k, 3)
        Points of each kind; a node never mixes kinds.
    origin : numpy.ndarray, shape (3,)
        A corner shared by the cubes of every level.
    voxel : float
        Unit of `levels` (length units).
    levels : tuple of int, optional
        Cube sides in voxels, coarsest first; default `LEVELS`.

    Returns
    -------
    dict
        The `ObjectPoints` fields ``points``, ``node_boxes``, ``node_ranges``, ``n_roots``,
        ``first_leaf`` and ``extent``.
    """
    levels = LEVELS if levels is None else levels
    points = np.concatenate([np.reshape(k, (-1, 3)) for k in kinds]).astype(np.float64)
    kind = np.repeat(np.arange(len(kinds)), [len(k) for k in kinds])
    keys = [np.floor((points - origin) / (side * voxel)).astype(np.int64) for side in levels]
    # lexsort sorts by its last key first: kind, then the coarsest cube, ..., the finest.
    columns = [key[:, axis] for key in reversed(keys) for axis in (2, 1, 0)]
    order = np.lexsort((*columns, kind))
    points, kind = points[order], kind[order]
    n = len(points)
    # Where a node of each level starts: a new kind or a new cube of that level or a coarser one.
    starts, changed = [], kind[1:] != kind[:-1]
    for key in keys:
        key = key[order]
        changed |= np.any(key[1:] != key[:-1], axis=1)
        starts.append(np.r_[0, 1 + np.flatnonzero(changed)] if n else np.zeros(0, np.int64))
    first = np.cumsum([0] + [len(s) for s in starts])
    ranges, boxes = [], []
    for level, level_starts in enumerate(starts):
        ends = np.r_[level_starts[1:], n]
        children = np.zeros((len(level_starts), 2), np.int64)
        if level + 1 < len(starts):
            child = first[level + 1] + np.searchsorted(starts[level + 1], np.r_[level_starts, n])
            children = np.stack([child[:-1], child[1:]], axis=1)
        ranges.append(np.column_stack([level_starts, ends, children]))
        boxes.append(_boxes(points, level_starts) if n else np.zeros((6, 0)))
    return {
        "points": np.ascontiguousarray(points),
        "node_boxes": np.ascontiguousarray(np.concatenate(boxes, axis=1)),
        "node_ranges": np.ascontiguousarray(np.concatenate(ranges).astype(np.int64)),
        "n_roots": len(starts[0]),
        "first_leaf": int(first[-2]),
        "extent": float(np.abs(points).max()) if n else 0.0,
    }
