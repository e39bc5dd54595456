"""Reading and writing the object and hand parts of grasp JSON files (see `exactgrasp.grasp`)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.errors import ExactGraspError, GraspFileError
from exactgrasp.geometry.solid import Solid, unit_scale
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.hand import Hand


def _resolve(base_dir: Path, relative: str, source: str, what: str) -> Path:
    path = Path(relative)
    path = path if path.is_absolute() else base_dir / path
    if not path.exists():
        raise GraspFileError(
            f"{source}: the {what} file {relative!r} (resolved to {path}) does not exist; paths "
            "in a grasp file are relative to the grasp file."
        )
    return path


def _relative(path: str | os.PathLike, base_dir: Path) -> str:
    return os.path.relpath(Path(path).resolve(), base_dir.resolve())


def read_object(data: dict, base_dir: Path, source: str, overrides: dict) -> Solid:
    """The grasp's object, from ``object``, ``object_units``, ``object_repair``,
    ``object_surface_samples``."""
    path = _resolve(base_dir, data["object"], source, "object")
    samples = overrides.get("surface_samples", data.get("object_surface_samples"))
    if isinstance(samples, str):
        samples = _resolve(base_dir, samples, source, "surface samples")
    repair = overrides.get("repair", data.get("object_repair", False))
    try:
        return Solid.from_file(
            path,
            units=data.get("object_units", "m"),
            repair=repair,
            surface_samples=samples,
        )
    except ExactGraspError as exc:
        raise type(exc)(f"{source}: object: {exc}") from exc


def read_hand(data: dict, base_dir: Path, source: str, overrides: dict) -> Hand:
    """The grasp's hand, from ``hand`` (files written here) or ``hand_model`` (shared data)."""
    joints = data.get("joints") or {}
    on_limit = overrides.get("on_limit", data.get("on_limit", "error"))
    frame = HandFrame.from_dict(data["hand_frame"]) if data.get("hand_frame") else None
    spec = data.get("hand")
    try:
        if spec is None:
            if "hand_model" not in data:
                raise GraspFileError(
                    f"{source}: names no hand; give 'hand_model' (an MJCF/URDF path) or 'hand'."
                )
            path = _resolve(base_dir, data["hand_model"], source, "hand model")
            options = data.get("hand_options") or {}
            return Hand.from_urdf(path, joints=joints, frame=frame, on_limit=on_limit, **options)
        kind = spec.get("type")
        if kind == "builtin":
            from exactgrasp.hands import get as builtin_hand

            builder = builtin_hand(spec["name"])
            options = spec.get("options") or {}
            return builder(joints=joints, frame=frame, on_limit=on_limit, **options)
        if kind == "file":
            path = _resolve(base_dir, spec["path"], source, "hand mesh")
            return Hand.from_file(
                path, frame=frame, units=spec.get("units", "m"), repair=spec.get("repair", False)
            )
        if kind == "meshes":
            solids = [
                Solid.from_file(_resolve(base_dir, p, source, "hand link"), units="m")
                for p in spec["paths"]
            ]
            return Hand.from_meshes(solids, frame=frame, names=spec.get("names"))
        raise GraspFileError(
            f"{source}: hand type {kind!r} is unknown; use 'builtin', 'file' or 'meshes'."
        )
    except GraspFileError:
        raise
    except ExactGraspError as exc:
        raise type(exc)(f"{source}: hand: {exc}") from exc


def write_ply(path: Path, vertices: np.ndarray, faces: np.ndarray | None = None) -> None:
    """Binary little-endian PLY with float64 vertices (trimesh's exporter writes float32,
    which would break bit-for-bit round trips of grasp files)."""
    vertices = np.ascontiguousarray(vertices, dtype="<f8")
    header = [
        "ply",
        "format binary_little_endian 1.0",
        f"element vertex {len(vertices)}",
        "property double x",
        "property double y",
        "property double z",
    ]
    body = vertices.tobytes()
    if faces is not None:
        header += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
        rows = np.zeros(len(faces), dtype=[("n", "u1"), ("v", "<i4", (3,))])
        rows["n"] = 3
        rows["v"] = faces
        body += rows.tobytes()
    path.write_bytes(("\n".join([*header, "end_header"]) + "\n").encode() + body)


def write_object(obj: Solid, base_dir: Path, stem: str) -> dict[str, Any]:
    """The object keys of a grasp file; in-memory geometry goes to ``<stem>.object.ply``."""
    if obj.source is not None:
        src = obj.source
        out: dict[str, Any] = {
            "object": _relative(src["path"], base_dir),
            "object_units": src["units"],
            "object_repair": src["repair"],
        }
        if src.get("surface_samples"):
            out["object_surface_samples"] = _relative(src["surface_samples"], base_dir)
        elif obj.surface_samples is not None:
            name = f"{stem}.samples.ply"
            write_ply(base_dir / name, obj.surface_samples / unit_scale(src["units"]))
            out["object_surface_samples"] = name
        return out
    name = f"{stem}.object.ply"
    write_ply(base_dir / name, obj.vertices, obj.faces)
    out = {"object": name, "object_units": "m", "object_repair": False}
    if obj.surface_samples is not None:
        samples = f"{stem}.samples.ply"
        write_ply(base_dir / samples, obj.surface_samples)
        out["object_surface_samples"] = samples
    return out


def write_hand(hand: Hand, base_dir: Path, stem: str) -> dict[str, Any]:
    """The hand keys of a grasp file; hands not read from files are written as link meshes."""
    out: dict[str, Any] = {"joints": dict(hand.joints), "hand_frame": hand.frame.to_dict()}
    src = hand.source or {}
    kind = src.get("type")
    if kind == "builtin":
        out["hand"] = {"type": "builtin", "name": src["name"], "options": src.get("options", {})}
    elif kind == "model":
        out["hand_model"] = _relative(src["path"], base_dir)
        if src.get("options"):
            out["hand_options"] = src["options"]
    elif kind == "file":
        out["hand"] = {
            "type": "file",
            "path": _relative(src["path"], base_dir),
            "units": src["units"],
            "repair": src["repair"],
        }
    else:
        folder = base_dir / f"{stem}.hand"
        folder.mkdir(exist_ok=True)
        paths = []
        for i, (vertices, faces) in enumerate(hand.link_arrays()):
            name = f"{i:02d}_{hand.link_names[i].replace('/', '_')}.ply"
            write_ply(folder / name, vertices, faces)
            paths.append(f"{stem}.hand/{name}")
        out["hand"] = {"type": "meshes", "paths": paths, "names": hand.link_names}
        out["joints"] = {}
    return out
