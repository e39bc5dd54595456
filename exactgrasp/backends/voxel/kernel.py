"""The voxel estimator's counting kernels: compiled (numba) and plain numpy, same numbers.

For every pose the object's points are moved into the hand grid's index space and those where
the trilinearly interpolated hand occupancy exceeds 0.5 are counted, interior and surface
points apart: ``volume = interior_inside * V_o + surface_inside * w_s``.

`estimate_counts` is the compiled path (threads share the poses; it walks the object's tree
of boxes and skips, or counts whole, the boxes that the hand's summed tables decide);
`estimate_counts_numpy` is the same estimator in plain vectorised numpy, every point of every
pose tested. Both evaluate every point they test with the same floating-point operations in
the same order, so their counts are identical.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from exactgrasp.backends.base import check_poses, resolve_jobs
from exactgrasp.backends.voxel.grids import HandOccupancy
from exactgrasp.backends.voxel.points import ObjectPoints
from exactgrasp.compiling import inner, kernel

__all__ = [
    "count_inside",
    "counts_of_checked",
    "estimate_counts",
    "estimate_counts_numpy",
    "estimate_volumes",
    "estimate_volumes_numpy",
    "volumes_of_checked",
]


# Every moved point lies within its box's moved bounds up to rounding, a few units in the last
# place of the largest term; this relative margin covers that many times over.
_MARGIN = 1e-9

# Masks of the packed summed table (`HandOccupancy.tiles`): occupied tiles low, full ones high.
_LOW, _HIGH = np.uint64(0xFFFFFFFF), np.uint64(32)

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


@inner()
def _interpolate(fx, fy, fz, code):
    """Trilinear interpolation in a cell whose corner values are the bits of `code`.

    A cell with all corners outside (code 0) gives exactly 0, one with all inside (255) 1
    within rounding, so no case needs a branch.
    """
    ex, ey, ez = 1.0 - fx, 1.0 - fy, 1.0 - fz
    c000, c100, c010, c110 = code & 1, code >> 1 & 1, code >> 2 & 1, code >> 3 & 1
    c001, c101, c011, c111 = code >> 4 & 1, code >> 5 & 1, code >> 6 & 1, code >> 7
    return ez * (ey * (ex * c000 + fx * c100) + fy * (ex * c010 + fx * c110)) + fz * (
        ey * (ex * c001 + fx * c101) + fy * (ex * c011 + fx * c111)
    )


@inner()
def _move_boxes(a, b, margin, boxes, first, last, bounds):
    """Moved bounds of the boxes ``first:last`` into ``bounds[:, :last - first]``.

    `boxes` holds the boxes' centres and half sides by coordinate, (6, m); the rows of
    `bounds` are low x, high x, low y, high y, low z, high z, widened by `margin`. No
    branches, so it vectorises.
    """
    a00, a01, a02, a10, a11, a12 = a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2]
    a20, a21, a22, b0, b1, b2 = a[2, 0], a[2, 1], a[2, 2], b[0], b[1], b[2]
    m00, m01, m02, m10, m11, m12 = abs(a00), abs(a01), abs(a02), abs(a10), abs(a11), abs(a12)
    m20, m21, m22 = abs(a20), abs(a21), abs(a22)
    for q in range(last - first):
        c0, c1, c2 = boxes[0, first + q], boxes[1, first + q], boxes[2, first + q]
        h0, h1, h2 = boxes[3, first + q], boxes[4, first + q], boxes[5, first + q]
        mid = a00 * c0 + a01 * c1 + a02 * c2 + b0
        reach = m00 * h0 + m01 * h1 + m02 * h2 + margin
        bounds[0, q], bounds[1, q] = mid - reach, mid + reach
        mid = a10 * c0 + a11 * c1 + a12 * c2 + b1
        reach = m10 * h0 + m11 * h1 + m12 * h2 + margin
        bounds[2, q], bounds[3, q] = mid - reach, mid + reach
        mid = a20 * c0 + a21 * c1 + a22 * c2 + b2
        reach = m20 * h0 + m21 * h1 + m22 * h2 + margin
        bounds[4, q], bounds[5, q] = mid - reach, mid + reach


@inner()
def _count_leaf(a, b, coords, start, end, codes, cells, cell, frac):
    """How many points ``start:end`` land where the interpolated occupancy exceeds 0.5.

    Three loops: moving the points and finding their cells, reading the cells' codes,
    interpolating. The first and last vectorise and no loop branches on a point (those near
    the hand's surface fall either way). A point outside the grid is moved onto the grid's
    outer layer of nodes, which are all outside the hand (`hand_occupancy` pads the grid),
    so it gets at most a rounding error above 0 and never counts, as in the numpy baseline.
    `coords` holds the points by coordinate (3, n), `codes` the cell codes raveled, `cells`
    the cells per axis; `cell` and `frac` are scratch.
    """
    a00, a01, a02, a10, a11, a12 = a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2]
    a20, a21, a22, b0, b1, b2 = a[2, 0], a[2, 1], a[2, 2], b[0], b[1], b[2]
    nx, ny, nz = cells
    # The largest coordinates inside the grid.
    top_x, top_y, top_z = np.nextafter(nx, 0.0), np.nextafter(ny, 0.0), np.nextafter(nz, 0.0)
    for k in range(end - start):
        x, y, z = coords[0, start + k], coords[1, start + k], coords[2, start + k]
        # Same operations in the same order as the numpy baseline: same rounding.
        gx = a00 * x + a01 * y + a02 * z + b0
        gy = a10 * x + a11 * y + a12 * z + b1
        gz = a20 * x + a21 * y + a22 * z + b2
        gx, gy, gz = min(max(gx, 0.0), top_x), min(max(gy, 0.0), top_y), min(max(gz, 0.0), top_z)
        i, j, m = int(gx), int(gy), int(gz)
        cell[k] = (i * ny + j) * nz + m
        frac[0, k], frac[1, k], frac[2, k] = gx - i, gy - j, gz - m
    for k in range(end - start):
        cell[k] = codes[cell[k]]
    inside = 0
    for k in range(end - start):
        inside += _interpolate(frac[0, k], frac[1, k], frac[2, k], cell[k]) > 0.5
    return inside


@inner()
def _count_pose(
    a, b, margin, coords, boxes, ranges, n_roots, first_leaf, n_interior, codes, cells, tiles,
    tile_shape, shift, stack, bounds, cell, frac,
):  # fmt: skip
    """Interior and surface points inside the hand for one pose (see `count_inside`).

    Walks the tree of boxes depth first, the children of a node together. A box whose moved
    bounds cover no tile with an inside corner is skipped, one inside the grid covering full
    tiles only is counted whole, the points of the other leaves are tested one by one.
    """
    nx, ny, nz = cells
    ty, tz = tile_shape
    interior = surface = 0
    for root in range(n_roots):
        inside, top = 0, 0
        first, last = root, root + 1
        while True:
            _move_boxes(a, b, margin, boxes, first, last, bounds)
            for q in range(last - first):
                node = first + q
                lx, hx, ly, hy = bounds[0, q], bounds[1, q], bounds[2, q], bounds[3, q]
                lz, hz = bounds[4, q], bounds[5, q]
                # Points outside the grid (below 0, or at n and above) never count.
                if hx < 0.0 or lx >= nx or hy < 0.0 or ly >= ny or hz < 0.0 or lz >= nz:
                    continue
                # Tiles [x0, x1) x [y0, y1) x [z0, z1) hold every cell the points can reach.
                x0 = int(lx) >> shift if lx >= 0.0 else 0
                y0 = int(ly) >> shift if ly >= 0.0 else 0
                z0 = int(lz) >> shift if lz >= 0.0 else 0
                x1 = ((int(hx) if hx < nx else nx - 1) >> shift) + 1
                y1 = ((int(hy) if hy < ny else ny - 1) >> shift) + 1
                z1 = ((int(hz) if hz < nz else nz - 1) >> shift) + 1
                # Unsigned indices skip numba's negative-index handling (all are >= 0 here).
                i00, i01 = np.uint64((x0 * ty + y0) * tz), np.uint64((x0 * ty + y1) * tz)
                i10, i11 = np.uint64((x1 * ty + y0) * tz), np.uint64((x1 * ty + y1) * tz)
                u0, u1 = np.uint64(z0), np.uint64(z1)
                # Unsigned wrap-around leaves both packed counts exact: each final count fits.
                total = (
                    tiles[i11 + u1] - tiles[i01 + u1] - tiles[i10 + u1] - tiles[i11 + u0]
                    + tiles[i00 + u1] + tiles[i01 + u0] + tiles[i10 + u0] - tiles[i00 + u0]
                )  # fmt: skip
                if total & _LOW == 0:
                    continue
                start, end = ranges[node, 0], ranges[node, 1]
                within = lx >= 0.0 and ly >= 0.0 and lz >= 0.0 and hx < nx and hy < ny
                within = within and hz < nz
                if within and np.int64(total >> _HIGH) == (x1 - x0) * (y1 - y0) * (z1 - z0):
                    inside += end - start
                elif node < first_leaf:
                    stack[top] = node
                    top += 1
                else:
                    inside += _count_leaf(a, b, coords, start, end, codes, cells, cell, frac)
            if top == 0:
                break
            top -= 1
            first, last = ranges[stack[top], 2], ranges[stack[top], 3]
        # A root holds one kind of point.
        if ranges[root, 0] < n_interior:
            interior += inside
        else:
            surface += inside
    return interior, surface


@kernel(nogil=True)
def count_inside(
    linear, offset, coords, n_interior, extent, boxes, ranges, n_roots, first_leaf, codes,
    tiles, shift, first, last, counts,
):  # fmt: skip
    """Count poses ``first:last``: interior and surface points inside the hand into `counts`.

    Arguments are those of `estimate_counts`, unpacked (`coords` the points by coordinate,
    (3, n)); see `_index_space` for the poses. Releases the GIL, so threads can count
    different poses at once; `counts` is int64 (poses, 2).
    """
    leaf_size = fanout = 1
    for node in range(ranges.shape[0]):
        leaf_size = max(leaf_size, ranges[node, 1] - ranges[node, 0])
        fanout = max(fanout, ranges[node, 3] - ranges[node, 2])
    # A node is pushed at most once per root: the internal nodes bound the stack.
    stack = np.empty(max(1, first_leaf), np.int64)
    bounds = np.empty((6, fanout))
    cell = np.empty(leaf_size, np.int64)
    frac = np.empty((3, leaf_size))
    cells, tile_shape = codes.shape, tiles.shape[1:]
    flat_codes, flat_tiles = codes.ravel(), tiles.ravel()
    for p in range(first, last):
        a, b = linear[p], offset[p]
        largest = 0.0
        for axis in range(3):
            row = abs(a[axis, 0]) + abs(a[axis, 1]) + abs(a[axis, 2])
            largest = max(largest, abs(b[axis]) + row * extent)
        counts[p, 0], counts[p, 1] = _count_pose(
            a, b, _MARGIN * (1.0 + largest), coords, boxes, ranges, n_roots, first_leaf,
            n_interior, flat_codes, cells, flat_tiles, tile_shape, shift, stack, bounds, cell,
            frac,
        )  # fmt: skip


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
