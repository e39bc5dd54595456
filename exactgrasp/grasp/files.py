"""Reading and writing the object and hand parts of grasp files (see `exactgrasp.grasp.grasp`
and ``docs/grasp-file.md``).

Errors from reading the object or the hand are re-raised as errors of the grasp file: naming
it, the key concerned and the fix as the file spells it (``"object_repair": true``, not
``repair=True``), from the fixes the errors carry (`exactgrasp.errors.Fix`), never from their
text. Hands are read and written through `exactgrasp.hands.sources.HAND_SOURCES`.
"""

from __future__ import annotations

import builtins
import hashlib
import json
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.cache import DiskCache, LRUCache, code_digest
from exactgrasp.errors import (
    ExactGraspError,
    Fix,
    FrameError,
    GraspFileError,
    JointError,
    MeshError,
    ModelError,
    outside_caller,
    recording_warnings,
    warn_once,
    warned_here,
)
from exactgrasp.geometry.files import relative_path, resolve_path, write_ply
from exactgrasp.geometry.intake import REPAIR, unit_scale
from exactgrasp.geometry.solid import Solid
from exactgrasp.grasp.schema import schema_dict
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.hand import Hand
from exactgrasp.hands.sources import HAND_SOURCES, source_for
from exactgrasp.version import __version__

__all__ = [
    "HAND_KEYS",
    "OBJECT_KEYS",
    "file_terms",
    "read_hand",
    "read_object",
    "write_hand",
    "write_object",
]

# -- the file's spelling of a fix -------------------------------------------------------------

#: How a grasp file sets what the Python API's ``frame=`` does.
FRAME_FIX = (
    'give "hand_frame": {"origin": [x, y, z], "normal": [x, y, z], "up": [x, y, z], '
    '"depth": d} (the paper\'s frame) or "hand_frame": {"identity": true} in the grasp file'
)


def _key_value(key: str, value: str) -> str:
    """``"a": {"b": value}`` for the dotted key ``a.b``."""
    *outer, last = key.split(".")
    text = f"{json.dumps(last)}: {value}"
    for name in reversed(outer):
        text = f"{json.dumps(name)}: {{{text}}}"
    return text


def file_terms(fix: Fix) -> str | None:
    """A fix as a grasp file spells it: the key that sets it, when the reader recorded one.

    Parameters
    ----------
    fix : Fix
        Its `Fix.file_key` set by the reader (`read_object`, `read_hand`); None keeps the
        Python spelling, ``""`` (a Python-only escape hatch) drops the fix.

    Returns
    -------
    str or None
        ``pass repair=True`` is ``set "object_repair": true in the grasp file`` (for the key
        ``object_repair``), a bare ``repair=True`` is ``"object_repair": true``, the place of
        ``units`` is ``"object_units" in the grasp file``.
    """
    key = fix.file_key
    if key == "":
        return None
    if key == "hand_frame":
        return FRAME_FIX
    if key is None or (fix.value is ... and fix.shown is None and fix.form != "where"):
        return fix.in_python()
    if fix.form == "where":
        return f"{json.dumps(key)} in the grasp file"
    if fix.python is not None:
        return fix.python
    shown = json.dumps(fix.value) if fix.shown is None else fix.shown or "..."
    text = _key_value(key, shown)
    if fix.form in ("pass", "Pass"):
        return f"{'S' if fix.form == 'Pass' else 's'}et {text} in the grasp file"
    return text


#: Settings of the Python API that no grasp-file key reaches, and the frame, which has its
#: own key: the same for every part of the file.
COMMON_KEYS = {"check_scale": "", "frame": "hand_frame"}
#: The grasp-file key behind each Python argument, by the part of the file being read.
OBJECT_KEYS = {
    "repair": "object_repair",
    "units": "object_units",
    "surface_samples": "object_surface_samples",
    **COMMON_KEYS,
}
JOINT_KEYS = {"on_limit": "on_limit", "joints": "joints"}
_MODEL_OPTIONS = schema_dict()["properties"]["hand_options"]["properties"]
HAND_KEYS = {
    "model": {**{k: f"hand_options.{k}" for k in _MODEL_OPTIONS}, **JOINT_KEYS, **COMMON_KEYS},
    "builtin": {
        "distal_coupling": "hand.options.distal_coupling",
        "tessellation": "hand.options.tessellation",
        **JOINT_KEYS,
        **COMMON_KEYS,
    },
    "file": {"repair": "hand.repair", "units": "hand.units", **COMMON_KEYS},
    "meshes": dict(COMMON_KEYS),
}
#: The key an error of each hand kind is about.
HAND_KEY = {"model": "hand_model", "builtin": "hand", "file": "hand", "meshes": "hand"}


def _as_file_error(exc: ExactGraspError, source: str, key: str, keys: dict) -> ExactGraspError:
    """``exc`` for a grasp file: naming ``key``, its fixes spelled as file keys."""
    # Joint errors keep their class: callers (batch reports) sort failures by it.
    cls = JointError if isinstance(exc, JointError) else GraspFileError
    return exc.respelled(file_terms, f"{source}: {key}: ", keys=keys, cls=cls)


# -- reading and writing ---------------------------------------------------------------------

#: Objects read from grasp files in this process, by file (path and SHA-256 of its bytes) and
#: reading options: a dataset's grasps name a few objects many times each, and reading,
#: checking and resolving a messy mesh costs more than a voxel descriptor.
OBJECTS = LRUCache(32)

#: The same objects on disk (`exactgrasp.cache.DiskCache`, ``EXACTGRASP_CACHE``): the solid's
#: arrays, its reports and the warnings its reading gave, keyed on the same file content and
#: options and on the code that reads them (the geometry room's sources and this module:
#: `exactgrasp.cache.code_digest`). Every batch worker on a machine, and every later
#: run, reads a messy mesh's solid instead of resolving it again (0.4 s for the authors'
#: pitcher).
OBJECT_SOLIDS = DiskCache("objects", version=lambda: f"{__version__}/{code_digest(__file__)}")


def _file_content(path: Path) -> tuple[str, str | None]:
    """(resolved path, SHA-256 of the bytes), or (path, None) when it cannot be read (the
    reader then says why)."""
    try:
        return str(path.resolve()), hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return str(path), None


def _read_solid(path: Path, units: str, repair: bool, samples: Any) -> Solid:
    """`Solid.from_file`, kept in `OBJECTS` and `OBJECT_SOLIDS`; exactgrasp's warnings about
    the mesh are given again at every read, as a read without the caches would give them, and
    other libraries' once per process."""
    key = None  # samples given as an array: not cached
    if samples is None or isinstance(samples, str | os.PathLike):
        found = None if samples is None else _file_content(Path(samples))
        key = (_file_content(path), units, bool(repair), found)

    def read() -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        solid, ours, others = _read_recording_warnings(path, units, repair, samples)
        arrays = {"vertices": solid.vertices, "faces": solid.faces}
        if solid.surface_samples is not None:
            arrays["surface_samples"] = solid.surface_samples
        reports = {name: getattr(solid, name) for name in _SOLID_RECORD}
        return arrays, {**reports, "ours": ours, "others": others}

    def build() -> tuple[Solid, list[str]]:
        if key is None or key[0][1] is None or (key[3] is not None and key[3][1] is None):
            arrays, record = read()  # not kept on disk; an unreadable file: the reader says why
        else:
            arrays, record = OBJECT_SOLIDS.get(OBJECT_SOLIDS.key([repr(key), str(path)]), read)
        for message, category, filename, lineno in record["others"]:
            warnings.warn_explicit(message, _warning_class(category), filename, lineno)
        solid = Solid._trusted(
            arrays["vertices"], arrays["faces"], str(path), arrays.get("surface_samples")
        )
        for name in _SOLID_RECORD:
            setattr(solid, name, record[name])
        return solid, record["ours"]

    solid, notes = OBJECTS.get(key, build)
    for note in notes:
        warn_once(note)
    return solid


#: What `Solid.from_file` sets beside the arrays, kept with them in `OBJECT_SOLIDS`.
_SOLID_RECORD = ("shell_report", "repair_report", "source")


def _read_recording_warnings(
    path: Path, units: str, repair: bool, samples: Any
) -> tuple[Solid, list[str], list[tuple[str, str, str, int]]]:
    """`Solid.from_file` and the warnings it gave, for the caller to give (all given here when
    the read fails).

    Returns
    -------
    (Solid, list of str, list of (str, str, str, int))
        The solid, exactgrasp's warnings, and other libraries' as (message, category name,
        file, line).
    """
    caught: list[warnings.WarningMessage] = []
    site = outside_caller()
    try:
        with recording_warnings() as caught:
            solid = Solid.from_file(path, units=units, repair=repair, surface_samples=samples)
    except Exception:
        for w in caught:
            if warned_here(w, site):
                warn_once(str(w.message))
            else:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        raise
    ours = [str(w.message) for w in caught if warned_here(w, site)]
    others = [
        (str(w.message), w.category.__name__, w.filename, w.lineno)
        for w in caught
        if not warned_here(w, site)
    ]
    return solid, ours, others


def _warning_class(name: str) -> type[Warning]:
    """The built-in warning class of this name; `UserWarning` for any other."""
    found = getattr(builtins, name, None)
    return found if isinstance(found, type) and issubclass(found, Warning) else UserWarning


def read_object(data: dict, base_dir: Path, source: str, overrides: dict) -> Solid:
    """The grasp's object, from ``object``, ``object_units``, ``object_repair``,
    ``object_surface_samples``."""
    path = resolve_path(base_dir, data["object"], source, "object")
    samples = overrides.get("surface_samples", data.get("object_surface_samples"))
    if isinstance(samples, str | os.PathLike):
        samples = resolve_path(base_dir, samples, source, "object_surface_samples")
    repair = overrides.get("repair", data.get("object_repair", REPAIR))
    try:
        return _read_solid(
            path, overrides.get("units", data.get("object_units", "m")), repair, samples
        )
    except (MeshError, ModelError) as exc:
        raise _as_file_error(exc, source, "object", OBJECT_KEYS) from exc


def _check_package_dirs(data: dict, base_dir: Path, source: str) -> None:
    """Every folder of ``hand_options.package_dirs`` exists, relative to the grasp file."""
    dirs = (data.get("hand_options") or {}).get("package_dirs")
    if dirs is None:
        return
    if isinstance(dirs, str):
        dirs = [dirs]
    for folder in dirs.values() if isinstance(dirs, dict) else dirs:
        path = base_dir / folder
        if not path.is_dir():
            raise GraspFileError(
                f"{source}: hand_options.package_dirs: the folder {folder!r} (resolved to "
                f"{path}) does not exist; paths in a grasp file are relative to the grasp file."
            )


def read_hand(data: dict, base_dir: Path, source: str, overrides: dict) -> Hand:
    """The grasp's hand, from ``hand`` (files written here) or ``hand_model`` (shared data)."""
    joints = data.get("joints") or {}
    on_limit = overrides.get("on_limit", data.get("on_limit", "error"))
    try:
        frame = HandFrame.from_dict(data["hand_frame"]) if data.get("hand_frame") else None
    except FrameError as exc:
        raise _as_file_error(exc, source, "hand_frame", COMMON_KEYS) from exc
    spec = data.get("hand")
    kind = "model" if spec is None else spec.get("type")
    if kind not in HAND_SOURCES:
        raise GraspFileError(
            f"{source}: hand.type {kind!r} is unknown; use one of "
            f"{sorted(set(HAND_SOURCES) - {'model'})} (or 'hand_model' for a model file)."
        )
    _check_package_dirs(data, base_dir, source)
    try:
        return HAND_SOURCES[kind].read(
            data, base_dir, source, joints=joints, frame=frame, on_limit=on_limit
        )
    except GraspFileError:
        raise
    except (MeshError, ModelError, FrameError, JointError) as exc:
        key = "joints" if isinstance(exc, JointError) else HAND_KEY[kind]
        raise _as_file_error(exc, source, key, HAND_KEYS[kind]) from exc


def write_object(obj: Solid, base_dir: Path, stem: str) -> dict[str, Any]:
    """The object keys of a grasp file; in-memory geometry goes to ``<stem>.object.ply``."""
    if obj.source is not None:
        src = obj.source
        out: dict[str, Any] = {
            "object": relative_path(src["path"], base_dir),
            "object_units": src["units"],
            "object_repair": src["repair"],
        }
        if src.get("surface_samples"):
            out["object_surface_samples"] = relative_path(src["surface_samples"], base_dir)
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
    out.update(source_for(hand).write(hand, base_dir, stem))
    return out
