"""The exact kernel's two builds against each other, in one process: the baseline build
(``_kernel``) and the AVX2 one (``_kernel_avx2``, x86-64 only), each CPU second of one thread.

The intersector's kernel is swapped chunk by chunk (about 400 poses each, every distinct pose
of the balanced preset, no broad phase, the builds' order turning from chunk to chunk), and
each chunk's time under the baseline build is divided by its time under the AVX2 build: the
machine's drift, which moves both alike within seconds, cancels in the ratio. Prints the
median and quartiles of those ratios (above 1: the AVX2 build is faster). ``--scene`` as in
``exact_per_pose.py``. With ``--against FILE``, the kernel built by another tree (a copy of
its ``_kernel_avx2`` or ``_kernel`` extension file) takes the baseline build's place: above 1,
this tree's AVX2 build is faster than that one.

    python benchmarks/exact_builds.py --scene spray --rounds 5
    python benchmarks/exact_builds.py --scene cereal --against /tmp/main_kernel_avx2.so
"""

from __future__ import annotations

import argparse
import importlib
import importlib.machinery
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np
from exact_per_pose import SCENES, scene_and_poses
from shared_data import add_data_options


def other_build(path: Path):
    """``pose_volumes`` of the kernel extension file ``path`` (another tree's ``_kernel_avx2``
    or ``_kernel``, under any file name), loaded without replacing this tree's module."""
    for stem in ("_kernel_avx2", "_kernel"):
        name = "exactgrasp.backends.exact." + stem
        loader = importlib.machinery.ExtensionFileLoader(name, str(path))
        spec = importlib.util.spec_from_file_location(name, path, loader=loader)
        saved = sys.modules.get(name)
        try:
            module = importlib.util.module_from_spec(spec)
        except ImportError:
            continue
        loader.exec_module(module)
        if saved is not None:
            sys.modules[name] = saved
        return module.pose_volumes
    raise SystemExit(f"--against {path}: not a build of the exact kernel; pass one")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=sorted(SCENES), default="spray")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--against", type=Path, help="another tree's kernel extension file")
    add_data_options(ap)
    args = ap.parse_args(argv)
    from exactgrasp.backends._builds import cpu_has_avx2
    from exactgrasp.backends.exact import ExactBackend, intersector

    if not cpu_has_avx2():
        print("this CPU does not run AVX2: one build only")
        return 0
    name = "exactgrasp.backends.exact._kernel"
    builds = {b: importlib.import_module(name + b).pose_volumes for b in ("", "_avx2")}
    if args.against is not None:
        if not args.against.is_file():
            raise SystemExit(f"--against {args.against}: no such file; pass a built kernel")
        builds[""] = other_build(args.against)
    scene = scene_and_poses(args)
    if scene is None:
        return 0
    grasp, poses = scene
    chunks = np.array_split(poses, max(1, len(poses) // 400))
    backend = ExactBackend(broadphase=None, n_jobs=1)
    backend.volumes(grasp, poses)  # tables built, the exact fallback's pairs kept
    ratios = []
    for r in range(args.rounds):
        for i, chunk in enumerate(chunks):
            seconds = {}
            for build in ("", "_avx2") if (r + i) % 2 == 0 else ("_avx2", ""):
                intersector.pose_volumes = builds[build]
                start = time.process_time()
                backend.volumes(grasp, chunk)
                seconds[build] = time.process_time() - start
            ratios.append(seconds[""] / seconds["_avx2"])
    intersector.pose_volumes = builds["_avx2"]
    q = np.quantile(ratios, [0.25, 0.5, 0.75])
    baseline = f"{args.against.name} (other tree)" if args.against else "baseline"
    print(
        f"{args.scene}: {baseline} / AVX2 build, {len(ratios)} chunks: median x{q[1]:.3f}",
        f"(quartiles x{q[0]:.3f}-x{q[2]:.3f})",
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
