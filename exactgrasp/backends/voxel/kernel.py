"""The voxel estimator's counting kernels: compiled (numba) and plain numpy, same numbers.

For every pose the object's points are moved into the hand grid's index space and those where
the trilinearly interpolated hand occupancy exceeds 0.5 are counted, interior and surface
points apart: ``volume = interior_inside * V_o + surface_inside * w_s``.

`estimate_counts` is the compiled path (parallel over poses, skipping blocks of points that
cannot reach the hand); `estimate_counts_numpy` is the same estimator in plain vectorised
numpy. Both evaluate every point with the same floating-point operations in the same order, so
their counts are identical. Imports `exactgrasp.backends.base` and the voxel room's grids and
points only.
"""

from __future__ import annotations

import numba
import numpy as np

from exactgrasp.backends.base import check_poses
from exactgrasp.backends.voxel.grids import HandOccupancy
from exactgrasp.backends.voxel.points import ObjectPoints

__all__ = [
    "count_inside",
    "estimate_counts",
    "estimate_counts_numpy",
    "estimate_volumes",
    "estimate_volumes_numpy",
]


# A point can only count when it lies in a grid cell with an inside corner, so within sqrt(3)
# node spacings of an inside node; the small extra keeps rounding in the bound harmless.
_REACH = np.sqrt(3.0) + 1e-6


def _index_space(hand: HandOccupancy, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses as affine maps from object coordinates to hand-grid index coordinates.

    Returns ``A = R / h`` (n, 3, 3) and ``b = (t - origin) / h`` (n, 3): a point ``x`` lands
    at grid coordinates ``A @ x + b`` (node ``(i, j, k)`` at integer coordinates).
    """
    flat = check_poses(poses).reshape(-1, 4, 4)
    inv_h = 1.0 / hand.grid.spacing
    linear = np.ascontiguousarray(flat[:, :3, :3]) * inv_h
    offset = (np.ascontiguousarray(flat[:, :3, 3]) - hand.grid.origin) * inv_h
    return linear, offset


@numba.njit(cache=True, inline="always")
def _far(a, b, centre, radius, cells, clearance, factor):
    """Whether no point within `radius` (grid spacings) of `centre` can reach the hand.

    Bounds the distance from the mapped centre to the nearest inside node from below: the part
    outside the grid's box and the clearance inside it add in quadrature.
    """
    out2 = 0.0
    i0 = i1 = i2 = 0
    for axis in range(3):
        g = a[axis, 0] * centre[0] + a[axis, 1] * centre[1] + a[axis, 2] * centre[2] + b[axis]
        # Nodes run from 0 to cells[axis] (one more node than cells).
        clamped = min(max(g, 0.0), float(cells[axis]))
        out2 += (g - clamped) ** 2
        # Coarse cell I gathers the points within half a spacing of its nodes.
        index = min(int((clamped + 0.5) / factor), clearance.shape[axis] - 1)
        if axis == 0:
            i0 = index
        elif axis == 1:
            i1 = index
        else:
            i2 = index
    # A point in coarse cell I and an inside node in cell J are at least
    # factor * |I - J| - sqrt(3) * (factor - 1/2) spacings apart.
    near = factor * clearance[i0, i1, i2] - np.sqrt(3.0) * (factor - 0.5)
    reach = radius + _REACH
    return out2 + (near * near if near > 0.0 else 0.0) > reach * reach


@numba.njit(cache=True, inline="always")
def _interpolate(fx, fy, fz, code):
    """Trilinear interpolation in a cell whose corner values are the bits of `code`."""
    ex, ey, ez = 1.0 - fx, 1.0 - fy, 1.0 - fz
    c000, c100, c010, c110 = code & 1, code >> 1 & 1, code >> 2 & 1, code >> 3 & 1
    c001, c101, c011, c111 = code >> 4 & 1, code >> 5 & 1, code >> 6 & 1, code >> 7
    return ez * (ey * (ex * c000 + fx * c100) + fy * (ex * c010 + fx * c110)) + fz * (
        ey * (ex * c001 + fx * c101) + fy * (ex * c011 + fx * c111)
    )


@numba.njit(parallel=True, cache=True)
def count_inside(
    linear, offset, points, n_interior, starts, centres, radii,
    group_starts, group_centres, group_radii, codes, inv_h, clearance, factor,
):  # fmt: skip
    """Interior and surface points inside the hand, per pose: int64 array (poses, 2).

    Arguments are those of `estimate_counts`, unpacked; see `_index_space` for the poses.
    """
    counts = np.zeros((linear.shape[0], 2), np.int64)
    cx, cy, cz = codes.shape
    flat = codes.ravel()
    for p in numba.prange(linear.shape[0]):
        a, b = linear[p], offset[p]
        a00, a01, a02, a10, a11, a12 = a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2]
        a20, a21, a22, b0, b1, b2 = a[2, 0], a[2, 1], a[2, 2], b[0], b[1], b[2]
        inside_interior = inside_surface = 0
        for group in range(group_radii.shape[0]):
            reach = group_radii[group] * inv_h
            if _far(a, b, group_centres[group], reach, codes.shape, clearance, factor):
                continue
            for block in range(group_starts[group], group_starts[group + 1]):
                reach = radii[block] * inv_h
                if _far(a, b, centres[block], reach, codes.shape, clearance, factor):
                    continue
                inside = 0
                for q in range(starts[block], starts[block + 1]):
                    x, y, z = points[q, 0], points[q, 1], points[q, 2]
                    # Same operations in the same order as the numpy baseline: same rounding.
                    gx = a00 * x + a01 * y + a02 * z + b0
                    gy = a10 * x + a11 * y + a12 * z + b1
                    gz = a20 * x + a21 * y + a22 * z + b2
                    if not (0.0 <= gx < cx and 0.0 <= gy < cy and 0.0 <= gz < cz):
                        continue
                    i, j, k = int(gx), int(gy), int(gz)
                    code = flat[(i * cy + j) * cz + k]
                    # All-outside and all-inside cells need no arithmetic: the weights sum to 1
                    # within rounding, far from the 0.5 threshold.
                    if code == 0:
                        continue
                    if code != 255 and not _interpolate(gx - i, gy - j, gz - k, code) > 0.5:
                        continue
                    inside += 1
                # Blocks hold one kind of point each.
                if starts[block] < n_interior:
                    inside_interior += inside
                else:
                    inside_surface += inside
        counts[p, 0] = inside_interior
        counts[p, 1] = inside_surface
    return counts


def estimate_counts(hand: HandOccupancy, obj: ObjectPoints, poses: np.ndarray) -> np.ndarray:
    """Count the object's points inside the hand for each pose (compiled, with culling).

    Parameters
    ----------
    hand : HandOccupancy
        The hand grid (`hand_occupancy`).
    obj : ObjectPoints
        The object's interior and surface points (`object_points`).
    poses : numpy.ndarray, shape (..., 4, 4)
        Rigid transforms of the object: point ``x`` moves to ``R @ x + t``.

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2] + (2,), int64
        Interior points inside, surface points inside.
    """
    poses = check_poses(poses)
    linear, offset = _index_space(hand, poses)
    counts = count_inside(
        linear,
        offset,
        obj.points,
        obj.n_interior,
        obj.block_starts,
        obj.block_centres,
        obj.block_radii,
        obj.group_starts,
        obj.group_centres,
        obj.group_radii,
        hand.cell_codes,
        1.0 / hand.grid.spacing,
        hand.clearance,
        hand.clearance_factor,
    )
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


def estimate_volumes(hand: HandOccupancy, obj: ObjectPoints, poses: np.ndarray) -> np.ndarray:
    """Estimated intersection volume per pose (compiled path).

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2], float64
        ``interior_inside * V_o + surface_inside * w_s`` in the meshes' length units cubed.
    """
    return _volumes(obj, estimate_counts(hand, obj, poses))


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
