"""The real grasps of the report: the shared Barrett data, and contact grasps made from it.

Grasps come as `Case` records (a short name, the object, where it came from). Contact grasps
on objects other than the cereal box are made from the raw human-study records with
`exactgrasp.close_fingers`; a record it cannot repair is skipped and reported, never used.
"""

from __future__ import annotations

import csv
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.errors import DataError, ExactGraspError
from exactgrasp.geometry.manifold import to_manifold, union
from exactgrasp.grasp import Grasp
from exactgrasp.grasp.closing import close_fingers_result

#: A closed grasp whose hand still overlaps its object by more than this fraction of the hand
#: volume is not a contact grasp and is skipped.
CONTACT_TOLERANCE = 1e-4
#: A closed grasp is kept only if at least this many fingers touch the object ...
MIN_FINGERS = 2
#: ... and the object had to be backed off the palm by at most this much (m): a larger back-off
#: changes the grasp more than closing the fingers does.
MAX_BACKOFF = 0.015
#: Objects whose STL is not closed and must be repaired on reading.
NEEDS_REPAIR = ("FoodClip",)


@dataclass
class Case:
    """One grasp of the report.

    Attributes
    ----------
    name : str
        Short unique label, e.g. ``"CerealBox/sub4_grasp1_optimal0"``.
    object : str
        Object name (the STL stem), e.g. ``"CerealBox"``.
    kind : str
        ``"cereal"`` (adjusted contact grasp), ``"spray"`` (the noise-set grasp) or
        ``"closed"`` (a study record closed with `close_fingers`).
    grasp : Grasp
    source : str
        The file it came from.
    notes : dict
        What was done to it (closing: joints before and after, residual overlap).
    """

    name: str
    object: str
    kind: str
    grasp: Grasp
    source: str
    notes: dict[str, Any] = field(default_factory=dict)


def barrett_dir(data_dir: str | Path) -> Path:
    """The ``barrett-grasps`` folder of a shared data folder, checked.

    Parameters
    ----------
    data_dir : path-like
        The shared data folder (holding ``barrett-grasps/`` and ``osu-objects/``).

    Returns
    -------
    pathlib.Path
    """
    data_dir = Path(data_dir)
    if not data_dir.is_dir():
        raise DataError(
            f"data folder {str(data_dir)!r} does not exist; pass the shared data folder that "
            "holds barrett-grasps/ and osu-objects/, e.g. --data ../shared/data (or set "
            "EXACTGRASP_DATA)."
        )
    missing = [
        sub
        for sub in ("barrett-grasps/grasps", "barrett-grasps/noise", "osu-objects")
        if not (data_dir / sub).is_dir()
    ]
    if missing:
        raise DataError(
            f"data folder {str(data_dir)!r} lacks {', '.join(missing)}; pass the shared data "
            "folder that holds barrett-grasps/ and osu-objects/."
        )
    return data_dir / "barrett-grasps"


def _samples_for(path: Path) -> str | None:
    """The authors' surface samples beside the object a grasp file names, if any."""
    data = json.loads(path.read_text())
    obj = (path.parent / data["object"]).resolve()
    ply = obj.with_name(obj.stem + "_P.ply")
    return str(ply) if ply.exists() else None


def read_grasp(path: Path, authors_samples: bool, name: str | None = None) -> Grasp:
    """A grasp file of the shared data, with the authors' surface samples when asked.

    Parameters
    ----------
    path : pathlib.Path
    authors_samples : bool
    name : str, optional
        Replaces the name in the file.

    Returns
    -------
    Grasp
    """
    overrides: dict[str, Any] = {"on_limit": "clip"}
    if authors_samples:
        samples = _samples_for(path)
        if samples:
            overrides["surface_samples"] = samples
    if any(obj in str(path) for obj in NEEDS_REPAIR):
        overrides["repair"] = True
    with warnings.catch_warnings():
        # Study records hold distal values 7.6e-4 rad past the URDF's rounded limit; clipping
        # them is documented in the data README and not worth a warning per record.
        warnings.simplefilter("ignore")
        grasp = Grasp.from_file(path, **overrides)
    if name:
        grasp.name = name
    return grasp


def cereal_cases(barrett: Path, n: int | None, authors_samples: bool) -> list[Case]:
    """The 34 adjusted cereal-box contact grasps (``n`` of them evenly spread by file name)."""
    files = sorted((barrett / "grasps").glob("obj5_*.json"))
    if n is not None and n < len(files):
        # Evenly spread, so that a subset still spans the subjects and grasp types.
        picks = np.unique(np.linspace(0, len(files) - 1, max(n, 1)).round().astype(int))
        files = [files[i] for i in picks]
    cases = []
    for path in files:
        label = "CerealBox/" + path.stem.removeprefix("obj5_").removesuffix("_target")
        label = label.removesuffix("_prime")
        grasp = read_grasp(path, authors_samples, name=label)
        cases.append(Case(label, "CerealBox", "cereal", grasp, str(path)))
    return cases


def spray_case(barrett: Path, authors_samples: bool) -> Case:
    """The spray-bottle grasp the paper's joint-noise test starts from."""
    path = barrett / "noise" / "spray_bottle_base.json"
    if not path.exists():
        raise DataError(f"{path} is missing from the shared data.")
    label = "SprayBottle/noise_base"
    return Case(label, "SprayBottle", "spray", read_grasp(path, authors_samples, label), str(path))


def overlap_fraction(grasp: Grasp) -> float:
    """Exact hand ∩ object volume at the grasp pose, as a fraction of the hand volume."""
    hand = union(grasp.hand.link_arrays(), name=grasp.hand.model.name)
    pose = grasp.object_pose
    vertices = grasp.object.vertices @ pose[:3, :3].T + pose[:3, 3]
    obj = to_manifold(vertices, grasp.object.faces, grasp.object.name)
    return float((hand ^ obj).volume()) / grasp.hand.volume


def _records(barrett: Path, obj: str) -> list[Path]:
    """Study records of one object, the least penetrating first (the easiest to repair)."""
    folder = barrett / "study-records" / obj
    if not folder.is_dir():
        return []
    depth: dict[str, float] = {}
    index = barrett / "study-records" / "index.csv"
    if index.exists():
        with open(index, newline="") as handle:
            for row in csv.DictReader(handle):
                if row["object"] == obj:
                    depth[row["record"]] = float(row["penetration_mm"])
    files = sorted(folder.glob("*.json"))
    return sorted(files, key=lambda p: (depth.get(p.stem, np.inf), p.stem))


def _close(grasp: Grasp) -> tuple[Any, np.ndarray, dict[str, Any]]:
    """Close the hand onto the object: (hand, object pose after any back-off, notes)."""
    with warnings.catch_warnings():
        # A back-off is reported in the notes (and the report), not as a warning per record.
        warnings.simplefilter("ignore", UserWarning)
        result = close_fingers_result(grasp.hand, grasp.object, object_pose=grasp.object_pose)
    notes = {
        "backoff_m": float(result.backoff_distance),
        "fingers_in_contact": sum(1 for f in result.fingers if f.contact_links),
        "contact_links": sorted({link for f in result.fingers for link in f.contact_links}),
    }
    return result.hand, np.asarray(result.object_pose, dtype=np.float64), notes


def _closed_case(path: Path, obj: str, authors_samples: bool, cache: Path) -> Case:
    """A study record closed onto its object (closing results cached as JSON)."""
    label = f"{obj}/{path.stem.split('_', 1)[1]}"
    raw = read_grasp(path, authors_samples, name=label)
    cached = cache / f"{path.stem}.json"
    if cached.exists():
        record = json.loads(cached.read_text())
        if record["status"] != "ok":
            raise ExactGraspError(record["reason"])
        hand = raw.hand.with_joints(record["joints"], on_limit="clip")
        pose = np.asarray(record["object_pose"])
        notes = record["notes"]
        _check_closed(notes)
    else:
        before = overlap_fraction(raw)
        try:
            hand, pose, closing = _close(raw)
            closed = Grasp(hand, raw.object, pose, name=label)
            after = overlap_fraction(closed)
            if after > CONTACT_TOLERANCE:
                raise ExactGraspError(
                    f"still overlaps the object by {after:.2e} of the hand volume after closing"
                )
        except ExactGraspError as exc:
            cache.mkdir(parents=True, exist_ok=True)
            cached.write_text(json.dumps({"status": "skipped", "reason": str(exc)}))
            raise
        notes = {
            "overlap_before": before,
            "overlap_after": after,
            **closing,
            "joints_before": raw.hand.joints,
            "joints_after": dict(hand.joints),
        }
        cache.mkdir(parents=True, exist_ok=True)
        cached.write_text(
            json.dumps(
                {
                    "status": "ok",
                    "joints": dict(hand.joints),
                    "object_pose": pose.tolist(),
                    "notes": notes,
                },
                indent=1,
            )
        )
        _check_closed(notes)
    grasp = Grasp(hand, raw.object, pose, name=label)
    return Case(label, obj, "closed", grasp, str(path), notes)


def _check_closed(notes: dict[str, Any]) -> None:
    """Refuse a closing that touches with too few fingers or moved the object too far."""
    if notes["fingers_in_contact"] < MIN_FINGERS:
        raise ExactGraspError(
            f"only {notes['fingers_in_contact']} finger(s) touch the object after closing"
        )
    if notes["backoff_m"] > MAX_BACKOFF:
        raise ExactGraspError(
            f"the object had to be backed off the palm by {notes['backoff_m'] * 1e3:.1f} mm "
            f"(more than {MAX_BACKOFF * 1e3:g} mm) to close the fingers"
        )


def contact_cases(
    barrett: Path,
    objects: tuple[str, ...],
    per_object: int,
    tries: int,
    authors_samples: bool,
    cache: Path,
    log=print,
) -> tuple[list[Case], list[dict[str, str]]]:
    """Contact grasps made from raw study records with `close_fingers`.

    Parameters
    ----------
    barrett : pathlib.Path
        The ``barrett-grasps`` folder.
    objects : tuple of str
    per_object : int
        Grasps kept per object.
    tries : int
        Records tried per object, the least penetrating first.
    authors_samples : bool
    cache : pathlib.Path
        Folder for the closing results.
    log : callable

    Returns
    -------
    cases : list of Case
    skipped : list of dict
        ``{"record", "object", "reason"}`` for each record that could not be repaired.
    """
    cases: list[Case] = []
    skipped: list[dict[str, str]] = []
    for obj in objects:
        kept = 0
        for path in _records(barrett, obj)[:tries]:
            if kept >= per_object:
                break
            try:
                case = _closed_case(path, obj, authors_samples, cache)
            except (ExactGraspError, ImportError) as exc:
                skipped.append({"record": f"{obj}/{path.stem}", "object": obj, "reason": str(exc)})
                log(f"  skipped {obj}/{path.stem}: {exc}")
                continue
            cases.append(case)
            kept += 1
    return cases, skipped
