"""Where a hand in a grasp file comes from: the `HAND_SOURCES` registry, one source per kind.

A grasp file names its hand as a model file (``hand_model``, the shared Barrett data's key) or
as ``hand: {"type": kind, ...}`` with kind ``"builtin"``, ``"file"`` or ``"meshes"``. Each
kind is one `HandSource` that reads such a hand and writes one back (`source_for` picks the
writer from ``Hand.source``; hands built in memory are written as link meshes).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

from exactgrasp.errors import GraspFileError
from exactgrasp.geometry.files import relative_path, resolve_path, write_ply
from exactgrasp.geometry.intake import REPAIR
from exactgrasp.geometry.solid import Solid
from exactgrasp.hands.builtins import get_builtin
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.hand import Hand

__all__ = [
    "HAND_SOURCES",
    "BuiltinSource",
    "FileSource",
    "HandSource",
    "MeshesSource",
    "ModelSource",
    "available_hand_sources",
    "source_for",
]


class HandSource(Protocol):
    """Reads and writes one kind of hand description of a grasp file."""

    kind: str

    def read(
        self,
        data: dict[str, Any],
        base_dir: Path,
        source: str,
        *,
        joints: dict[str, float],
        frame: HandFrame | None,
        on_limit: str,
    ) -> Hand:
        """The hand described by the grasp dict ``data`` (paths relative to ``base_dir``).

        Parameters
        ----------
        data : dict
            The whole parsed grasp file.
        base_dir : pathlib.Path
            Folder of the grasp file.
        source : str
            The grasp file, for messages.
        joints : dict of str to float
        frame : HandFrame or None
        on_limit : {"error", "clip"}
        """
        ...

    def write(self, hand: Hand, base_dir: Path, stem: str) -> dict[str, Any]:
        """The grasp-file keys that describe ``hand`` (files it needs go beside the JSON).

        Parameters
        ----------
        hand : Hand
        base_dir : pathlib.Path
            Folder of the grasp file (paths are written relative to it).
        stem : str
            Stem of files written for in-memory geometry.
        """
        ...


class ModelSource:
    """An MJCF/URDF file: ``hand_model`` (relative path) and optional ``hand_options``."""

    kind = "model"

    def read(self, data, base_dir, source, *, joints, frame, on_limit):
        if "hand_model" not in data:
            raise GraspFileError(
                f"{source}: names no hand; give 'hand_model' (an MJCF/URDF path) or 'hand'."
            )
        path = resolve_path(base_dir, data["hand_model"], source, "hand model")
        options = dict(data.get("hand_options") or {})
        if options.get("package_dirs") is not None:
            options["package_dirs"] = _package_dirs(
                options["package_dirs"], lambda p: base_dir / p
            )
        return Hand.from_urdf(path, joints=joints, frame=frame, on_limit=on_limit, **options)

    def write(self, hand, base_dir, stem):
        src = hand.source
        out: dict[str, Any] = {"hand_model": relative_path(src["path"], base_dir)}
        if src.get("options"):
            options = dict(src["options"])
            if options.get("package_dirs") is not None:
                options["package_dirs"] = _package_dirs(
                    options["package_dirs"], lambda p: relative_path(Path.cwd() / p, base_dir)
                )
            out["hand_options"] = options
        return out


def _package_dirs(value: Any, convert) -> Any:
    """``package_dirs`` (a folder, a list of folders or ``{name: folder}``) with every folder
    passed through ``convert``: grasp files hold them relative to the grasp file."""
    if isinstance(value, dict):
        return {name: str(convert(folder)) for name, folder in value.items()}
    if isinstance(value, list | tuple):
        return [str(convert(folder)) for folder in value]
    return str(convert(value))


class BuiltinSource:
    """A built-in hand: ``hand: {"type": "builtin", "name": ..., "options": {...}}``."""

    kind = "builtin"

    def read(self, data, base_dir, source, *, joints, frame, on_limit):
        spec = data["hand"]
        builder = get_builtin(spec["name"])
        options = spec.get("options") or {}
        return builder(joints=joints, frame=frame, on_limit=on_limit, **options)

    def write(self, hand, base_dir, stem):
        src = hand.source
        spec = {"type": "builtin", "name": src["name"], "options": src.get("options", {})}
        return {"hand": spec}


class FileSource:
    """A rigid hand of one mesh file: ``hand: {"type": "file", "path", "units", "repair"}``."""

    kind = "file"

    def read(self, data, base_dir, source, *, joints, frame, on_limit):
        spec = data["hand"]
        path = resolve_path(base_dir, spec["path"], source, "hand mesh")
        return Hand.from_file(
            path, frame=frame, units=spec.get("units", "m"), repair=spec.get("repair", REPAIR)
        )

    def write(self, hand, base_dir, stem):
        src = hand.source
        return {
            "hand": {
                "type": "file",
                "path": relative_path(src["path"], base_dir),
                "units": src["units"],
                "repair": src["repair"],
            }
        }


class MeshesSource:
    """Rigid link meshes: ``hand: {"type": "meshes", "paths": [...], "names": [...]}``.

    Also the writer of every hand not read from files: its posed links go to
    ``<stem>.hand/NN_<link>.ply`` (metres) and its joints are written empty.
    """

    kind = "meshes"

    def read(self, data, base_dir, source, *, joints, frame, on_limit):
        spec = data["hand"]
        solids = [
            Solid.from_file(resolve_path(base_dir, p, source, "hand link"), units="m")
            for p in spec["paths"]
        ]
        return Hand.from_meshes(solids, frame=frame, names=spec.get("names"))

    def write(self, hand, base_dir, stem):
        folder = base_dir / f"{stem}.hand"
        folder.mkdir(exist_ok=True)
        paths = []
        for i, (vertices, faces) in enumerate(hand.link_arrays()):
            name = f"{i:02d}_{hand.link_names[i].replace('/', '_')}.ply"
            write_ply(folder / name, vertices, faces)
            paths.append(f"{stem}.hand/{name}")
        return {"hand": {"type": "meshes", "paths": paths, "names": hand.link_names}, "joints": {}}


#: Every hand source by kind.
HAND_SOURCES: dict[str, HandSource] = {
    source.kind: source
    for source in (ModelSource(), BuiltinSource(), FileSource(), MeshesSource())
}


def available_hand_sources() -> set[str]:
    """The kinds of hand description a grasp file may use."""
    return set(HAND_SOURCES)


def source_for(hand: Hand) -> HandSource:
    """The source that writes ``hand``: the one it was read from, else link meshes."""
    kind = (hand.source or {}).get("type")
    return HAND_SOURCES.get(kind, HAND_SOURCES["meshes"])
