"""Would a hand's tables, BVHs and voxel grids pay if kept per link? Each timed per link
against the backends' own work on the union of the links, on study records.

Kept per link, they would be built once per worker and only posed for each row, sparing the
per-row build on the posed hand; but each pose would then be computed against every link
(and, for an exact sum, against the pieces where links overlap) instead of once against the
union. For every ``--records``-th study record (6 by default, every 4th of the 24 of
``benchmarks/batch.py``), on one thread, library defaults, the CPU seconds of the computing
thread over the default sampler's poses:

``exact`` tables (broad phase off):

* the union: `ExactIntersector` of the posed links and the object, its build and its kernel;
* the hand's half of that build (the same intersector with a tiny far-away object): the
  most that tables kept per link could spare a row;
* per link: one `ExactIntersector` of each link alone with the object, its kernel, summed
  over the links, and the same for each piece where two links overlap (manifold3d's
  intersection), which inclusion-exclusion subtracts again. Pieces of three links are not
  run: the per-link figure is a lower bound.

``exact`` BVHs (the broad phase's, coal): the union's BVH build, and a "far" query
(`geometry.bvh.MeshPair.far`: collision, then distance) per pose against the union's BVH and
against each link's in turn, on the poses the kernel's own test leaves open
(`culling.crossing_poses`: the only ones the broad phase is asked about) and on 200 poses far
from the hand; also the union's kernel time on the open poses, the most culling can spare.

``voxel`` grids: the posed hand's grid (`VoxelBackend.hand_grid`'s, paper resolution) and its
count over the poses, against one grid per link at the same voxel size, each counted over
the same poses. A per-link estimate would also have to count a point inside two links once,
which the per-link sum here does not (its total over the union's is printed): the per-link
time is a lower bound.

Tables, BVHs or grids per link pay only if the extra time per row is less than the build
they spare.

Usage::

    python benchmarks/per_link.py [--records 6]
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
from pathlib import Path

import numpy as np
import trimesh
from batch import study_rows
from shared_data import add_data_options

from exactgrasp.backends.base import thread_limit
from exactgrasp.backends.exact.culling import crossing_poses
from exactgrasp.backends.exact.intersector import ExactIntersector, shifted
from exactgrasp.backends.voxel import VoxelBackend
from exactgrasp.backends.voxel.grids import hand_occupancy
from exactgrasp.backends.voxel.kernel import volumes_of_checked
from exactgrasp.batch.worker import warm_up
from exactgrasp.geometry.bvh import MeshPair
from exactgrasp.geometry.manifold import mesh_arrays, to_manifold
from exactgrasp.grasp import Grasp
from exactgrasp.paths.presets import as_sampler


def thread_seconds(fn, *args, **kwargs):
    """(CPU seconds of this thread, result) of ``fn(*args, **kwargs)``."""
    t0 = time.thread_time()
    out = fn(*args, **kwargs)
    return time.thread_time() - t0, out


def overlap_pieces(links: list) -> list:
    """``[(V, F), ...]``: the solid where each pair of links overlaps, those with volume."""
    solids = [to_manifold(V, F, "hand link") for V, F in links]
    pieces = []
    for a, b in itertools.combinations(solids, 2):
        both = a ^ b
        if both.volume() > 0:
            pieces.append(mesh_arrays(both))
    return pieces


def kernel_seconds(meshes: list, body: list, poses: np.ndarray) -> float:
    """CPU seconds of the exact kernel of each mesh alone with ``body`` over ``poses``, summed."""
    total = 0.0
    for mesh in meshes:
        seconds, _ = thread_seconds(ExactIntersector([mesh], body, None).volumes, poses)
        total += seconds
    return total


def query_ms(pairs: list, poses: np.ndarray) -> float:
    """Milliseconds per pose of asking each `MeshPair` in turn whether the pose is far (as
    one BVH per link would: the first near link ends it)."""
    t0 = time.thread_time()
    for pose in poses:
        all(pair.far(pose) for pair in pairs)
    return 1e3 * (time.thread_time() - t0) / len(poses)


def exact_figures(grasp: Grasp, poses: np.ndarray) -> dict:
    """The exact backend's tables and BVHs, union against links (see the module's text)."""
    links, body = grasp.canonical_hand_links(), grasp.canonical_object_bodies()
    build, union = thread_seconds(ExactIntersector, links, body, None)
    kernel, _ = thread_seconds(union.volumes, poses)
    speck = trimesh.creation.box(extents=(0.01, 0.01, 0.01))
    far_speck = [(speck.vertices + np.array([100.0, 0.0, 0.0]), speck.faces)]
    hand_build, _ = thread_seconds(ExactIntersector, links, far_speck, None)
    pieces = overlap_pieces(links)
    local = poses.copy()  # about the local origin, as `ExactIntersector` computes
    local[:, :3, 3] += local[:, :3, :3] @ union.origin - union.origin
    crossing = crossing_poses(
        local, union.hand_mesh, union.hand_grid, union.object_mesh, union.object_grid,
        union.shells,
    )  # fmt: skip
    open_kernel = 0.0
    if not crossing.all():
        open_kernel, _ = thread_seconds(union.volumes, poses[~crossing])
    BV, BF = union.object_mesh.vertices, union.object_mesh.faces
    union_bvh, whole = thread_seconds(
        MeshPair, "coal", union.hand_mesh.vertices, union.hand_mesh.faces, BV, BF, union.gap
    )
    per_link_bvh = [
        MeshPair("coal", V, F, BV, BF, union.gap) for V, F in shifted(links, union.origin)
    ]
    far = np.tile(np.eye(4), (200, 1, 1))
    far[:, 0, 3] = 30.0 + 0.1 * np.arange(200)
    return {
        "union_build_s": build,
        "hand_build_s": hand_build,
        "union_kernel_s": kernel,
        "links_kernel_s": kernel_seconds(links, body, poses),
        "pieces": len(pieces),
        "pieces_kernel_s": kernel_seconds(pieces, body, poses),
        "open_poses": int((~crossing).sum()),
        "open_kernel_s": open_kernel,
        "union_bvh_s": union_bvh,
        "query_ms": {
            name: {"union": query_ms([whole], P), "links": query_ms(per_link_bvh, P)}
            for name, P in (("open", local[~crossing]), ("far", far))
            if len(P)
        },
    }


def voxel_figures(grasp: Grasp, poses: np.ndarray, backend: VoxelBackend) -> dict:
    """The voxel backend's grid of the posed hand against grids per link (see the module's
    text)."""
    links = grasp.canonical_hand_links()
    points = backend.object_point_set(grasp)
    build, union = thread_seconds(hand_occupancy, links, backend.hand_resolution, backend.grid)
    count, volumes = thread_seconds(volumes_of_checked, union, points, poses, 1)
    spacing = union.grid.spacing
    link_count, link_volumes = 0.0, np.zeros(len(poses))
    for V, F in links:
        resolution = max(2, round(float(np.ptp(V, axis=0).max()) / spacing))
        grid = hand_occupancy([(V, F)], resolution, backend.grid)
        seconds, got = thread_seconds(volumes_of_checked, grid, points, poses, 1)
        link_count += seconds
        link_volumes += got
    return {
        "grid_build_s": build,
        "union_count_s": count,
        "links_count_s": link_count,
        "links_over_union_volume": float(link_volumes.sum() / volumes.sum()),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=6, help="study records (every 4th of 24)")
    add_data_options(parser)
    args = parser.parse_args()
    study = study_rows(args, max(1, 24 // args.records))
    if study is None:
        return 0
    manifest, rows = study
    rows = rows[: args.records]
    poses = as_sampler(None).poses().reshape(-1, 4, 4)
    print(
        f"{len(rows)} study records, {len(poses)} poses each, one thread, "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
        flush=True,
    )
    for backend in ("exact", "voxel"):  # each backend's kernels loaded before any timing
        warm_up(backend)
    voxel = VoxelBackend()
    figures = []
    with thread_limit(1):
        for row in rows:
            grasp = Grasp.from_file(Path(manifest).parent / row.grasp)
            ex, vx = exact_figures(grasp, poses), voxel_figures(grasp, poses, voxel)
            figures.append({"record": row.id, "exact": ex, "voxel": vx})
            extra = ex["links_kernel_s"] + ex["pieces_kernel_s"] - ex["union_kernel_s"]
            print(
                f"{row.id}\n  exact tables: union build {ex['union_build_s']:.2f} s (the "
                f"hand's {ex['hand_build_s']:.2f} s), kernel {ex['union_kernel_s']:.2f} s; "
                f"the links' kernels {ex['links_kernel_s']:.2f} s and {ex['pieces']} overlap "
                f"pieces' {ex['pieces_kernel_s']:.2f} s: {extra:+.2f} s\n  exact BVHs: "
                f"{ex['open_poses']} poses open, the kernel on them {ex['open_kernel_s']:.3f} "
                f"s; the union's BVH built in {ex['union_bvh_s']:.3f} s; a far query per "
                "pose, union against links: "
                + "; ".join(
                    f"{k} {q['union']:.2f} against {q['links']:.2f} ms"
                    for k, q in ex["query_ms"].items()
                )
                + f"\n  voxel grids: the hand's built in {vx['grid_build_s']:.3f} s, counted "
                f"in {vx['union_count_s']:.3f} s; per link {vx['links_count_s']:.3f} s "
                f"(their volumes' sum / the union's: {vx['links_over_union_volume']:.3f})",
                flush=True,
            )
    ex = [f["exact"] for f in figures]
    vx = [f["voxel"] for f in figures]
    kernel = sum(f["union_kernel_s"] for f in ex)
    per_link = sum(f["links_kernel_s"] + f["pieces_kernel_s"] for f in ex)
    count = sum(f["union_count_s"] for f in vx)
    link_count = sum(f["links_count_s"] for f in vx)
    print(
        f"in all, exact: the kernels per link and piece / the union's x{per_link / kernel:.2f} "
        f"({per_link:.1f} against {kernel:.1f} s); the hand's builds, the most tables per link "
        f"could spare: {sum(f['hand_build_s'] for f in ex):.1f} s\n"
        f"in all, voxel: the counts per link / the union's x{link_count / count:.2f} "
        f"({link_count:.2f} against {count:.2f} s); the hand's grids, the most grids per link "
        f"could spare: {sum(f['grid_build_s'] for f in vx):.2f} s",
        flush=True,
    )
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
