"""Record the winding-number and voxel kernels' results on fixed fuzzed inputs.

``numba_kernels.npz`` in this folder holds the inputs made here and the results of the numba
kernels of commit 98cb945 (the last with numba winding-number and voxel kernels), recorded with
that commit's package::

    python tests/kernel_goldens/record.py   # writes tests/kernel_goldens/numba_kernels.npz

`tests/test_kernel_goldens.py` checks that the compiled kernels give the same results to the
bit. Run this again only to add a case on purpose (then the file records the kernels of the
day, which the test can no longer compare with numba's); the inputs depend on this script and
numpy's generators only.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
OUT = HERE / "numba_kernels.npz"


def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit icosphere (outward faces) without trimesh: vertices (n, 3), faces (m, 3) int64."""
    t = (1.0 + 5.0**0.5) / 2.0
    V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]  # fmt: skip
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]  # fmt: skip
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    for _ in range(subdivisions):
        middle: dict = {}

        def mid(i, j, middle=middle):
            key = (min(i, j), max(i, j))
            if key not in middle:
                m = V[i] + V[j]
                V.append(m / np.linalg.norm(m))
                middle[key] = len(V) - 1
            return middle[key]

        F = [
            face
            for a, b, c in F
            for face in ((a, mid(a, b), mid(c, a)), (b, mid(b, c), mid(a, b)),
                         (c, mid(c, a), mid(b, c)), (mid(a, b), mid(b, c), mid(c, a)))
        ]  # fmt: skip
    return np.array(V), np.array(F, np.int64)


def box(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box with outward faces."""
    (x0, y0, z0), (x1, y1, z1) = lower, upper
    V = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], float)
    F = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]  # fmt: skip
    return V, np.array(F, np.int64)


def meshes() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Closed, crumpled (self-crossing) and open meshes."""
    rng = np.random.default_rng(1)
    V, F = icosphere(2)
    crumpled = V * (1.0 + 0.45 * rng.standard_normal((len(V), 1)))
    Vb, Fb = box((-0.5, -0.25, -0.75), (0.5, 0.25, 0.75))
    # Two boxes sharing a face: coincident triangles of opposite orientation.
    Vc, Fc = box((0.5, -0.25, -0.75), (1.0, 0.25, 0.0))
    return {
        "sphere": (V, F),
        "crumpled": (crumpled, F),
        "boxes": (np.vstack([Vb, Vc]), np.vstack([Fb, Fc + len(Vb)])),
        "open": (V, F[: len(F) // 2]),
    }


def winding_cases(rng) -> dict[str, np.ndarray]:
    """`winding_number` of random points, mesh vertices, face centres and edge midpoints."""
    out = {}
    for name, (V, F) in meshes().items():
        lo, hi = V.min(0) - 0.3, V.max(0) + 0.3
        points = [rng.uniform(lo, hi, (150, 3)), V[:20], V[F[:20]].mean(1),
                  0.5 * (V[F[:20, 0]] + V[F[:20, 1]]), np.array([[1e3, -2e3, 5e2]])]  # fmt: skip
        out[f"winding/{name}/V"], out[f"winding/{name}/F"] = V, F
        out[f"winding/{name}/points"] = np.vstack(points)
    return out


def lattice_cases(rng) -> dict[str, np.ndarray]:
    """Triangles in index coordinates: generic, snapped to half-integers (rays through
    vertices and edges), an integer box (faces through nodes), crumpled, an open soup."""
    V, F = icosphere(2)
    shapes = {
        "generic": (V * 6.3 + 8.2, F, (17, 16, 18)),
        "snapped": (np.round((V * 6.0 + 8.0) * 2.0) / 2.0, F, (17, 17, 17)),
        "integer_box": (*box((1, 1, 1), (6, 5, 7)), (9, 8, 10)),
        "clipped": (V * 9.0 + 4.0, F, (10, 9, 11)),
        "crumpled": (meshes()["crumpled"][0] * 6.0 + 8.0, F, (17, 17, 17)),
    }
    out = {}
    for name, (W, G, shape) in shapes.items():
        out[f"lattice/{name}/triangles"] = np.ascontiguousarray(W[G], dtype=np.float64)
        out[f"lattice/{name}/shape"] = np.array(shape, np.int64)
    soup = rng.uniform(0.0, 12.0, (60, 3, 3))
    soup[::3] = np.round(soup[::3])
    out["lattice/soup/triangles"] = soup
    out["lattice/soup/shape"] = np.array((13, 12, 13), np.int64)
    return out


def dart_cases(rng) -> dict[str, np.ndarray]:
    """Candidates and spacings: a cube, a sphere's surface, a long line (the sampler's grid
    grows its cells), one point repeated, a single point."""
    direction = rng.standard_normal((800, 3))
    long = np.zeros((500, 3))
    long[:, 0] = rng.uniform(0.0, 1e4, 500)
    long[:, 1:] = rng.uniform(0.0, 1.0, (500, 2))
    cases = {
        "cube": (rng.random((1200, 3)), 0.07),
        "sphere": (direction / np.linalg.norm(direction, axis=1, keepdims=True), 0.11),
        "long": (long, 0.8),
        "repeated": (np.tile([[0.25, -1.5, 3.0]], (40, 1)), 0.1),
        "single": (np.array([[1.0, 2.0, 3.0]]), 0.5),
    }
    out = {}
    for name, (points, spacing) in cases.items():
        out[f"dart/{name}/points"] = points
        out[f"dart/{name}/spacing"] = np.array(spacing)
    return out


def count_cases(rng) -> dict[str, np.ndarray]:
    """The counting kernel's arguments: a hand grid of two overlapping spheres and a box of
    points (the library's own builders), random and grid-aligned poses, some across the grid's
    border and some far."""
    from scipy.spatial.transform import Rotation

    from exactgrasp.backends.voxel import kernel
    from exactgrasp.backends.voxel.grids import hand_occupancy, summed_table, tile_any
    from exactgrasp.backends.voxel.points import object_points

    V, F = icosphere(2)
    links = [(V * 0.04, F), (V * 0.03 + [0.05, 0.0, 0.01], F)]
    hand = hand_occupancy(links, 32)
    Vb, Fb = box((-0.03, -0.02, -0.015), (0.03, 0.02, 0.015))
    obj = object_points([(Vb, Fb)], 14, surface_count=300)
    n = 400
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, :3] = Rotation.random(n, random_state=5).as_matrix()
    poses[:, :3, 3] = rng.uniform([-0.07, -0.06, -0.06], [0.1, 0.06, 0.07], (n, 3))
    poses[:40, :3, :3] = np.eye(3)
    poses[:40, :3, 3] = hand.grid.origin + hand.grid.spacing * rng.integers(0, 32, (40, 3))
    poses[-5:, :3, 3] = [5.0, -3.0, 1.0]
    linear, offset = kernel._index_space(hand, poses)
    # The same grid with tiles of 4 x 4 x 4 cells, as a finer hand grid gets.
    codes = hand.cell_codes
    occupied = tile_any(codes != 0, 4).astype(np.uint64)
    full = ~tile_any(codes != 255, 4)
    coarse = summed_table(occupied + (full.astype(np.uint64) << np.uint64(32)))
    return {
        "count/linear": linear,
        "count/offset": offset,
        "count/coords": np.ascontiguousarray(obj.points.T),
        "count/n_interior": np.array(obj.n_interior),
        "count/extent": np.array(obj.extent),
        "count/boxes": obj.node_boxes,
        "count/ranges": obj.node_ranges,
        "count/n_roots": np.array(obj.n_roots),
        "count/first_leaf": np.array(obj.first_leaf),
        "count/codes": hand.cell_codes,
        "count/tiles": hand.tiles,
        "count/shift": np.array(hand.tile_shift),
        "count/coarse/tiles": coarse,
        "count/coarse/shift": np.array(2),
    }


def inputs() -> dict[str, np.ndarray]:
    """Every case's inputs, from fixed seeds."""
    rng = np.random.default_rng(20261205)
    return {**winding_cases(rng), **lattice_cases(rng), **dart_cases(rng), **count_cases(rng)}


def record(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The kernels' results on `arrays` (the inputs): keys ``<case>/result...``."""
    from exactgrasp.backends.voxel.kernel import count_inside
    from exactgrasp.backends.voxel.points import dart_throw
    from exactgrasp.geometry.winding import (
        winding_inside_lattice,
        winding_number,
    )

    out = {}
    for key in [k for k in arrays if k.endswith("/points") and k.startswith("winding/")]:
        case = key.rsplit("/", 1)[0]
        V, F = arrays[f"{case}/V"], arrays[f"{case}/F"]
        out[f"{case}/result"] = np.array([winding_number(p, V, F) for p in arrays[key]])
    for key in [k for k in arrays if k.startswith("lattice/") and k.endswith("/triangles")]:
        case = key.rsplit("/", 1)[0]
        nx, ny, nz = (int(v) for v in arrays[f"{case}/shape"])
        out[f"{case}/result"] = winding_inside_lattice(arrays[key], nx, ny, nz)
    for key in [k for k in arrays if k.startswith("dart/") and k.endswith("/points")]:
        case = key.rsplit("/", 1)[0]
        out[f"{case}/result"] = dart_throw(arrays[key], float(arrays[f"{case}/spacing"]))
    a = {k.split("/", 1)[1]: v for k, v in arrays.items() if k.startswith("count/")}
    for prefix in ("", "coarse/"):
        counts = np.zeros((len(a["linear"]), 2), np.int64)
        count_inside(
            a["linear"], a["offset"], a["coords"], int(a["n_interior"]), float(a["extent"]),
            a["boxes"], a["ranges"], int(a["n_roots"]), int(a["first_leaf"]), a["codes"],
            a[prefix + "tiles"], int(a[prefix + "shift"]), 0, len(counts), counts,
        )  # fmt: skip
        out[f"count/{prefix}result"] = counts
    return out


def main() -> int:
    arrays = inputs()
    results = record(arrays)
    np.savez_compressed(OUT, **arrays, **results)
    print(f"wrote {OUT} ({OUT.stat().st_size:,} bytes, {len(arrays) + len(results)} arrays)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
