"""Fuzz run of the exact backend against independent references.

Runs the generators of ``tests/test_adversarial.py`` (box solids in contact with exact
rational references, non-convex, multi-shell, hollow, overlapping-shell and sliver solids
against manifold3d, convex pairs against scipy's half-space intersection), each case also
moved far from the origin or scaled by 1e2 / 1e-3 now and then, and reports the poses where
`ExactIntersector` disagrees with the reference (the rule of `exact.agrees`: 1e-9 relative,
floor 1e-6 of the hand volume), negative volumes, poses that fell back to the boolean, culled
poses, and poses where broadphase None and coal differ.

    python benchmarks/fuzz_exact.py [--cases 600] [--seed 0] [--json fuzz.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from test_adversarial import (  # noqa: E402
    SCALES,
    SCENES,
    far_variant,
    is_rational,
    mismatches,
    reference,
    reference_error,
    run_exact,
)


def make_cases(category: str, seed: int):
    """The scenes of a case with their references, (label, scene, reference volumes, hand
    volume): the generated scene, the same moved 10-1000 units from the origin, and scaled by
    one of 1e2, 1e-3, 2**7, 2**-10 (not for convex pairs, whose reference is computed
    directly)."""
    rng = np.random.default_rng(seed)
    scene = SCENES[category](rng)
    exact = scene.name.startswith("box world")
    want, hv = reference(scene)
    yield "origin", scene, want, hv
    if scene.name.startswith("convex"):
        return
    yield "far", far_variant(rng, scene, exact), want, hv
    s = float(rng.choice(SCALES))
    scaled = scene.moved(s, np.zeros(3))
    if exact:
        yield "scaled", scaled, *reference(scaled)
    else:
        yield "scaled", scaled, want * s**3, hv * s**3


def record(report, category, case, scene, got, plain, want, ex) -> None:
    """Add one scene's results to the report: a mismatch is a pose farther from the
    reference than the backend's own bound (`volume_bounds`) plus the reference's error."""
    n = len(got)
    stats = ex.stats
    report["scenes"] += 1
    report["poses"] += n
    cat = report["per_category"][category]
    cat["poses"] += n
    report["poses_limit"] += stats["poses_limit"]
    report["poses_culled"] += stats["poses_culled"]
    exact = is_rational(scene)
    report["poses_rational"] += n if exact else 0
    allowed = ex.volume_bounds + reference_error(scene, want, exact)
    for k in np.flatnonzero(~(np.abs(got - want) <= allowed)):
        cat["mismatching_poses"] += 1
        report["mismatches"].append(
            {
                "case": case,
                "category": category,
                "scene": scene.name,
                "pose_index": int(k),
                "pose": scene.poses[k].tolist(),
                "source": str(ex.pose_sources[k]),
                "value": float(got[k]),
                "reference": float(want[k]),
                "error": float(abs(got[k] - want[k])),
                "allowed": float(allowed[k]),
            }
        )
    for k in np.flatnonzero(got < 0):
        report["negative"].append(
            {"case": case, "scene": scene.name, "pose_index": int(k), "value": float(got[k])}
        )
    for k in np.flatnonzero(got != plain):
        report["broadphase_differences"].append(
            {
                "case": case,
                "scene": scene.name,
                "pose_index": int(k),
                "coal": float(got[k]),
                "none": float(plain[k]),
            }
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=600)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default="fuzz_exact.json", help="where to write the results")
    args = ap.parse_args(argv)

    categories = sorted(SCENES)
    t0 = time.perf_counter()
    report = {
        "cases": 0,
        "scenes": 0,
        "poses": 0,
        "mismatches": [],
        "negative": [],
        "broadphase_differences": [],
        "errors": [],
        "poses_limit": 0,
        "poses_culled": 0,
        "poses_rational": 0,
        "per_category": {c: {"cases": 0, "poses": 0, "mismatching_poses": 0} for c in categories},
    }
    for i in range(args.cases):
        category = categories[i % len(categories)]
        seed = args.seed * 1_000_003 + i
        report["cases"] += 1
        report["per_category"][category]["cases"] += 1
        try:
            cases = list(make_cases(category, seed))
        except Exception as exc:  # a generator or reference failure is reported, not fatal
            report["errors"].append(
                {"case": f"make_cases({category!r}, {seed})", "error": repr(exc)}
            )
            traceback.print_exc(limit=2)
            continue
        for variant, scene, want, _hv in cases:
            case = f"make_cases({category!r}, {seed}) [{variant}]"
            try:
                got, ex = run_exact(scene, "coal")
                plain, _ = run_exact(scene, None)
            except Exception as exc:  # a refused input is a finding too
                report["errors"].append({"case": case, "error": f"{type(exc).__name__}: {exc}"})
                traceback.print_exc(limit=2)
                continue
            record(report, category, case, scene, got, plain, want, ex)
            print(
                f"[{i + 1}/{args.cases}] {case}: {scene.name}: {len(got)} poses, "
                f"limit {ex.stats['poses_limit']}, culled {ex.stats['poses_culled']}",
                flush=True,
            )
            for line in mismatches(scene, got, want, ex.volume_bounds, is_rational(scene)):
                print("    MISMATCH", line, flush=True)
    report["seconds"] = time.perf_counter() - t0
    report["args"] = vars(args)

    print()
    print(
        f"cases {report['cases']}, scenes {report['scenes']}, poses {report['poses']}, "
        f"{report['seconds']:.0f} s"
    )
    print(
        f"mismatching poses {len(report['mismatches'])}, negative volumes "
        f"{len(report['negative'])}, broadphase differences "
        f"{len(report['broadphase_differences'])}, errors {len(report['errors'])}"
    )
    print(
        f"limits {report['poses_limit']}, culled poses {report['poses_culled']}, "
        f"poses with a rational reference {report['poses_rational']}"
    )
    for c, v in report["per_category"].items():
        print(
            f"  {c:20s} cases {v['cases']:4d} poses {v['poses']:5d} "
            f"mismatching {v['mismatching_poses']}"
        )
    worst = sorted(report["mismatches"], key=lambda m: -m["error"] / m["allowed"])[:10]
    for m in worst:
        print(
            f"  worst: {m['case']} pose {m['pose_index']} ({m['source']}): {m['value']!r} vs "
            f"{m['reference']!r} (error {m['error']:.3g}, allowed {m['allowed']:.3g})"
        )
    Path(args.json).write_text(json.dumps(report, indent=1))
    print(f"written {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
