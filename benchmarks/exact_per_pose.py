"""CPU milliseconds per pose of the exact backend on one thread: the real spray-bottle grasp,
every distinct pose of the balanced preset, no broad phase (every pose through the kernel).

For an A/B of two commits, check the other one out beside this tree and run the two in turn,
each in a fresh process, several rounds (the machine drifts between runs, so compare within a
round):

    git worktree add ../base <commit>
    for r in 1 2 3 4; do
        PYTHONPATH=../base python benchmarks/exact_per_pose.py --label base
        PYTHONPATH=. python benchmarks/exact_per_pose.py --label new
    done

Prints the label, the poses, ``--repeat`` timings (ms a pose, after a warm-up that compiles the
kernels) and the volumes' sum, which must agree to the bit between the two trees.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from shared_data import add_data_options, data_or_skip

GRASP = "barrett-grasps/noise/spray_bottle_base.json"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", default="this tree")
    ap.add_argument("--repeat", type=int, default=3)
    add_data_options(ap)
    args = ap.parse_args(argv)
    data = data_or_skip(args, GRASP)
    if data is None:
        return 0
    warnings.simplefilter("ignore")
    import exactgrasp as eg
    from exactgrasp.backends.base import repeated_poses
    from exactgrasp.backends.exact import ExactBackend
    from exactgrasp.paths.presets import as_sampler

    grasp = eg.Grasp.from_file(data / GRASP)
    poses = as_sampler(None).poses().reshape(-1, 4, 4)
    poses = poses[np.sort(np.unique(repeated_poses(poses), return_index=True)[1])]
    backend = ExactBackend(broadphase=None, n_jobs=1)
    backend.volumes(grasp, poses[:50])
    times = []
    for _ in range(args.repeat):
        start = time.process_time()
        volumes = backend.volumes(grasp, poses)
        times.append((time.process_time() - start) * 1e3 / len(poses))
    print(
        args.label, len(poses), " ".join(f"{t:.3f}" for t in times), "ms a pose;",
        f"volumes' sum {float(volumes.sum())!r}",
    )  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
