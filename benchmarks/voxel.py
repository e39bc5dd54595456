"""Speed of the voxel estimator: seconds per descriptor, and the speed-up over plain numpy.

Runs the paper's estimator (hand resolution 100, object resolution 50, about 7,300 surface
samples) on a real object from ``../shared/data/osu-objects/`` held in the built-in Barrett hand
(joints and object pose of the spray-bottle grasp in ``barrett-grasps/noise/``), over the
"balanced" path preset (474 paths x 9 steps = 4,266 poses).

Timed in one run:

* end to end: a fresh `VoxelBackend` per repeat, so the hand grid, the object's interior points
  and its surface samples are built every time (JIT compilation is excluded: one warm-up call
  first, and compiled kernels are cached on disk);
* cached geometry: `volumes` again on the same backend (grids reused);
* the plain numpy estimator (`estimate_volumes_numpy`, no culling) on the same grids, and the
  same end to end.

The machine may be shared, so the minimum over repeats is reported next to the median.

Usage::

    python benchmarks/voxel.py [--object SprayBottle] [--repeats 5] [--numpy-repeats 2]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numba
import numpy as np

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
GRASP_FILE = SHARED_DATA / "barrett-grasps" / "noise" / "spray_bottle_base.json"


CPU_TIMES: dict[int, list[float]] = {}


def timed(function, repeats):
    """Run `function` `repeats` times; return its last result and the wall times (s).

    The process CPU times (all threads) go to ``CPU_TIMES[id(wall times)]``: on a shared
    machine they show the work done, which other jobs do not inflate as much as wall time.
    """
    times, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = function()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    CPU_TIMES[id(times)] = cpu
    return result, times


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--object", default="SprayBottle", help="name in osu-objects/")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--numpy-repeats", type=int, default=2)
    args = parser.parse_args(argv)

    object_file = SHARED_DATA / "osu-objects" / f"{args.object}.STL"
    if not (GRASP_FILE.is_file() and object_file.is_file()):
        print(f"SKIPPED: shared data not found ({GRASP_FILE} or {object_file}).")
        return 0

    import exactgrasp as eg
    from exactgrasp.backends.voxel import (
        VoxelBackend,
        estimate_counts,
        estimate_counts_numpy,
        estimate_volumes,
        estimate_volumes_numpy,
    )

    record = json.loads(GRASP_FILE.read_text())
    hand = eg.hands.barrett(joints=record["joints"])
    solid = eg.Solid.from_file(object_file, units="mm")
    grasp = eg.Grasp(hand, solid, object_pose=np.array(record["object_pose_in_hand"]))
    poses = eg.PathSampler.preset("balanced").poses()

    # Warm-up: loads (or compiles) the numba kernels.
    VoxelBackend().volumes(grasp, poses)

    def end_to_end():
        return VoxelBackend().volumes(grasp, poses)

    volumes, e2e = timed(end_to_end, args.repeats)
    backend = VoxelBackend()
    hand_grid, t_hand = timed(lambda: backend.hand_grid(grasp), 1)
    obj, t_obj = timed(lambda: backend.object_point_set(grasp), 1)
    _, t_cached = timed(lambda: backend.volumes(grasp, poses), args.repeats)
    _, t_fast = timed(lambda: estimate_volumes(hand_grid, obj, poses), args.repeats)
    slow_volumes, t_numpy = timed(
        lambda: estimate_volumes_numpy(hand_grid, obj, poses), args.numpy_repeats
    )
    same = np.array_equal(
        estimate_counts(hand_grid, obj, poses), estimate_counts_numpy(hand_grid, obj, poses)
    )
    grids = t_hand[0] + t_obj[0]

    hand_volume = grasp.canonical_hand_volume
    print(f"object {args.object} in eg.hands.barrett(), preset 'balanced': {poses.shape}")
    print(
        f"hand grid {hand_grid.grid.shape}, {obj.n_interior} interior + {obj.n_surface} "
        f"surface points; max value {volumes.max() / hand_volume:.4f} of the hand volume"
    )
    print(
        f"numba {numba.__version__}, {numba.get_num_threads()} threads, "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}"
    )
    print(f"numba counts == numpy counts: {same}; volumes equal: "
          f"{np.array_equal(volumes, slow_volumes)}")  # fmt: skip
    print()
    rows = [
        ("voxel, end to end (grids built)", e2e),
        ("voxel, cached grids", t_cached),
        ("  of which hand grid", t_hand),
        ("  of which object points", t_obj),
        ("  of which estimate (compiled)", t_fast),
        ("numpy estimate (same grids)", t_numpy),
    ]
    print(f"{'what':38s} {'min s':>8s} {'median s':>9s} {'min CPU s':>10s}")
    for label, times in rows:
        cpu = min(CPU_TIMES[id(times)])
        print(f"{label:38s} {min(times):8.3f} {statistics.median(times):9.3f} {cpu:10.3f}")
    print()
    print(f"speed-up, estimate only:  {min(t_numpy) / min(t_fast):6.1f}x (numpy / compiled)")
    print(f"speed-up, end to end:     {(grids + min(t_numpy)) / min(e2e):6.1f}x")
    cpu_ratio = min(CPU_TIMES[id(t_numpy)]) / min(CPU_TIMES[id(t_fast)])
    print(f"CPU-time ratio, estimate: {cpu_ratio:6.1f}x (work done, all threads)")
    print(f"seconds per descriptor:   {min(e2e):.3f} end to end, {min(t_cached):.3f} cached")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
