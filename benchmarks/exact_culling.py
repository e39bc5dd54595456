"""What the exact backend's broad phase costs or spares: ``broadphase="coal"`` against
``None`` on poses around study-record grasps.

For every 6th of the 24 study records of ``benchmarks/batch.py`` (4 records, each a Barrett
hand of about 72,000 triangles), 1,500 seeded random rotations, each moved ``--distances``
canonical units (the hand is about 2 across) in a random direction: `ExactIntersector.intersect`
with the broad phase (library defaults otherwise) and without, one thread, alternating which
goes first, ``--repeat`` times; the median CPU seconds of the computing thread of each, their
ratio, the poses culled, whether the BVHs were built, and whether the volumes are identical
(they must be: culling never changes a result).

Then, per record and distance, what the BVHs do once built: on the poses the broad phase
leaves open (not apart by the bounds, not certainly crossing), the kernel's CPU milliseconds a
pose against culling's (`culling.culled_poses`: the BVH query and the shells' look-ups) plus
the kernel's on the poses it does not cull, and the BVHs' build: they pay where the first
exceeds the second by more than the build, which sets
`defaults.EXACT_CULL_TRIANGLES_PER_POSE`.

Usage::

    python benchmarks/exact_culling.py [--distances 4,2,1.5] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from batch import study_rows
from scipy.spatial.transform import Rotation
from shared_data import add_data_options

from exactgrasp.backends.base import thread_limit
from exactgrasp.backends.exact import ExactBackend
from exactgrasp.backends.exact.culling import culled_poses
from exactgrasp.batch.worker import warm_up
from exactgrasp.geometry.bvh import MeshPair
from exactgrasp.grasp import Grasp

POSES = 1500


def around(distance: float, seed: int) -> np.ndarray:
    """``POSES`` rigid poses (4, 4): random rotations, moved ``distance`` in random directions."""
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (POSES, 1, 1))
    poses[:, :3, :3] = Rotation.random(POSES, random_state=seed).as_matrix()
    direction = rng.normal(size=(POSES, 3))
    poses[:, :3, 3] = distance * direction / np.linalg.norm(direction, axis=1)[:, None]
    return poses


def timed_intersect(grasp: Grasp, broadphase: str | None, poses: np.ndarray):
    """(CPU seconds of this thread, `Intersection`, BVHs built) of a fresh intersector's call."""
    intersector = ExactBackend(broadphase=broadphase).intersector(grasp)
    t0 = time.thread_time()
    result = intersector.intersect(poses)
    return time.thread_time() - t0, result, intersector.cull is not None


def open_pose_costs(grasp: Grasp, poses: np.ndarray) -> dict:
    """Per open pose, the kernel's CPU ms against culling's with the BVHs built (see above)."""
    ix = ExactBackend(broadphase="coal").intersector(grasp)
    t0 = time.thread_time()
    ix.cull = MeshPair(
        "coal", ix.hand_mesh.vertices, ix.hand_mesh.faces, ix.object_mesh.vertices,
        ix.object_mesh.faces, ix.gap,
    )  # fmt: skip
    build = time.thread_time() - t0
    local = poses.copy()  # about the intersector's local origin, as `intersect` moves them
    local[:, :3, 3] += local[:, :3, :3] @ ix.origin - ix.origin
    apart, crossing = ix.broad_phase(local)
    chosen = local[~apart & ~crossing]
    out = {
        "open": len(chosen),
        "build_s": build,
        "triangles": len(ix.hand_mesh.faces) + len(ix.object_mesh.faces),
    }
    if not len(chosen):
        return out
    t0 = time.thread_time()
    ix._chunk(chosen)
    kernel = time.thread_time() - t0
    t0 = time.thread_time()
    culled = culled_poses(
        chosen, ix.cull, ix.hand_mesh, ix.hand_grid, ix.object_mesh, ix.object_grid, ix.shells,
        ix.samples, np.zeros(len(chosen), bool),
    )  # fmt: skip
    ix._chunk(chosen[~culled])
    culling = time.thread_time() - t0
    out.update(kernel_ms=1e3 * kernel / len(chosen), culling_ms=1e3 * culling / len(chosen))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--distances", default="4,2,1.5", help="canonical units, comma-separated")
    parser.add_argument("--repeat", type=int, default=3)
    add_data_options(parser)
    args = parser.parse_args()
    study = study_rows(args, 6)
    if study is None:
        return 0
    manifest, rows = study
    print(
        f"{len(rows)} study records, {POSES} poses a distance, one thread, "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
        flush=True,
    )
    warm_up("exact")
    figures = []
    with thread_limit(1):
        for row in rows:
            grasp = Grasp.from_file(Path(manifest).parent / row.grasp)
            for k, distance in enumerate(float(d) for d in args.distances.split(",")):
                poses = around(distance, seed=k)
                seconds: dict[str | None, list[float]] = {"coal": [], None: []}
                volumes = {}
                for repeat in range(args.repeat):
                    for bp in ("coal", None) if repeat % 2 == 0 else (None, "coal"):
                        spent, result, built = timed_intersect(grasp, bp, poses)
                        seconds[bp].append(spent)
                        volumes[bp] = result.volumes
                        if bp == "coal":
                            culled, cull_built = result.stats["poses_culled"], built
                coal, plain = statistics.median(seconds["coal"]), statistics.median(seconds[None])
                same = bool(np.array_equal(volumes["coal"], volumes[None]))
                zero = int((volumes[None] == 0).sum())
                figures.append({
                    "record": row.id, "distance": distance, "coal_s": coal, "none_s": plain,
                    "culled": culled, "zero": zero, "bvh_built": cull_built, "identical": same,
                })  # fmt: skip
                print(
                    f"{row.id}, {distance:g} away: coal {coal:.2f} s, None {plain:.2f} s "
                    f"(x{coal / plain:.2f}); {culled} of the {zero} zero volumes culled, BVHs "
                    f"{'built' if cull_built else 'not built'}, volumes "
                    f"{'identical' if same else 'DIFFERENT'}",
                    flush=True,
                )
                costs = open_pose_costs(grasp, poses)
                figures[-1]["open_poses"] = costs
                if costs["open"]:
                    saving = costs["kernel_ms"] - costs["culling_ms"]
                    pays = (
                        f"the build repaid after {1e3 * costs['build_s'] / saving:.0f} open poses"
                        if saving > 0
                        else "never repaid"
                    )
                    print(
                        f"  {costs['open']} poses open: the kernel {costs['kernel_ms']:.3f} ms a "
                        f"pose, culling {costs['culling_ms']:.3f} ms; BVHs built in "
                        f"{costs['build_s']:.3f} s for {costs['triangles']} triangles: {pays}",
                        flush=True,
                    )
    coal = sum(f["coal_s"] for f in figures)
    plain = sum(f["none_s"] for f in figures)
    print(f"in all: coal {coal:.1f} s, None {plain:.1f} s (x{coal / plain:.2f})", flush=True)
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")
    return 0 if all(f["identical"] for f in figures) else 1


if __name__ == "__main__":
    sys.exit(main())
