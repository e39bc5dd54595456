"""The voxel estimator's counting kernels: compiled and plain numpy, same numbers.

For every pose the object's points are moved into the hand grid's index space and those where
the trilinearly interpolated hand occupancy exceeds 0.5 are counted, interior and surface
points apart: ``volume = interior_inside * V_o + surface_inside * w_s``.

`estimate_counts` is the compiled path (`count_inside`, compiled ahead of time from
``_kernel.pyx``, and for x86-64 CPUs with AVX2 also as ``_kernel_avx2``, picked at import;
threads share the poses, each counting its own without the GIL; it walks the object's tree of
boxes and skips, or counts whole, the boxes that the hand's summed tables decide);
`estimate_counts_numpy` is the same estimator in plain vectorised numpy, every point of every
pose tested. Both evaluate every point they test with the same floating-point operations in
the same order, so their counts are identical.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from exactgrasp.backends._builds import fastest_build
from exactgrasp.backends.base import check_poses, resolve_jobs
from exactgrasp.backends.voxel.grids import HandOccupancy
from exactgrasp.backends.voxel.points import ObjectPoints

__all__ = [
    "count_inside",
    "counts_of_checked",
    "estimate_counts",
    "estimate_counts_numpy",
    "estimate_volumes",
    "estimate_volumes_numpy",
    "volumes_of_checked",
]


#: The counting kernel this CPU runs: ``count_inside`` of ``_kernel_avx2`` where the CPU runs
#: AVX2 and the package was built with it (x86-64), else of ``_kernel`` (the same source and
#: the same counts; `exactgrasp.backends._builds`). See ``_kernel.pyx`` for its arguments.
count_inside = fastest_build("exactgrasp.backends.voxel._kernel").count_inside

# Poses a thread takes at a time: enough that taking one costs little, few enough that the
# threads finish together.
_POSES_PER_TASK = 64

# Fewer poses than this are counted on the calling thread alone: starting other threads
# costs more than they save.
_PARALLEL_POSES = 256


def _index_space(hand: HandOccupancy, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses as affine maps from object coordinates to hand-grid index coordinates.

    Returns ``A = R / h`` (n, 3, 3) and ``b = (t - origin) / h`` (n, 3): a point ``x`` lands
    at grid coordinates ``A @ x + b`` (node ``(i, j, k)`` at integer coordinates).
    """
    flat = poses.reshape(-1, 4, 4)  # checked by the public entry points
    inv_h = 1.0 / hand.grid.spacing
    linear = np.ascontiguousarray(flat[:, :3, :3]) * inv_h
    offset = (np.ascontiguousarray(flat[:, :3, 3]) - hand.grid.origin) * inv_h
    return linear, offset


def estimate_counts(
    hand: HandOccupancy, obj: ObjectPoints, poses: np.ndarray, n_jobs: int | None = None
) -> np.ndarray:
    """Count the object's points inside the hand for each pose (compiled, with culling).

    Parameters
    ----------
    hand : HandOccupancy
        The hand grid (`hand_occupancy`).
    obj : ObjectPoints
        The object's interior and surface points (`object_points`).
    poses : numpy.ndarray, shape (..., 4, 4)
        Rigid transforms of the object: point ``x`` moves to ``R @ x + t``.
    n_jobs : int, optional
        Threads; None: `exactgrasp.backends.base.default_threads` (every core, or what a
        batch worker allows), -1: every core. Each pose is counted by one thread, so the
        counts do not depend on it.

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2] + (2,), int64
        Interior points inside, surface points inside.
    """
    return counts_of_checked(hand, obj, check_poses(poses), n_jobs)


def counts_of_checked(
    hand: HandOccupancy, obj: ObjectPoints, poses: np.ndarray, n_jobs: int | None = None
) -> np.ndarray:
    """`estimate_counts` of poses `exactgrasp.backends.base.check_poses` returned: the
    backend checks them once, where they enter."""
    linear, offset = _index_space(hand, poses)
    n = len(linear)
    counts = np.zeros((n, 2), np.int64)

    def count(first: int, last: int) -> None:
        count_inside(
            linear, offset, coords, obj.n_interior, obj.extent, obj.node_boxes,
            obj.node_ranges, obj.n_roots, obj.first_leaf, hand.cell_codes, hand.tiles,
            hand.tile_shift, first, last, counts,
        )  # fmt: skip

    # The points by coordinate, for the vectorised loop of `_count_leaf`.
    coords = np.ascontiguousarray(obj.points.T)
    jobs = min(resolve_jobs(n_jobs), -(-n // _POSES_PER_TASK))
    if jobs <= 1 or n < _PARALLEL_POSES:
        count(0, n)
    else:
        # Threads take pieces in turn until none is left, so a thread the machine keeps
        # waiting holds up at most one piece (`next` on a range iterator is atomic).
        pieces = iter(range(0, n, _POSES_PER_TASK))

        def work() -> None:
            for first in pieces:
                count(first, min(n, first + _POSES_PER_TASK))

        with ThreadPoolExecutor(jobs - 1) as pool:
            helpers = [pool.submit(work) for _ in range(jobs - 1)]
            work()
            for helper in helpers:
                helper.result()
    return counts.reshape((*poses.shape[:-2], 2))


def estimate_counts_numpy(
    hand: HandOccupancy, obj: ObjectPoints, poses: np.ndarray, chunk_elements: int = 2_000_000
) -> np.ndarray:
    """The same counts as `estimate_counts` in plain vectorised numpy, every point tested.

    Parameters
    ----------
    hand, obj, poses
        As for `estimate_counts`.
    chunk_elements : int
        Poses are handled in groups of about this many (pose, point) pairs to bound memory.

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2] + (2,), int64
    """
    poses = check_poses(poses)
    linear, offset = _index_space(hand, poses)
    occ = hand.grid.values
    nx, ny, nz = occ.shape
    flat_occ = occ.ravel()
    px, py, pz = obj.points[:, 0], obj.points[:, 1], obj.points[:, 2]
    is_interior = np.arange(len(obj.points)) < obj.n_interior
    counts = np.zeros((len(linear), 2), np.int64)
    step = max(1, chunk_elements // max(1, len(obj.points)))
    for first in range(0, len(linear), step):
        a = linear[first : first + step, :, :, None]
        b = offset[first : first + step, :, None]
        # Written out term by term, in the compiled kernel's order, so rounding is identical.
        gx = a[:, 0, 0] * px + a[:, 0, 1] * py + a[:, 0, 2] * pz + b[:, 0]
        gy = a[:, 1, 0] * px + a[:, 1, 1] * py + a[:, 1, 2] * pz + b[:, 1]
        gz = a[:, 2, 0] * px + a[:, 2, 1] * py + a[:, 2, 2] * pz + b[:, 2]
        ix, iy, iz = np.floor(gx), np.floor(gy), np.floor(gz)
        valid = (ix >= 0) & (ix < nx - 1) & (iy >= 0) & (iy < ny - 1) & (iz >= 0) & (iz < nz - 1)
        fx, fy, fz = gx - ix, gy - iy, gz - iz
        ex, ey, ez = 1.0 - fx, 1.0 - fy, 1.0 - fz
        base = np.where(valid, (ix * ny + iy) * nz + iz, 0).astype(np.int64)

        def corner(dx, dy, dz, base=base, valid=valid):
            return np.where(valid, flat_occ[base + (dx * ny + dy) * nz + dz], 0)

        value = ez * (
            ey * (ex * corner(0, 0, 0) + fx * corner(1, 0, 0))
            + fy * (ex * corner(0, 1, 0) + fx * corner(1, 1, 0))
        ) + fz * (
            ey * (ex * corner(0, 0, 1) + fx * corner(1, 0, 1))
            + fy * (ex * corner(0, 1, 1) + fx * corner(1, 1, 1))
        )
        inside = value > 0.5
        counts[first : first + step, 0] = (inside & is_interior).sum(axis=1)
        counts[first : first + step, 1] = (inside & ~is_interior).sum(axis=1)
    return counts.reshape((*poses.shape[:-2], 2))


def _volumes(obj: ObjectPoints, counts: np.ndarray) -> np.ndarray:
    return counts[..., 0] * obj.voxel_volume + counts[..., 1] * obj.surface_weight


def estimate_volumes(
    hand: HandOccupancy, obj: ObjectPoints, poses: np.ndarray, n_jobs: int | None = None
) -> np.ndarray:
    """Estimated intersection volume per pose (compiled path; `n_jobs` as for `estimate_counts`).

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2], float64
        ``interior_inside * V_o + surface_inside * w_s`` in the meshes' length units cubed.
    """
    return _volumes(obj, estimate_counts(hand, obj, poses, n_jobs))


def volumes_of_checked(
    hand: HandOccupancy, obj: ObjectPoints, poses: np.ndarray, n_jobs: int | None = None
) -> np.ndarray:
    """`estimate_volumes` of poses `exactgrasp.backends.base.check_poses` returned."""
    return _volumes(obj, counts_of_checked(hand, obj, poses, n_jobs))


def estimate_volumes_numpy(
    hand: HandOccupancy, obj: ObjectPoints, poses: np.ndarray
) -> np.ndarray:
    """Estimated intersection volume per pose (plain numpy baseline, no culling).

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2], float64
        Same values as `estimate_volumes`.
    """
    return _volumes(obj, estimate_counts_numpy(hand, obj, poses))
