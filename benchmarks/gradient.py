"""Benchmark: the volume's derivatives with the volumes against the volumes alone.

On real Barrett-hand grasps, the exact backend with the library's defaults
(`ExactBackend()`) times ``volume_gradients`` (volumes, twist and joint derivatives) and
``volumes`` on the same poses: every distinct pose of the default sampler's descriptor
(the balanced preset), the two alternating, each the median of ``--repeat`` runs, after one
warm-up call of each (kernel compilation, tables). Prints per grasp both medians and their
ratio (the cost of the derivatives), in wall-clock seconds and in CPU seconds of the process
(``time.process_time``, all threads: steadier than the wall clock on a shared machine), and
the share of poses with a non-zero volume. ``--every N`` keeps every N-th distinct pose.

    python benchmarks/gradient.py [--repeat 5] [--every 1] [--json results.json]

Needs the shared data folder; skips with a message when it is absent.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
from shared_data import add_data_options, data_or_skip  # noqa: E402

GRASPS = (
    "barrett-grasps/noise/spray_bottle_base.json",
    "barrett-grasps/study-records/CerealBox/obj5_sub4_grasp1_optimal0.json",
    "barrett-grasps/grasps/obj5_sub5_grasp5_optimal0_target.json",
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--every", type=int, default=1)
    add_data_options(ap)
    args = ap.parse_args(argv)
    data = data_or_skip(args, GRASPS[0])
    if data is None:
        return 0
    import numpy as np

    import exactgrasp as eg
    from exactgrasp.backends.base import repeated_poses
    from exactgrasp.backends.exact import ExactBackend

    poses = eg.PathSampler().poses().reshape(-1, 4, 4)
    poses = poses[np.unique(repeated_poses(poses))][:: args.every]
    rows = []
    for name in GRASPS:
        grasp = eg.Grasp.from_file(data / name)
        backend = ExactBackend()
        backend.volumes(grasp, poses)
        result = backend.volume_gradients(grasp, poses)
        plain, both, plain_cpu, both_cpu = [], [], [], []
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            backend.volumes(grasp, poses)
            plain.append(time.perf_counter() - t0)
            plain_cpu.append(time.process_time() - c0)
            t0, c0 = time.perf_counter(), time.process_time()
            backend.volume_gradients(grasp, poses)
            both.append(time.perf_counter() - t0)
            both_cpu.append(time.process_time() - c0)
        row = {
            "grasp": Path(name).stem,
            "poses": len(poses),
            "non_zero": float(np.mean(result.volumes > 0)),
            "volumes_s": statistics.median(plain),
            "gradients_s": statistics.median(both),
            "volumes_cpu_s": statistics.median(plain_cpu),
            "gradients_cpu_s": statistics.median(both_cpu),
            "runs_volumes_s": plain,
            "runs_gradients_s": both,
        }
        row["ratio"] = row["gradients_s"] / row["volumes_s"]
        row["ratio_cpu"] = row["gradients_cpu_s"] / row["volumes_cpu_s"]
        rows.append(row)
        print(
            f"{row['grasp']:34s} {row['poses']} poses ({100 * row['non_zero']:.0f} % non-zero): "
            f"volumes {row['volumes_s']:.3f} s ({row['volumes_cpu_s']:.3f} s CPU), with "
            f"gradients {row['gradients_s']:.3f} s ({row['gradients_cpu_s']:.3f} s CPU): "
            f"x{row['ratio']:.3f} wall, x{row['ratio_cpu']:.3f} CPU",
            flush=True,
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
