"""Speed of the voxel estimator on the real Barrett grasp, and its ratio to plain numpy.

The spray-bottle grasp of ``barrett-grasps/noise/`` in the shared data folder
(`exactgrasp.datapath.data_dir`; the authors' Barrett URDF, 62k triangles; the bottle, 11k
triangles, with generated surface samples) is read from its file and described with the
library's defaults, as a user calls it::

    grasp = eg.Grasp.from_file(path)
    eg.compute_descriptor(grasp, backend="voxel")    # balanced preset, 4,266 poses

Timed in one run, each figure the median of ``--repeats`` runs:

* first call: a fresh Python process per run (the kernels compiled when the package was
  built): the import, then
  ``Grasp.from_file`` and the descriptor;
* warm call: ``Grasp.from_file`` and the descriptor again in this process (what a second
  descriptor of the same hand and object costs), and the parts a first call builds, each
  afresh: reading the grasp, the hand grid, the object points, the hand's volume (the union
  of its links), the compiled estimate;
* the plain numpy estimator (`estimate_volumes_numpy`: the same estimator, every point of
  every pose tested, no culling, one thread) against the compiled one, on the same grids and
  the preset's 4,266 poses, the two alternating; their counts must be identical. The ratio
  is given with the default threads (every core) and with one thread: on a shared machine
  the second core is often busy, and the one-thread ratio does not depend on it.

Seconds drift by 20 % and more on a shared machine; the ratios, timed side by side, are the
stable figures. The first lines say which kernels ran (Cython, or numba before the port:
the script runs unchanged on either) and the figures go to ``--json`` for an A/B of two
checkouts.

Usage::

    python benchmarks/voxel.py [--repeats 3] [--grasp PATH] [--json results.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from exactgrasp.datapath import data_dir  # noqa: E402

GRASP_FILE = data_dir() / "barrett-grasps" / "noise" / "spray_bottle_base.json"

# One first call in a fresh process; prints its timings as JSON on its last line.
FIRST_CALL = """
import json, sys, time
t0 = time.perf_counter()
import exactgrasp as eg
t1 = time.perf_counter()
grasp = eg.Grasp.from_file(sys.argv[1])
t2 = time.perf_counter()
eg.compute_descriptor(grasp, backend="voxel")
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "from_file": t2 - t1, "descriptor": t3 - t2}))
"""


def seconds(function):
    """Wall time (s) of one call of `function`, and its result."""
    start = time.perf_counter()
    result = function()
    return time.perf_counter() - start, result


def median_seconds(function, repeats):
    """Median wall time (s) of `repeats` calls of `function`, and the last result."""
    times = []
    for _ in range(repeats):
        elapsed, result = seconds(function)
        times.append(elapsed)
    return statistics.median(times), result


def first_calls(path: Path, repeats: int) -> dict[str, float]:
    """Medians over fresh processes of the import, the grasp reading and the descriptor (s)."""
    runs = []
    for _ in range(repeats):
        done = subprocess.run(
            [sys.executable, "-c", FIRST_CALL, str(path)],
            capture_output=True,
            text=True,
            check=True,
            cwd=ROOT,
        )
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    out = {key: statistics.median(run[key] for run in runs) for key in runs[0]}
    out["call"] = statistics.median(run["from_file"] + run["descriptor"] for run in runs)
    return out


def kernel_kind() -> str:
    """``"Cython"``: the counting kernel compiled with the package (recorded with the figures,
    which numba kernels gave before)."""
    return "Cython"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--grasp", type=Path, default=GRASP_FILE, help="grasp JSON file")
    parser.add_argument("--repeats", type=int, default=3, help="runs per median (default 3)")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")
    args = parser.parse_args(argv)
    if not args.grasp.is_file():
        print(f"skipped: grasp file not found ({args.grasp}).")
        return 0

    import numpy as np

    import exactgrasp as eg
    from exactgrasp.backends import defaults
    from exactgrasp.backends.base import default_threads
    from exactgrasp.backends.voxel import (
        estimate_counts,
        estimate_counts_numpy,
        estimate_volumes,
        estimate_volumes_numpy,
    )
    from exactgrasp.backends.voxel.grids import hand_occupancy
    from exactgrasp.backends.voxel.points import object_points

    repeats = max(1, args.repeats)
    first = first_calls(args.grasp, repeats)

    def read_and_describe():
        return eg.compute_descriptor(eg.Grasp.from_file(args.grasp), backend="voxel")

    read_and_describe()  # the warm-up: kernels loaded, caches filled, as a second call finds
    warm, descriptor = median_seconds(read_and_describe, repeats)
    t_read, grasp = median_seconds(lambda: eg.Grasp.from_file(args.grasp), repeats)
    links, bodies = grasp.canonical_hand_links(), grasp.canonical_object_bodies()
    samples = grasp.canonical_object_surface_samples()
    hand_resolution = defaults.VOXEL_HAND_RESOLUTION
    object_resolution = defaults.VOXEL_OBJECT_RESOLUTION
    t_hand, hand = median_seconds(lambda: hand_occupancy(links, hand_resolution), repeats)
    t_object, obj = median_seconds(
        lambda: object_points(bodies, object_resolution, surface_samples=samples), repeats
    )
    fresh = [eg.Grasp.from_file(args.grasp) for _ in range(repeats)]
    t_volume = statistics.median(seconds(lambda g=g: g.canonical_hand_volume)[0] for g in fresh)
    poses = eg.PathSampler.preset("balanced").poses()

    threads = default_threads()
    fast, single, slow = [], [], []
    for _ in range(repeats):
        fast.append(seconds(lambda: estimate_volumes(hand, obj, poses))[0])
        single.append(seconds(lambda: estimate_volumes(hand, obj, poses, n_jobs=1))[0])
        slow.append(seconds(lambda: estimate_volumes_numpy(hand, obj, poses))[0])
    t_fast, t_single, t_slow = map(statistics.median, (fast, single, slow))
    counts = estimate_counts(hand, obj, poses)
    same = bool(np.array_equal(counts, estimate_counts_numpy(hand, obj, poses)))
    volumes = estimate_volumes(hand, obj, poses)
    same_descriptor = bool(
        np.array_equal(descriptor.values, volumes / grasp.canonical_hand_volume)
    )

    hand_triangles, object_triangles = (sum(len(f) for _, f in m) for m in (links, bodies))
    kernels = kernel_kind()
    print(
        f"grasp {args.grasp.name}: hand {hand_triangles:,} triangles, object "
        f"{object_triangles:,}; {poses.shape[0]} x {poses.shape[1]} poses"
    )
    print(
        f"hand grid {hand.grid.shape}, {obj.n_interior:,} interior + {obj.n_surface:,} surface "
        f"points; {kernels} kernels, {threads} threads by default, {os.cpu_count()} CPUs, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    print(
        f"compiled counts == numpy counts: {same}; descriptor == estimate / hand volume: "
        f"{same_descriptor}"
    )
    print(f"\nmedians of {repeats} (seconds drift with the machine's load; ratios less so)")
    rows = [
        ("first call: import exactgrasp", first["import"]),
        ("first call: Grasp.from_file + descriptor", first["call"]),
        ("  of which the descriptor", first["descriptor"]),
        ("warm call: Grasp.from_file + descriptor", warm),
        ("parts, each afresh: Grasp.from_file", t_read),
        ("  hand grid", t_hand),
        ("  object points", t_object),
        ("  hand volume (union of the links)", t_volume),
        (f"  estimate, compiled, {threads} threads", t_fast),
        ("  estimate, compiled, 1 thread", t_single),
        ("numpy estimate, same grids and poses", t_slow),
    ]
    for label, value in rows:
        print(f"{label:44s} {value:8.3f} s")
    ratio, ratio_single = t_slow / t_fast, t_slow / t_single
    print(f"\nratio, numpy estimate / compiled estimate: {ratio:.1f}x ({threads} threads), "
          f"{ratio_single:.1f}x (1 thread)")  # fmt: skip
    if args.json:
        figures = {label.strip(): value for label, value in rows}
        figures.update(
            kernels=kernels,
            ratio=ratio,
            ratio_one_thread=ratio_single,
            identical=same,
            load=os.getloadavg()[0],
            repeats=repeats,
        )
        args.json.write_text(json.dumps(figures, indent=1))
    return 0 if same and same_descriptor else 1


if __name__ == "__main__":
    sys.exit(main())
