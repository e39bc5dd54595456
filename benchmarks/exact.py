"""Benchmark of the exact backend on the real Barrett-hand grasps.

For each grasp: seconds per descriptor (all poses; those equal to another to rounding, the
"repeats", are computed once), share of poses and hand parts culled, and
the plain loop (one manifold3d boolean of the whole hand and the whole object per pose) timed
in the same run on a subsample of poses, with the largest relative difference between the two.
Both timings are the median of ``--repeat`` runs (3 by default; this machine's speed drifts by
up to 20 % from one run to the next), the two alternating.

    python benchmarks/exact.py [--poses-subsample 40] [--n-jobs 2] [--broadphase coal]
                               [--repeat 3] [--json results.json]

Needs the shared data folder (``$EXACTGRASP_DATA``, else ``../shared/data`` beside the
repository); skips with a message when it is absent.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from exactgrasp.datapath import data_dir  # noqa: E402

DATA = data_dir()
GRASPS = (
    "barrett-grasps/noise/spray_bottle_base.json",
    "barrett-grasps/grasps/obj5_sub4_grasp1_optimal0_target.json",
    "barrett-grasps/grasps/obj5_sub5_grasp5_optimal0_target.json",
)


def load_grasp(path: Path):
    """A real grasp through the library's loaders: (grasp, hand links, object bodies).

    Links and bodies are lists of (V (n, 3) float64, F (m, 3) int64) in the canonical frame
    (the paper's: grasp centre at the origin, half-depth 1), as every backend sees them.
    """
    from exactgrasp import Grasp

    grasp = Grasp.from_file(path)
    return grasp, grasp.canonical_hand_links(), grasp.canonical_object_bodies()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--poses-subsample",
        type=int,
        default=40,
        help="poses timed with the plain loop (default 40)",
    )
    ap.add_argument("--n-jobs", type=int, default=2)
    ap.add_argument(
        "--repeat", type=int, default=3, help="runs timed of each loop; the median is reported"
    )
    ap.add_argument("--broadphase", default="coal", choices=["coal", "fcl", "none"])
    ap.add_argument(
        "--grasps",
        nargs="*",
        default=list(GRASPS),
        help=f"grasp JSON files relative to the shared data folder ({DATA})",
    )
    ap.add_argument("--json", type=Path, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"skipped: real data not found at {DATA.resolve()} (set EXACTGRASP_DATA)")
        return 0
    sys.path.insert(0, str(ROOT))
    from exactgrasp.backends.exact import ExactIntersector, agrees, plain_volumes
    from exactgrasp.paths.sampler import PathSampler

    flat = PathSampler.preset("balanced").poses().reshape(-1, 4, 4)
    kind = "balanced preset"
    print(
        f"poses: {kind}, {len(flat)} per descriptor; n_jobs={args.n_jobs}, "
        f"broadphase={args.broadphase}"
    )
    header = (
        "grasp",
        "hand tri",
        "obj tri",
        "build s",
        "s/descr",
        "repeats",
        "poses culled",
        "parts culled",
        "parts inside",
        "parts clipped",
        "booleans",
        "plain s/pose",
        "speed-up",
        "max rel diff",
        "agree 1e-9",
    )
    rows = []
    records = []
    sub = np.random.default_rng(0).choice(
        len(flat), min(args.poses_subsample, len(flat)), replace=False
    )
    for rel in args.grasps:
        _, links, bodies = load_grasp(DATA / rel)
        t0 = time.perf_counter()
        ex = ExactIntersector(
            links,
            bodies,
            broadphase=None if args.broadphase == "none" else args.broadphase,
            n_jobs=args.n_jobs,
        )
        ex.volumes(flat[:2])  # warm caches outside the timing
        build = time.perf_counter() - t0
        exact_runs, plain_runs = [], []
        for _ in range(max(1, args.repeat)):
            t0 = time.perf_counter()
            result = ex.intersect(flat)
            exact_runs.append(time.perf_counter() - t0)
            vol = result.volumes
            t0 = time.perf_counter()
            ref = plain_volumes(links, bodies, flat[sub])
            plain_runs.append((time.perf_counter() - t0) / len(sub))
        per_descr = float(np.median(exact_runs))
        plain = float(np.median(plain_runs))
        st = result.stats
        diff = np.abs(vol[sub] - ref) / np.maximum(np.abs(ref), 1e-300)
        parts = st["parts"] * st["poses"]
        records.append(
            {
                "grasp": rel,
                "seconds_per_descriptor": per_descr,
                "seconds_per_descriptor_runs": exact_runs,
                "plain_seconds_per_pose_runs": plain_runs,
                "build_seconds": build,
                "plain_seconds_per_pose": plain,
                "speedup": plain * len(flat) / per_descr,
                "max_rel_diff": float(diff.max()),
                "agree_1e9": bool(agrees(vol[sub], ref, ex.hand_volume).all()),
                "n_jobs": args.n_jobs,
                "broadphase": args.broadphase,
                **{k: v for k, v in st.items() if k != "seconds"},
            }
        )
        rows.append(
            (
                Path(rel).stem,
                str(sum(len(F) for _, F in links)),
                str(sum(len(F) for _, F in bodies)),
                f"{build:.1f}",
                f"{per_descr:.2f}",
                str(st["poses_repeated"]),
                f"{st['poses_culled'] / st['poses']:.1%}",
                f"{st['parts_culled'] / parts:.1%}",
                f"{st['parts_inside'] / parts:.1%}",
                f"{st['parts_clipped'] / parts:.1%}",
                str(st["poses_limit"]),
                f"{plain:.3f}",
                f"{plain * len(flat) / per_descr:.0f}x",
                f"{diff.max():.1e}",
                str(bool(agrees(vol[sub], ref, ex.hand_volume).all())),
            )
        )
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print("  ".join(h.rjust(w) for h, w in zip(header, widths, strict=True)))
    for r in rows:
        print("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)))
    if args.json:
        args.json.write_text(json.dumps(records, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
