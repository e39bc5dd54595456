"""`separate` against the authors' contact adjustment, and over every raw study record.

Comparison (default): for each of the 34 contact-adjusted cereal-box grasps
(``barrett-grasps/grasps/obj5_*.json``, "theirs") the raw record it was adjusted from
(``study-records/CerealBox/<name less _target/_prime>.json``) is separated with
``separate(raw)``, the library's defaults (``--fingers default``), or with
``separate(raw, fingers=...)`` ("ours"). Per grasp: what was done with the fingers (and, for
``"auto"``, the links found buried), whether ours is in contact, the object-pose difference
ours-theirs and raw-theirs (the object's centroid, mm; the relative rotation, degrees), the
largest joint difference (rad), and the descriptor L2 distance (library defaults: the default
sampler and backend) ours-theirs against raw-theirs. The last line counts the records
separated, in contact, and closer to theirs than the raw record (of all 34: a refused record
counts as not closer). ``--limit N`` and ``--grasps STEM ...`` take a subset.

`compare_method` puts another method beside ``separate`` on the same records, in the same
terms (``python examples/penetration_descent.py --compare``: gradient descent on the exact
volume).

Batch (``--batch``): ``separate`` over every raw record of ``study-records/index.csv`` (or
every N-th, ``--every N``); its success rate (separated and in contact) and seconds per
record, written as it goes. FoodClip's open mesh is repaired on loading.

    python benchmarks/separate_authors.py [--fingers default|auto|keep|reclose] [--no-rotation]
        [--limit N] [--grasps STEM ...] [--json out.json]
    python benchmarks/separate_authors.py --batch [--every N] [--limit N] [--json out.json]

Needs the shared data folder; skips with a message when it is absent. Long because it holds
the three comparisons on the same records and their one set of measures.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
from shared_data import add_data_options, data_or_skip  # noqa: E402

GRASPS = "barrett-grasps/grasps"
RAW = "barrett-grasps/study-records"


def raw_name(adjusted: str) -> str:
    """The raw record's stem of an adjusted grasp's stem (``..._optimal0_target`` ->
    ``..._optimal0``)."""
    for suffix in ("_target", "_prime"):
        if adjusted.endswith(suffix):
            return adjusted[: -len(suffix)]
    return adjusted


def pose_difference(a, b) -> tuple[float, float]:
    """(centroid distance mm, relative rotation degrees) between two grasps' object poses."""
    import numpy as np

    c = a.object.centroid
    pa, pb = a.object_pose, b.object_pose
    d = np.linalg.norm((pa[:3, :3] @ c + pa[:3, 3]) - (pb[:3, :3] @ c + pb[:3, 3]))
    rel = pa[:3, :3].T @ pb[:3, :3]
    cos = min(1.0, max(-1.0, (np.trace(rel) - 1) / 2))
    return float(d * 1e3), math.degrees(math.acos(cos))


def joint_difference(a, b) -> float:
    return max(abs(a.hand.joints[n] - b.hand.joints[n]) for n in a.hand.joint_names)


def adjusted_paths(data: Path, limit: int | None = None, grasps=None) -> list[Path]:
    """The contact-adjusted cereal-box grasps in file-name order: the first ``limit``, or
    those whose stem (with or without ``_target`` / ``_prime``) is in ``grasps``."""
    paths = sorted((data / GRASPS).glob("obj5_*.json"))
    if grasps:
        paths = [p for p in paths if p.stem in grasps or raw_name(p.stem) in grasps]
    return paths[:limit]


def record_pair(path: Path, data: Path):
    """``(raw, theirs)``: the raw record an adjusted grasp was made from, and the adjusted
    grasp of file ``path``."""
    import exactgrasp as eg

    theirs = eg.Grasp.from_file(path)
    raw = eg.Grasp.from_file(data / RAW / "CerealBox" / f"{raw_name(path.stem)}.json")
    return raw, theirs


def against_theirs(ours, raw, theirs, d_raw=None, d_theirs=None) -> dict:
    """How far ``ours`` (a grasp made from the raw record) and the raw record lie from theirs:
    object pose (centroid mm, rotation degrees), largest joint difference (rad) and descriptor
    L2 (library defaults), each as ``ours_theirs_*`` and ``raw_theirs_*``. ``d_raw`` and
    ``d_theirs``: the raw record's and their descriptors, where already computed."""
    import exactgrasp as eg

    d_raw = eg.compute_descriptor(raw) if d_raw is None else d_raw
    d_theirs = eg.compute_descriptor(theirs) if d_theirs is None else d_theirs
    return {
        "ours_theirs_pose": pose_difference(ours, theirs),
        "raw_theirs_pose": pose_difference(raw, theirs),
        "ours_theirs_joint_rad": joint_difference(ours, theirs),
        "raw_theirs_joint_rad": joint_difference(raw, theirs),
        "ours_theirs_l2": eg.distance(eg.compute_descriptor(ours), d_theirs),
        "raw_theirs_l2": eg.distance(d_raw, d_theirs),
    }


def compare_one(path: Path, data: Path, fingers: str, rotation: bool) -> dict:
    """One adjusted grasp's row: its raw record separated (``fingers="default"``: with the
    library's defaults) and compared with it and with the raw record."""
    import exactgrasp as eg

    raw, theirs = record_pair(path, data)
    options = {} if fingers == "default" else {"fingers": fingers}
    t0 = time.perf_counter()
    try:
        result = eg.separate(raw, rotation=rotation, **options)
    except eg.SeparationError as exc:
        return {"grasp": path.stem, "error": str(exc)}
    seconds = time.perf_counter() - t0
    return {
        "grasp": path.stem,
        "seconds": seconds,
        "fingers": result.fingers,
        "buried_links": result.buried_links,
        "in_contact": result.in_contact,
        "moved_mm": result.translation_mm,
        "turned_deg": result.rotation_deg,
        **against_theirs(result.grasp, raw, theirs),
    }


def counts(rows: list[dict]) -> dict[str, int]:
    """Records compared, separated, in contact, and closer to theirs than the raw record
    (descriptor L2; a refused record is not closer); re-closed by the fingers' mode."""
    done = [r for r in rows if "error" not in r]
    return {
        "records": len(rows),
        "separated": len(done),
        "in_contact": sum(bool(r["in_contact"]) for r in done),
        "closer": sum(r["ours_theirs_l2"] < r["raw_theirs_l2"] for r in done),
        "reclosed": sum(r["fingers"] == "reclose" for r in done),
    }


def compare(
    data: Path, fingers: str, rotation: bool, out: Path | None, limit=None, grasps=None
) -> None:
    import numpy as np

    rows = []
    for path in adjusted_paths(data, limit, grasps):
        row = compare_one(path, data, fingers, rotation)
        rows.append(row)
        if "error" in row:
            print(f"{path.stem}: refused: {row['error']}")
            continue
        print(
            f"{path.stem:40s} {row['fingers']} contact={row['in_contact']} moved "
            f"{row['moved_mm']:.2f} mm {row['turned_deg']:.2f} deg; pose vs theirs "
            f"{row['ours_theirs_pose'][0]:.2f} mm {row['ours_theirs_pose'][1]:.2f} deg "
            f"(raw {row['raw_theirs_pose'][0]:.2f} mm "
            f"{row['raw_theirs_pose'][1]:.2f} deg); joints {row['ours_theirs_joint_rad']:.3f} "
            f"(raw {row['raw_theirs_joint_rad']:.3f}) rad; L2 {row['ours_theirs_l2']:.4f} "
            f"(raw {row['raw_theirs_l2']:.4f}); {row['seconds']:.1f} s",
            flush=True,
        )
        if out:
            out.write_text(json.dumps(rows, indent=1))
    if out:
        out.write_text(json.dumps(rows, indent=1))
    done = [r for r in rows if "error" not in r]
    n = counts(rows)
    print(
        f"fingers={fingers}: {n['separated']} of {n['records']} separated "
        f"({n['reclosed']} with the fingers re-closed), {n['in_contact']} in contact; ours "
        f"closer to theirs (descriptor L2) than the raw record in {n['closer']} of "
        f"{n['records']}; mean L2 "
        f"ours {np.mean([r['ours_theirs_l2'] for r in done]):.4f}, raw "
        f"{np.mean([r['raw_theirs_l2'] for r in done]):.4f}; median pose difference ours "
        f"{np.median([r['ours_theirs_pose'][0] for r in done]):.2f} mm "
        f"{np.median([r['ours_theirs_pose'][1] for r in done]):.2f} deg, raw "
        f"{np.median([r['raw_theirs_pose'][0] for r in done]):.2f} mm "
        f"{np.median([r['raw_theirs_pose'][1] for r in done]):.2f} deg; median joint "
        f"difference ours {np.median([r['ours_theirs_joint_rad'] for r in done]):.3f} rad, raw "
        f"{np.median([r['raw_theirs_joint_rad'] for r in done]):.3f} rad"
    )


# -- another method beside `separate`: the gradient descent of examples/penetration_descent.py

#: The table of `compare_method`: (key of an outcome, label, how the records are summed up).
ROWS = (
    ("removed", "hand ∩ object reads exactly 0 after (`intersection_volume(grasp)`)", "count"),
    ("volume", "hand ∩ object after, m³: largest", "max"),
    ("loss_mm3", "Σ over links of link ∩ object, mm³ (raw: before): largest (median)", "max"),
    ("closer", "closer to theirs than the raw record (descriptor L2)", "count"),
    ("l2", "descriptor L2 to theirs, mean", "mean"),
    ("l2_ratio", "descriptor L2 to theirs / the raw record's: median (range)", "spread"),
    ("moved_mm", "object's centroid moved from the raw record, mm", "spread"),
    ("turned_deg", "object turned from the raw record, degrees", "spread"),
    ("joints_rad", "largest joint change from the raw record, rad", "spread"),
    ("theirs_mm", "object's centroid to theirs, mm", "spread"),
    ("theirs_rad", "largest joint difference to theirs, rad", "spread"),
    ("seconds", "seconds per record (wall)", "spread"),
    ("cpu_seconds", "CPU seconds per record (every thread)", "spread"),
    ("evaluations", "loss evaluations (volume and gradient of every link)", "spread"),
)


def outcome(ours, raw, theirs, seconds: tuple[float, float], links, refs) -> dict:
    """One method's figures on one record (the keys of `ROWS`, ``volume`` and ``raw``, the
    raw record's): the volumes left (``links(grasp)``: each link's volume ∩ the object),
    the change from the raw record, how far from theirs (``refs``: the raw record's and
    their descriptors); ``seconds``: the method's (wall, CPU)."""
    import exactgrasp as eg

    far = against_theirs(ours, raw, theirs, *refs)
    volume = float(eg.intersection_volume(ours))
    return {
        "volume": volume,
        "removed": volume == 0.0,
        "loss_mm3": float(sum(links(ours))) * 1e9,
        "closer": far["ours_theirs_l2"] < far["raw_theirs_l2"],
        "l2": far["ours_theirs_l2"],
        "l2_ratio": far["ours_theirs_l2"] / far["raw_theirs_l2"],
        "moved_mm": pose_difference(ours, raw)[0],
        "turned_deg": pose_difference(ours, raw)[1],
        "joints_rad": joint_difference(ours, raw),
        "theirs_mm": far["ours_theirs_pose"][0],
        "theirs_rad": far["ours_theirs_joint_rad"],
        "seconds": seconds[0],
        "cpu_seconds": seconds[1],
        "raw": {
            "loss_mm3": float(sum(links(raw))) * 1e9,
            "l2": far["raw_theirs_l2"],
            "theirs_mm": far["raw_theirs_pose"][0],
            "theirs_rad": far["raw_theirs_joint_rad"],
        },
    }


def compare_method_one(path: Path, data: Path, method, links) -> dict:
    """One adjusted grasp's raw record given to ``method`` (a grasp -> (grasp, loss
    evaluations)) and to `separate` with the library's defaults, each compared with theirs:
    ``{"grasp": stem, "method": outcome, "separate": outcome or {"error": message}}``."""
    import exactgrasp as eg

    raw, theirs = record_pair(path, data)
    refs = (eg.compute_descriptor(raw), eg.compute_descriptor(theirs))
    row = {"grasp": path.stem}
    clock = _Clock()
    ours, evaluations = method(raw)
    row["method"] = outcome(ours, raw, theirs, clock.read(), links, refs)
    row["method"]["evaluations"] = evaluations
    clock = _Clock()
    try:
        separated = eg.separate(raw).grasp
    except eg.SeparationError as exc:
        row["separate"] = {"error": str(exc)}
    else:
        row["separate"] = outcome(separated, raw, theirs, clock.read(), links, refs)
    return row


class _Clock:
    """Wall and CPU (every thread of the process) seconds since made."""

    def __init__(self):
        self.wall, self.cpu = time.perf_counter(), time.process_time()

    def read(self) -> tuple[float, float]:
        return time.perf_counter() - self.wall, time.process_time() - self.cpu


def _cell(values: list, how: str, n: int) -> str:
    import numpy as np

    if not values:
        return ""
    v = np.asarray(values, dtype=float)
    if how == "count":
        return f"{int(v.sum())} of {n}"
    if how == "max":
        return f"{v.max():.3g}" + ("" if v.max() == 0 else f" (median {np.median(v):.3g})")
    if how == "mean":
        return f"{v.mean():.3f}"
    return f"{np.median(v):.3g} ({v.min():.3g}-{v.max():.3g})"


def method_table(rows: list[dict], name: str) -> str:
    """`compare_method`'s table (Markdown): per method, counts of records, or medians with
    their ranges, as `ROWS` says; the method's column is headed ``name``."""
    columns = {
        name: [r["method"] for r in rows],
        "`separate(raw)`, defaults": [r["separate"] for r in rows if "error" not in r["separate"]],
        "raw record": [r["method"]["raw"] for r in rows],
    }
    lines = ["| | " + " | ".join(columns) + " |", "|---" * (len(columns) + 1) + "|"]
    for key, label, how in ROWS:
        cells = [_cell([o[key] for o in c if key in o], how, len(rows)) for c in columns.values()]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def compare_method(data: Path, method, links, name: str, limit=None, out=None) -> list[dict]:
    """`compare_method_one` over the adjusted cereal-box grasps (the first ``limit``), one
    line each as it goes, then `method_table`; the rows are written to ``out`` (JSON) as
    they come."""
    rows = []
    for path in adjusted_paths(data, limit):
        rows.append(compare_method_one(path, data, method, links))
        cells = [
            f"{m} "
            + (
                o.get("error")
                or f"volume {o['volume']:.3g} m^3, L2 {o['l2']:.3f}, {o['seconds']:.1f} s"
            )
            for m, o in rows[-1].items()
            if m != "grasp"
        ]
        raw_l2 = rows[-1]["method"]["raw"]["l2"]
        print(f"{path.stem}: " + "; ".join(cells) + f"; raw L2 {raw_l2:.3f}", flush=True)
        if out:
            out.write_text(json.dumps(rows, indent=1))
    print(method_table(rows, name))
    return rows


def batch(data: Path, fingers: str, limit: int | None, every: int, out: Path | None) -> None:
    import exactgrasp as eg

    with open(data / RAW / "index.csv") as fh:
        records = [(r["object"], r["record"]) for r in csv.DictReader(fh)]
    # A batch killed part-way resumes from its JSON file: the records there are not run again.
    rows = json.loads(out.read_text()) if out and out.exists() else []
    done = {(r["object"], r["record"]) for r in rows}
    for obj, record in records[::every][:limit]:
        if (obj, record) in done:
            continue
        t0, c0 = time.perf_counter(), time.process_time()
        row = {"object": obj, "record": record}
        try:
            # FoodClip.STL is open (the data's README: it had to be closed for its checks).
            grasp = eg.Grasp.from_file(
                data / RAW / obj / f"{record}.json", repair=obj == "FoodClip"
            )
            options = {} if fingers == "default" else {"fingers": fingers}
            result = eg.separate(grasp, **options)
            row.update(
                in_contact=result.in_contact,
                moved_mm=result.translation_mm,
                fingers=result.fingers,
            )
        except eg.ExactGraspError as exc:
            row["error"] = f"{type(exc).__name__}: {exc}"
        row["seconds"] = time.perf_counter() - t0
        row["cpu_seconds"] = time.process_time() - c0
        rows.append(row)
        ok = sum(bool(r.get("in_contact")) for r in rows)
        print(
            f"{obj}/{record}: {row.get('error') or row['in_contact']} ({row['seconds']:.1f} s); "
            f"{ok} of {len(rows)} in contact",
            flush=True,
        )
        if out:
            out.write_text(json.dumps(rows, indent=1))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--fingers",
        default="default",
        choices=("default", "auto", "keep", "reclose"),
        help="default: separate(raw) with the library's defaults",
    )
    ap.add_argument("--grasps", nargs="+", help="comparison: these stems only")
    ap.add_argument("--batch", action="store_true")
    ap.add_argument(
        "--rotation", action=argparse.BooleanOptionalAction, default=True, help="comparison"
    )
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--every", type=int, default=1, help="batch: every N-th record only")
    add_data_options(ap)
    args = ap.parse_args(argv)
    data = data_or_skip(args, f"{RAW}/index.csv")
    if data is None:
        return 0
    if args.batch:
        batch(data, args.fingers, args.limit, args.every, args.json)
    else:
        compare(data, args.fingers, args.rotation, args.json, args.limit, args.grasps)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
