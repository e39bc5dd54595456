"""Benchmark: exact penetration volumes of real hand-object pairs against voxel counts.

For real Barrett-hand grasps in contact or penetrating (``../shared/data``): the exact volume
of hand ∩ object (`exactgrasp.intersection_volume`) and its certified bound, manifold3d's
boolean of the same solids, and the common voxel-count estimate: the object voxelised at a
pitch (voxel centres inside the object), the centres inside the hand counted, times pitch^3,
at 5 mm and 2 mm, once on a grid anchored at the object's bounding box and on ``--offsets``
grids shifted by random fractions of a voxel. Timings (median of ``--repeat`` runs): one
exact call against one manifold3d boolean (both from the validated solids, building their
own structures), and per pose over a stack of ``--stack`` nearby poses.

Cases: four cereal-box contact grasps (``barrett-grasps/grasps``, intersection 0 as given)
and the spray-bottle grasp (``noise/spray_bottle_base.json``) with the object pushed 1, 2
and 5 mm towards the palm (-z in the hand frame), and the first recorded study grasp
(``study-records``, raw, penetrating) of every closed object.

    python benchmarks/penetration.py [--repeat 3] [--offsets 8] [--stack 256] [--json out.json]

Needs the shared data folder (``$EXACTGRASP_DATA``, else ``../shared/data`` beside the
repository); skips with a message when it is absent.
"""

from __future__ import annotations

import argparse
import datetime
import json
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from exactgrasp.datapath import data_dir  # noqa: E402

DATA = data_dir()
PUSHED = (
    "barrett-grasps/grasps/obj5_sub4_grasp1_optimal0_target.json",
    "barrett-grasps/grasps/obj5_sub5_grasp5_optimal0_target.json",
    "barrett-grasps/grasps/obj5_sub6_grasp1_optimal0_target.json",
    "barrett-grasps/grasps/obj5_sub6_grasp3_optimal0_target.json",
    "barrett-grasps/noise/spray_bottle_base.json",
)
PUSH_MM = (1.0, 2.0, 5.0)
#: FoodClip.STL is not closed (see the data's README); every other object is.
OPEN_OBJECTS = ("FoodClip",)
PITCHES_MM = (5.0, 2.0)


def translation(x: float, y: float, z: float) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = (x, y, z)
    return pose


def load(path: Path):
    """A grasp file as (hand Solid: the 9 links as one merged mesh, object Solid, pose)."""
    from exactgrasp.grasp import Grasp
    from exactgrasp.overlap import as_solid

    grasp = Grasp.from_file(path)
    with warnings.catch_warnings():
        # The links overlap: the intake merges them into their union, with a warning.
        warnings.simplefilter("ignore")
        hand = as_solid(trimesh.util.concatenate(grasp.hand.link_meshes()), "hand")
    return hand, grasp.object, grasp.object_pose


def cases() -> list[dict]:
    """Every case: name, group, grasp file, pose of the object in the hand (4, 4)."""
    out = []
    for rel in PUSHED:
        path = DATA / rel
        for mm in PUSH_MM:
            out.append(
                {"name": f"{path.stem} +{mm:g} mm", "group": "pushed", "file": path, "push_mm": mm}
            )
    records = DATA / "barrett-grasps" / "study-records"
    for folder in sorted(p for p in records.iterdir() if p.is_dir()):
        if folder.name in OPEN_OBJECTS:
            continue
        first = sorted(folder.glob("*.json"))[0]
        out.append(
            {
                "name": f"{folder.name} {first.stem}",
                "group": "recorded",
                "file": first,
                "push_mm": 0.0,
            }
        )
    return out


def voxel_count(hand, obj, pose: np.ndarray, pitch: float, shift: np.ndarray) -> float:
    """The voxel-count estimate of hand ∩ (obj moved by pose), m^3.

    Voxel centres ``lo + (i + shift) * pitch`` over the object's bounding box (``lo`` its
    minimum corner, object frame); those inside the object (winding number >= 1) and inside
    the hand (mapped into the object's frame) are counted, times pitch^3.
    """
    from exactgrasp.geometry.winding import winding_inside_lattice

    lo = obj.vertices.min(0)
    n = np.ceil((obj.vertices.max(0) - lo) / pitch).astype(int) + 2

    def lattice(points: np.ndarray) -> np.ndarray:
        # Node k of the lattice is centre k - 1 (one extra layer below the box).
        return np.ascontiguousarray((points - lo) / pitch - shift + 1.0)

    R, t = pose[:3, :3], pose[:3, 3]
    hand_in_object = (hand.vertices - t) @ R
    inside_obj = winding_inside_lattice(lattice(obj.vertices)[obj.faces], *n)
    inside_hand = winding_inside_lattice(lattice(hand_in_object)[hand.faces], *n)
    return float(np.count_nonzero(inside_obj & inside_hand)) * pitch**3


def median_time(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def nearby_poses(pose: np.ndarray, count: int, rng) -> np.ndarray:
    """``count`` rigid poses within 2 mm and 2 degrees of ``pose`` (about the hand origin)."""
    from scipy.spatial.transform import Rotation

    out = np.tile(np.eye(4), (count, 1, 1))
    out[:, :3, :3] = Rotation.from_rotvec(
        rng.uniform(-1, 1, (count, 3)) * np.radians(2) / 3**0.5
    ).as_matrix()
    out[:, :3, 3] = rng.uniform(-0.002, 0.002, (count, 3))
    return out @ pose


def run_case(case: dict, args, rng) -> dict:
    from exactgrasp.geometry.manifold import to_manifold
    from exactgrasp.overlap import intersection

    hand, obj, pose = load(case["file"])
    pose = translation(0, 0, -0.001 * case["push_mm"]) @ pose
    exact_s, result = median_time(lambda: intersection(hand, obj, pose), args.repeat)
    volume, bound = result.volumes, result.bounds

    def boolean() -> float:
        moved = to_manifold(obj.vertices, obj.faces, "object").transform(pose[:3, :])
        return (to_manifold(hand.vertices, hand.faces, "hand") ^ moved).volume()

    boolean_s, reference = median_time(boolean, args.repeat)
    row = {
        "name": case["name"],
        "group": case["group"],
        "push_mm": case["push_mm"],
        "exact_m3": volume,
        "bound_m3": bound,
        "boolean_m3": reference,
        "exact_vs_boolean": abs(volume - reference) / volume if volume else abs(reference),
        "exact_s": exact_s,
        "boolean_s": boolean_s,
    }
    for mm in PITCHES_MM:
        pitch = 0.001 * mm
        aligned = voxel_count(hand, obj, pose, pitch, np.full(3, 0.5))
        shifted = [voxel_count(hand, obj, pose, pitch, rng.random(3)) for _ in range(args.offsets)]
        row[f"voxel{mm:g}_m3"] = aligned
        row[f"voxel{mm:g}_rel"] = (aligned - volume) / volume if volume else float("nan")
        row[f"voxel{mm:g}_shifted_rel"] = (
            [(v - volume) / volume for v in shifted] if volume else []
        )
    return row


def stack_timing(case: dict, args, rng) -> dict:
    """One exact call over a stack of nearby poses against one boolean per pose.

    The call's fixed cost (the intersector's unions and grids) is what a one-pose call
    costs; what each further pose adds is ``(stack call - one-pose call) / (poses - 1)``.
    """
    from exactgrasp.backends.exact import ExactBackend
    from exactgrasp.geometry.manifold import to_manifold
    from exactgrasp.overlap import intersection_volume

    hand, obj, pose = load(case["file"])
    poses = nearby_poses(translation(0, 0, -0.001 * case["push_mm"]) @ pose, args.stack, rng)
    plain, bvh = ExactBackend(broadphase=None, n_jobs=1), ExactBackend(n_jobs=1)
    one_s, _ = median_time(lambda: intersection_volume(hand, obj, poses[0], plain), args.repeat)
    one_bvh_s, _ = median_time(lambda: intersection_volume(hand, obj, poses[0], bvh), args.repeat)
    stack_s, volumes = median_time(lambda: intersection_volume(hand, obj, poses, bvh), args.repeat)
    A = to_manifold(hand.vertices, hand.faces, "hand")
    B = to_manifold(obj.vertices, obj.faces, "object")
    boolean_s, reference = median_time(
        lambda: np.array([(A ^ B.transform(p[:3, :])).volume() for p in poses]), args.repeat
    )
    floor = 1e-6 * min(hand.volume, obj.volume)
    diff = np.abs(volumes - reference) / np.maximum(reference, floor)
    return {
        "name": case["name"],
        "poses": len(poses),
        "exact_one_s": one_s,
        "exact_one_coal_s": one_bvh_s,
        "exact_stack_s": stack_s,
        "exact_s_per_extra_pose": (stack_s - one_s) / (len(poses) - 1),
        "boolean_s_per_pose": boolean_s / len(poses),
        "max_rel_diff": float(diff.max()),
    }


def fmt_rel(x: float) -> str:
    return f"{100 * x:+.1f} %"


GROUPS = (
    ("pushed", "contact grasps pushed 1-5 mm"),
    ("recorded", "recorded study grasps"),
)


def report(rows: list[dict], stacks: list[dict], args, started: str) -> str:
    lines = [
        f"python benchmarks/penetration.py --repeat {args.repeat} --offsets {args.offsets} "
        f"--stack {args.stack} --seed {args.seed}",
        f"run {started} UTC",
        "",
        "| case | push | exact (mm^3) | bound (mm^3) | rel. diff to boolean | voxel 5 mm | "
        "voxel 2 mm | exact call (s) | boolean (s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        push = f"{r['push_mm']:g} mm" if r["group"] == "pushed" else "as recorded"
        lines.append(
            f"| {r['name']} | {push} | {1e9 * r['exact_m3']:.4f} | {1e9 * r['bound_m3']:.1e} | "
            f"{r['exact_vs_boolean']:.1e} | {fmt_rel(r['voxel5_rel'])} | "
            f"{fmt_rel(r['voxel2_rel'])} | {r['exact_s']:.3f} | {r['boolean_s']:.3f} |"
        )
    lines += [
        "",
        "| cases | voxel pitch | grid | estimates | reads 0 | median abs. rel. error | worst |",
        "|---|---|---|---|---|---|---|",
    ]
    for group, title in GROUPS:
        mine = [r for r in rows if r["group"] == group]
        for mm in PITCHES_MM:
            anchored = [r[f"voxel{mm:g}_rel"] for r in mine]
            shifted = [e for r in mine for e in r[f"voxel{mm:g}_shifted_rel"]]
            for label, errs in (
                ("anchored", anchored),
                (f"{args.offsets} random shifts per case", shifted),
            ):
                zeros = sum(e == -1.0 for e in errs)
                errs = [abs(e) for e in errs]
                lines.append(
                    f"| {title} | {mm:g} mm | {label} | {len(errs)} | {zeros} | "
                    f"{100 * statistics.median(errs):.1f} % | {100 * max(errs):.1f} % |"
                )
    lines += [
        "",
        "| case | poses | exact, 1 pose (s) | same, coal BVH built (s) | exact, all poses (s) | "
        "exact per extra pose (s) | boolean per pose (s) | max rel. diff |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in stacks:
        lines.append(
            f"| {s['name']} | {s['poses']} | {s['exact_one_s']:.3f} | "
            f"{s['exact_one_coal_s']:.3f} | {s['exact_stack_s']:.3f} | "
            f"{s['exact_s_per_extra_pose']:.4f} | {s['boolean_s_per_pose']:.4f} | "
            f"{s['max_rel_diff']:.1e} |"
        )
    ex = [r["exact_s"] for r in rows]
    bo = [r["boolean_s"] for r in rows]
    lines += [
        "",
        f"one pose per call: exact median {statistics.median(ex):.3f} s (max {max(ex):.3f}), "
        f"boolean median {statistics.median(bo):.3f} s (max {max(bo):.3f}); "
        f"max exact-vs-boolean rel. diff {max(r['exact_vs_boolean'] for r in rows):.1e}, "
        f"max bound / volume {max(r['bound_m3'] / r['exact_m3'] for r in rows):.1e}",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="timed runs; the median is reported")
    ap.add_argument("--offsets", type=int, default=8, help="shifted voxel grids per case")
    ap.add_argument("--stack", type=int, default=256, help="poses in the per-pose timing")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None, help="also write the rows to this file")
    args = ap.parse_args(argv)
    if not (DATA / "barrett-grasps").is_dir():
        print(f"skipped: shared data not found at {DATA.resolve()} (set EXACTGRASP_DATA)")
        return 0
    from exactgrasp.overlap import intersection_volume

    started = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M")
    rng = np.random.default_rng(args.seed)
    # Compile (or load) the kernels before anything is timed.
    cube = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    intersection_volume(cube, cube, translation(0.05, 0.03, 0.01))
    all_cases = cases()
    rows = []
    for case in all_cases:
        rows.append(run_case(case, args, rng))
        print(f"{case['name']}: exact {rows[-1]['exact_m3']:.6e} m^3", file=sys.stderr)
    picks = [all_cases[0], all_cases[3 * (len(PUSHED) - 1) + 1], all_cases[-1]]
    stacks = [stack_timing(case, args, rng) for case in picks]
    text = report(rows, stacks, args, started)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "stacks": stacks}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
