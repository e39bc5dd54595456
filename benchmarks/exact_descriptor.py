"""Benchmark of the exact descriptor end to end, as a user calls it, on the real spray bottle.

``compute_descriptor(grasp, "balanced", backend="exact")`` with the library's defaults, the grasp
read from its file before each run (so nothing is cached from the run before), against the plain
loop (one manifold3d boolean of the whole hand and the whole object per pose) timed in the same
run on a subsample of poses and extrapolated per pose. Both are the median of ``--repeat`` runs
(3 by default), the two alternating; one untimed descriptor first loads the kernels.

CPU seconds are reported beside wall seconds: on a shared machine they measure the work done.
``--stages`` also times, one by one, what the descriptor path does besides the kernel: the
manifold3d unions and tables of the intersector, the coal BVH, the hand's own volume union, and
the kernel's volumes of all poses in one call against calls per 1/20 of the paths (1 and 2
threads).

    python benchmarks/exact_descriptor.py [--poses-subsample 40] [--repeat 3] [--stages]
                                          [--data ../shared/data] [--json results.json]

Skips with a message when the data folder is absent.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# The data folder's helper alone: importing exactgrasp here would warm what is being timed.
_DATAPATH = importlib.util.spec_from_file_location("datapath", ROOT / "exactgrasp" / "datapath.py")
datapath = importlib.util.module_from_spec(_DATAPATH)
_DATAPATH.loader.exec_module(datapath)
GRASP = "barrett-grasps/noise/spray_bottle_base.json"


def seconds(fn, *args, **kwargs) -> tuple[float, object]:
    """Wall seconds of one call, and its result."""
    wall, _, out = timed(fn, *args, **kwargs)
    return wall, out


def timed(fn, *args, **kwargs) -> tuple[float, float, object]:
    """Wall and CPU seconds (this process, every thread) of one call, and its result. On a
    shared machine the CPU seconds measure the work; the wall seconds also what others run."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return time.perf_counter() - t0, time.process_time() - c0, out


def stage_times(path: Path, repeat: int) -> dict[str, list[float]]:
    """Median [wall, CPU] seconds of each stage of the exact descriptor path, timed one by one
    (poses computed: [count, count])."""
    from exactgrasp.backends.exact import ExactIntersector
    from exactgrasp.geometry.bvh import MeshPair
    from exactgrasp.geometry.manifold import union_volume
    from exactgrasp.grasp import Grasp
    from exactgrasp.paths.sampler import PathSampler

    poses = PathSampler.preset("balanced").poses()
    chunk = max(1, poses.shape[0] // 20)
    runs: dict[str, list[tuple[float, float]]] = {}

    def add(key: str, wall: float, cpu: float) -> None:
        runs.setdefault(key, []).append((wall, cpu))

    for _ in range(repeat):
        grasp = Grasp.from_file(path)
        links, bodies = grasp.canonical_hand_links(), grasp.canonical_object_bodies()
        wall, cpu, ex = timed(ExactIntersector, links, bodies, broadphase=None, n_jobs=1)
        add("intersector build (unions, grids, tables)", wall, cpu)
        hand, obj = ex.hand_mesh, ex.object_mesh
        wall, cpu, _ = timed(
            MeshPair, "coal", hand.vertices, hand.faces, obj.vertices, obj.faces, ex.gap
        )
        add("coal BVH build", wall, cpu)
        wall, cpu, _ = timed(union_volume, grasp.hand.link_arrays())
        add("hand volume union", wall, cpu)
        for jobs in (1, 2):
            ex.n_jobs = jobs
            wall, cpu, _ = timed(ex.volumes, poses)
            add(f"kernel, one call, {jobs} thread(s)", wall, cpu)
            t0, c0 = time.perf_counter(), time.process_time()
            computed = 0
            for start in range(0, poses.shape[0], chunk):
                stats = ex.intersect(poses[start : start + chunk]).stats
                computed += stats["poses"] - stats["poses_repeated"]
            add(
                f"kernel, 1/20 of the paths per call, {jobs} thread(s)",
                time.perf_counter() - t0,
                time.process_time() - c0,
            )
        distinct = len(np.unique(ex_rep(ex, poses)))
        add("poses computed, one call", distinct, distinct)
        add("poses computed, 1/20 of the paths per call", computed, computed)
    return {key: np.median(np.array(v), axis=0).tolist() for key, v in runs.items()}


def ex_rep(ex, poses: np.ndarray) -> np.ndarray:
    """The representative of each pose as the intersector finds it (local coordinates)."""
    from exactgrasp.backends.exact import repeated_poses

    every = np.array(poses.reshape(-1, 4, 4))
    every[:, :3, 3] += every[:, :3, :3] @ ex.origin - ex.origin
    return repeated_poses(every)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses-subsample", type=int, default=40)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--stages", action="store_true", help="also time each stage alone")
    ap.add_argument("--data", type=Path, default=datapath.data_dir())
    ap.add_argument("--json", type=Path, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)
    path = args.data / GRASP
    if not path.is_file():
        print(f"skipped: {path} not found")
        return 0
    sys.path.insert(0, str(ROOT))
    from exactgrasp.backends.exact import plain_volumes
    from exactgrasp.descriptor import compute_descriptor
    from exactgrasp.grasp import Grasp
    from exactgrasp.paths.sampler import PathSampler

    flat = PathSampler.preset("balanced").poses().reshape(-1, 4, 4)
    sub = np.random.default_rng(0).choice(len(flat), args.poses_subsample, replace=False)
    compile_s, _ = seconds(compute_descriptor, Grasp.from_file(path), "balanced", "exact")
    descriptor_runs, cpu_runs, load_runs, plain_runs = [], [], [], []
    for _ in range(max(1, args.repeat)):
        load, grasp = seconds(Grasp.from_file, path)
        took, cpu, descriptor = timed(compute_descriptor, grasp, "balanced", backend="exact")
        load_runs.append(load)
        descriptor_runs.append(took)
        cpu_runs.append(cpu)
        links, bodies = grasp.canonical_hand_links(), grasp.canonical_object_bodies()
        plain, ref = seconds(plain_volumes, links, bodies, flat[sub])
        plain_runs.append(plain / len(sub))
    per_descriptor = float(np.median(descriptor_runs))
    per_pose = float(np.median(plain_runs))
    got = descriptor.values.ravel()[sub] * descriptor.metadata["hand_volume_canonical"]
    record = {
        "grasp": GRASP,
        "poses": len(flat),
        "backend_params": descriptor.metadata["backend_params"],
        "first_descriptor_seconds": compile_s,
        "load_seconds": float(np.median(load_runs)),
        "descriptor_seconds": per_descriptor,
        "descriptor_seconds_runs": descriptor_runs,
        "descriptor_cpu_seconds": float(np.median(cpu_runs)),
        "plain_seconds_per_pose": per_pose,
        "plain_seconds_per_pose_runs": plain_runs,
        "speedup": per_pose * len(flat) / per_descriptor,
        "max_rel_diff": float(np.max(np.abs(got - ref) / np.maximum(np.abs(ref), 1e-300))),
    }
    print(f"{GRASP}: {len(flat)} poses, backend_params {record['backend_params']}")
    print(f"  grasp from file          {record['load_seconds']:.2f} s")
    runs = ", ".join(f"{r:.2f}" for r in descriptor_runs)
    print(f"  exact descriptor         {per_descriptor:.2f} s  (runs {runs})")
    print(f"  ... CPU seconds          {record['descriptor_cpu_seconds']:.2f} s")
    print(f"  plain loop per pose      {per_pose * 1e3:.1f} ms  (x {len(flat)} poses)")
    print(f"  speed-up                 {record['speedup']:.0f}x")
    print(f"  max rel diff (subsample) {record['max_rel_diff']:.1e}")
    if args.stages:
        record["stages"] = stage_times(path, max(1, args.repeat))
        print(f"  {'stage (median)':<52} {'wall s':>8} {'CPU s':>8}")
        for key, (wall, cpu) in record["stages"].items():
            print(f"  {key:<52} {wall:8.3f} {cpu:8.3f}")
    if args.json:
        args.json.write_text(json.dumps(record, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
