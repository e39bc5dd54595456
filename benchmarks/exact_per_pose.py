"""CPU milliseconds per pose of the exact backend on one thread: a grasp, every distinct pose
of the balanced preset, no broad phase (every pose through the kernel).

``--scene`` picks the grasp: ``spray`` (default; the authors' Barrett hand and spray bottle,
``barrett-grasps/noise/spray_bottle_base.json``), ``cereal`` (a contact-adjusted cereal-box
study grasp, ``barrett-grasps/grasps/obj5_sub4_grasp1_optimal0_target.json``) or ``messy``
(the messy-hand benchmark's hand, `messy_hand.write_hand`: 17 links, 283k triangles, edges of
four faces and a self-crossing palm, with the built-in bottle pushed into its palm).

For an A/B of two commits, check the other one out beside this tree and run the two in turn,
each in a fresh process, several rounds (the machine drifts between runs, so compare within a
round):

    git worktree add ../base <commit>
    for r in 1 2 3 4; do
        PYTHONPATH=../base python benchmarks/exact_per_pose.py --label base
        PYTHONPATH=. python benchmarks/exact_per_pose.py --label new
    done

``--machine`` runs it in one process alone, then in two at once: the machine's own speed-up of
two cores on this kernel, which two threads cannot pass. ``--pieces K`` also times the kernel
in one call against K runs of neighbouring poses and K interleaved sets of them (how the
intersector cuts a call for its threads).

Prints the label, the poses, ``--repeat`` timings (ms a pose, after a warm-up that compiles the
kernels) and the volumes' sum, which must agree to the bit between the two trees.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
import warnings

import numpy as np
from shared_data import add_data_options, data_or_skip

GRASP = "barrett-grasps/noise/spray_bottle_base.json"
SCENES = {
    "spray": GRASP,
    "cereal": "barrett-grasps/grasps/obj5_sub4_grasp1_optimal0_target.json",
    "messy": None,
}


def messy_grasp(folder):
    """The messy-hand benchmark's hand (`messy_hand.write_hand`) with the built-in bottle
    pushed 2 cm into its palm (a sphere of 5 cm at the origin)."""
    from messy_hand import write_hand

    import exactgrasp as eg

    path, _ = write_hand(folder)
    hand = eg.Hand.from_mjcf(path, frame=eg.HandFrame.identity())
    place = np.eye(4)
    place[:3, 3] = (0.0, 0.0, 0.07)
    return eg.Grasp(hand, eg.objects.get("bottle_with_handle"), place, name="messy")


def scene_and_poses(args):
    """The grasp of ``args.scene`` and every distinct pose of the balanced preset (k, 4, 4),
    or None where the scene's shared data is missing (a message says so)."""
    needed = SCENES[args.scene]
    data = data_or_skip(args, needed) if needed else None
    if needed and data is None:
        return None
    warnings.simplefilter("ignore")
    import exactgrasp as eg
    from exactgrasp.backends.base import repeated_poses
    from exactgrasp.paths.presets import as_sampler

    if needed:
        grasp = eg.Grasp.from_file(data / needed)
    else:
        import tempfile
        from pathlib import Path

        with tempfile.TemporaryDirectory() as tmp:
            grasp = messy_grasp(Path(tmp))
    poses = as_sampler(None).poses().reshape(-1, 4, 4)
    return grasp, poses[np.sort(np.unique(repeated_poses(poses), return_index=True)[1])]


def time_pieces(intersector, poses: np.ndarray, pieces: int, label: str) -> None:
    """Print the kernel's wall seconds over ``poses`` in one call, in ``pieces`` runs of
    neighbouring poses and in ``pieces`` interleaved sets (every ``pieces``-th pose), each
    the best of 3, in local coordinates as the intersector moves them."""
    local = poses.copy()
    local[:, :3, 3] += local[:, :3, :3] @ intersector.origin - intersector.origin
    n = len(local)
    ways = {
        "one call": [np.arange(n)],
        "runs": np.array_split(np.arange(n), pieces),
        "interleaved": [np.arange(k, n, pieces) for k in range(pieces)],
    }
    best = {}
    for _ in range(3):
        for way, parts in ways.items():
            start = time.perf_counter()
            for ix in parts:
                intersector._kernel(local[ix], intersector.capacity, False)
            best[way] = min(best.get(way, np.inf), time.perf_counter() - start)
    print(label, ", ".join(f"{way} {t:.3f} s" for way, t in best.items()))


def machine_speed_up(args) -> int:
    """Run this benchmark (``--repeat`` timings) in one process, then in two processes whose
    timings start at the same moment; print the median ms a pose of each, and twice the
    first over the mean of the two: the machine's own speed-up of two cores on this kernel."""
    command = [sys.executable, __file__, "--scene", args.scene, "--repeat", str(args.repeat)]
    command += ["--label", "p"]
    command += ["--data", str(args.data)] if args.data else []

    def medians(count: int) -> list[float]:
        start = str(time.time() + 40.0)  # after every process has loaded its scene
        runs = [
            subprocess.Popen([*command, "--start-at", start], stdout=subprocess.PIPE, text=True)
            for _ in range(count)
        ]
        lines = [run.communicate()[0].strip().splitlines()[-1] for run in runs]
        # "p <poses> <timings> ms a pose; volumes' sum <sum>"
        return [float(np.median([float(t) for t in line.split()[2:-6]])) for line in lines]

    alone, both = medians(1)[0], medians(2)
    print(
        f"{args.scene}: one process alone {alone:.4f} ms a pose, two at once "
        f"{both[0]:.4f} and {both[1]:.4f}: the machine's two-core speed-up "
        f"x{2 * alone / float(np.mean(both)):.2f}"
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", default="this tree")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scene", choices=sorted(SCENES), default="spray")
    ap.add_argument(
        "--threads", action="store_true",
        help="also time the poses on two threads (n_jobs=2) against one, wall clock, alternating",
    )  # fmt: skip
    ap.add_argument(
        "--pieces", type=int, default=0,
        help="also time the kernel over the poses in one call, in that many runs of "
        "neighbouring poses, and in that many interleaved sets (one thread, best of 3)",
    )  # fmt: skip
    ap.add_argument(
        "--machine", action="store_true",
        help="only run this benchmark in one process alone, then in two at once: the "
        "machine's own speed-up of two cores on this kernel (what threads cannot pass)",
    )  # fmt: skip
    ap.add_argument("--start-at", type=float, default=0.0, help=argparse.SUPPRESS)
    add_data_options(ap)
    args = ap.parse_args(argv)
    if args.machine:
        return machine_speed_up(args)
    scene = scene_and_poses(args)
    if scene is None:
        return 0
    grasp, poses = scene
    from exactgrasp.backends.exact import ExactBackend

    backend = ExactBackend(broadphase=None, n_jobs=1)
    backend.volumes(grasp, poses[:50])
    while time.time() < args.start_at:
        time.sleep(0.01)
    times = []
    for _ in range(args.repeat):
        start = time.process_time()
        volumes = backend.volumes(grasp, poses)
        times.append((time.process_time() - start) * 1e3 / len(poses))
    print(
        args.label, len(poses), " ".join(f"{t:.3f}" for t in times), "ms a pose;",
        f"volumes' sum {float(volumes.sum())!r}",
    )  # fmt: skip
    if args.pieces:
        time_pieces(backend.intersector(grasp), poses, args.pieces, args.label)
    if args.threads:
        two = ExactBackend(broadphase=None, n_jobs=2)
        two.volumes(grasp, poses[:50])
        walls = {1: [], 2: []}
        for _ in range(args.repeat):
            for jobs, b in ((1, backend), (2, two)):
                start = time.perf_counter()
                got = b.volumes(grasp, poses)
                walls[jobs].append(time.perf_counter() - start)
                assert np.array_equal(got, volumes)
        one, both = (float(np.median(walls[j])) for j in (1, 2))
        print(args.label, f"wall one thread {one:.3f} s, two {both:.3f} s: x{one / both:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
