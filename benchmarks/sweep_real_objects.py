"""The exact backend against the plain boolean on the authors' real objects, near-touching
poses included.

Scenes: the spray-bottle grasp (``barrett-grasps/noise/spray_bottle_base.json``, the authors'
Barrett URDF) with its own bottle, and with each other object of ``osu-objects/*.STL``
(millimetres; an open mesh is repaired) put where the bottle is (its bounding box's centre on
the bottle's). Poses, each scene: a seeded subsample of the balanced preset, and near-touching
poses: along some of the preset's paths, the times where the exact volume turns from 0 to
positive, bisected to about 1e-13 in time (the last pose reading 0 and the first reading more).
The exact volumes (`ExactIntersector`, broad phase None, and coal, which must agree bit for
bit) are compared with `plain_volumes` (manifold3d unions and one boolean a pose) on every
near-touching pose and on some of the others.

Reported per scene and in all: poses, poses whose volume was within the kernel's bound of zero
and was computed again from the exact arrangement, poses against the reference, poses farther
from it than the kernel's bound plus the reference's own error (1e-9 relative plus
manifold3d's tolerance times both areas, four times over), non-zero volumes failing `agrees`,
zeros where the reference is positive (overlaps within the scene's rounding) with the largest
such reference
over the hand's volume, the largest relative difference among non-zero volumes, NaN or
negative volumes, and whether the two broad phases agree.

    python benchmarks/sweep_real_objects.py [--poses 300] [--paths 12] [--reference 30]
                                            [--seed 0] [--json results.json]

Needs the shared data folder (``$EXACTGRASP_DATA``, else ``../shared/data`` beside the
repository; ``--data`` elsewhere); skips with a message when it is absent.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from shared_data import add_data_options, data_or_skip  # noqa: E402

from exactgrasp import Grasp, Solid  # noqa: E402
from exactgrasp.backends.exact import (  # noqa: E402
    ExactIntersector,
    agrees,
    plain_error,
    plain_volumes,
)
from exactgrasp.errors import MeshError  # noqa: E402
from exactgrasp.geometry.se3 import exp_se3  # noqa: E402
from exactgrasp.paths.sampler import PathSampler  # noqa: E402

GRASP = "barrett-grasps/noise/spray_bottle_base.json"
#: Path times scanned for a change from 0 to a positive volume, and the bisection's steps.
SCAN_TIMES = np.linspace(-1.0, 1.0, 21)
BISECTIONS = 44


def read_object(path: Path) -> Solid:
    """An authors' object in millimetres, repaired where it is not closed."""
    try:
        return Solid.from_file(path, units="mm")
    except MeshError as exc:
        if "not a closed surface" not in str(exc):
            raise
        return Solid.from_file(path, units="mm", repair=True)


def scenes(data: Path) -> list[tuple[str, Grasp]]:
    """The spray-bottle grasp, then each other object at the bottle's place."""
    base = Grasp.from_file(data / GRASP)
    out = [("SprayBottle (its own grasp)", base)]
    bottle = base.object.vertices
    centre = 0.5 * (bottle.min(0) + bottle.max(0))
    for path in sorted((data / "osu-objects").glob("*.STL")):
        if path.stem == "SprayBottle":
            continue
        solid = read_object(path)
        shift = np.eye(4)
        shift[:3, 3] = centre - 0.5 * (solid.vertices.min(0) + solid.vertices.max(0))
        out.append((path.stem, Grasp(base.hand, solid, base.object_pose @ shift, name=path.stem)))
    return out


def near_touching(ex: ExactIntersector, omega: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Poses (k, 4, 4) on both sides of each time, along each path (omega, direction (n, 3)),
    where the volume turns from 0 to positive, outward from t = 0."""
    n, m = len(omega), len(SCAN_TIMES)
    t = np.tile(SCAN_TIMES, n)
    scan = ex.volumes(
        exp_se3(np.repeat(omega, m, 0) * t[:, None], np.repeat(direction, m, 0) * t[:, None])
    )
    scan = scan.reshape(n, m) > 0
    zero, kept, which = [], [], []
    middle = m // 2
    for k in range(n):
        for step in (1, -1):
            j = middle
            while 0 <= j + step < m and scan[k, j] == scan[k, j + step]:
                j += step
            if 0 <= j + step < m:
                a, b = SCAN_TIMES[j], SCAN_TIMES[j + step]
                zero.append(b if scan[k, j] else a)
                kept.append(a if scan[k, j] else b)
                which.append(k)
    if not which:
        return np.zeros((0, 4, 4))
    zero, kept, which = np.array(zero), np.array(kept), np.array(which)
    for _ in range(BISECTIONS):
        mid = 0.5 * (zero + kept)
        positive = (
            ex.volumes(exp_se3(omega[which] * mid[:, None], direction[which] * mid[:, None])) > 0
        )
        kept = np.where(positive, mid, kept)
        zero = np.where(positive, zero, mid)
    times = np.concatenate([zero, kept])
    paths = np.concatenate([which, which])
    return exp_se3(omega[paths] * times[:, None], direction[paths] * times[:, None])


def sweep(name: str, grasp: Grasp, args: argparse.Namespace, rng: np.random.Generator) -> dict:
    """One scene's figures (see the module)."""
    clock = time.perf_counter()
    hand, obj = grasp.canonical_hand_links(), grasp.canonical_object_bodies()
    ex = ExactIntersector(hand, obj, broadphase=None, n_jobs=1)
    sampler = PathSampler.preset("balanced")
    every = sampler.poses().reshape(-1, 4, 4)
    sampled = every[rng.choice(len(every), args.poses, replace=False)]
    table = sampler.paths
    paths = rng.choice(len(table.direction), args.paths, replace=False)
    near = near_touching(ex, table.omega[paths], table.direction[paths])
    poses = np.concatenate([sampled, near])
    result = ex.intersect(poses)
    got, bounds = result.volumes, result.volume_bounds
    coal = ExactIntersector(hand, obj, broadphase="coal", n_jobs=1).volumes(poses)
    checked = np.concatenate(
        [rng.choice(len(sampled), min(args.reference, len(sampled)), replace=False),
         len(sampled) + np.arange(len(near))]
    )  # fmt: skip
    want = plain_volumes(hand, obj, poses[checked])
    size = max(float(np.abs(V).max()) for V, _ in hand + obj)
    allowed = bounds[checked] + plain_error(want, size, ex.areas)
    mine = got[checked]
    nonzero = mine != 0
    banded = (mine == 0) & (want > 0)
    rel = np.abs(mine - want)[nonzero] / np.abs(want)[nonzero]
    return {
        "scene": name,
        "poses": len(poses),
        "near_touching": len(near),
        "arranged": int(result.stats["poses_arranged"]),
        "against_reference": len(checked),
        "beyond_bound": int((~(np.abs(mine - want) <= allowed)).sum()),
        "nonzero_failing_agrees": int(
            (~agrees(mine[nonzero], want[nonzero], ex.hand_volume)).sum()
        ),
        "zeros_reference_positive": int(banded.sum()),
        "largest_such_over_hand": float(want[banded].max() / ex.hand_volume)
        if banded.any()
        else 0.0,
        "largest_relative_nonzero": float(rel.max()) if len(rel) else 0.0,
        "nan_or_negative": int((~(got >= 0)).sum()),
        "broad_phases_identical": bool(np.array_equal(got, coal)),
        "seconds": time.perf_counter() - clock,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=300, help="preset poses a scene (subsample)")
    ap.add_argument("--paths", type=int, default=12, help="paths bisected a scene")
    ap.add_argument("--reference", type=int, default=30, help="subsampled poses compared")
    ap.add_argument("--seed", type=int, default=0)
    add_data_options(ap)
    args = ap.parse_args(argv)
    data = data_or_skip(args, GRASP)
    if data is None:
        return 0
    rng = np.random.default_rng(args.seed)
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the objects' repair and shell notes
        all_scenes = scenes(data)
    for name, grasp in all_scenes:
        row = sweep(name, grasp, args, rng)
        rows.append(row)
        print(
            f"{name:28s} poses {row['poses']:5d} (near-touching {row['near_touching']:3d}, "
            f"arranged exactly {row['arranged']:3d}), "
            f"vs reference {row['against_reference']:3d}: beyond bound {row['beyond_bound']}, "
            f"non-zero failing agrees {row['nonzero_failing_agrees']}, zeros where the "
            f"reference is positive {row['zeros_reference_positive']} (largest "
            f"{row['largest_such_over_hand']:.2g} of the hand), largest relative "
            f"{row['largest_relative_nonzero']:.2g}, NaN/negative {row['nan_or_negative']}, "
            f"broad phases identical {row['broad_phases_identical']}, {row['seconds']:.0f} s",
            flush=True,
        )
    total = {k: sum(r[k] for r in rows) for k in ("poses", "near_touching", "arranged",
             "against_reference", "beyond_bound", "nonzero_failing_agrees",
             "zeros_reference_positive", "nan_or_negative")}  # fmt: skip
    total["largest_such_over_hand"] = max(r["largest_such_over_hand"] for r in rows)
    total["largest_relative_nonzero"] = max(r["largest_relative_nonzero"] for r in rows)
    total["broad_phases_identical"] = all(r["broad_phases_identical"] for r in rows)
    print(f"all {len(rows)} scenes: " + ", ".join(f"{k} {v}" for k, v in total.items()))
    if args.json:
        args.json.write_text(json.dumps({"scenes": rows, "all": total}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
