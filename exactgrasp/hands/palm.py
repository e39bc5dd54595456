"""Palm frames of hand models: `PalmSpec` and turning a palm description into one."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.errors import Fix, FrameError, ModelError

__all__ = [
    "AXES",
    "PALM_FILE",
    "PALM_KEYS",
    "PalmSpec",
    "is_keyed",
    "missing_palm",
    "missing_palm_fix",
    "palm_axis",
    "palm_from_file",
    "palm_missing",
    "resolve_palm",
]

#: Axis names of a frame: column index, or ``-(index + 1)`` for the negative axis.
AXES = {"+x": 0, "x": 0, "+y": 1, "y": 1, "+z": 2, "z": 2, "-x": -1, "-y": -2, "-z": -3}


@dataclass(frozen=True)
class PalmSpec:
    """A palm frame in hand (root body) coordinates.

    Attributes
    ----------
    origin : tuple of 3 float
        A point on the palm face (metres).
    normal : tuple of 3 float
        Unit vector out of the palm (the approach direction).
    up : tuple of 3 float
        Unit vector along the palm, perpendicular to ``normal`` (e.g. towards the thumb).
    depth : float
        Palm-to-closed-fingertip distance d (metres), > 0.
    """

    origin: tuple
    normal: tuple
    up: tuple
    depth: float

    def __post_init__(self):
        origin = np.asarray(self.origin, dtype=np.float64).reshape(-1)
        normal = np.asarray(self.normal, dtype=np.float64).reshape(-1)
        up = np.asarray(self.up, dtype=np.float64).reshape(-1)
        if origin.shape != (3,) or normal.shape != (3,) or up.shape != (3,):
            raise ModelError("palm origin, normal and up must each have 3 coordinates")
        if not (np.all(np.isfinite([*origin, *normal, *up])) and math.isfinite(self.depth)):
            raise ModelError("palm origin, normal, up and depth must be finite numbers")
        if np.linalg.norm(normal) == 0 or np.linalg.norm(up) == 0:
            raise ModelError("palm normal and up must be non-zero vectors")
        normal, up = normal / np.linalg.norm(normal), up / np.linalg.norm(up)
        if abs(normal @ up) > 1e-6:
            raise ModelError(
                f"palm up {up.tolist()} is not perpendicular to normal "
                f"{normal.tolist()} (dot = {normal @ up:.3g})"
            )
        if not self.depth > 0:
            raise ModelError(f"palm depth must be > 0 (metres), got {self.depth!r}")
        object.__setattr__(self, "origin", tuple(origin.tolist()))
        object.__setattr__(self, "normal", tuple(normal.tolist()))
        object.__setattr__(self, "up", tuple(up.tolist()))
        object.__setattr__(self, "depth", float(self.depth))


#: The palm frame's keys, as ``palm_frame.json`` and ``palm=`` hold them in hand coordinates.
PALM_KEYS = '{"origin": [x, y, z], "normal": [x, y, z], "up": [x, y, z], "depth": d}'
#: The file of palm frames beside a model file.
PALM_FILE = "palm_frame.json"


def palm_from_file(path: Path) -> dict | None:
    """The palm frame ``palm_frame.json`` beside the model file ``path`` gives it, if any.

    The file holds one palm frame (a dict of `PalmSpec` keys, optionally naming a body or
    site), or, for a folder of several models, a JSON object keyed by model file name
    (``{"robotiq.xml": {...}, "panda_hand.urdf": {...}}``), each value a palm frame.

    Parameters
    ----------
    path : pathlib.Path
        The model file.

    Returns
    -------
    dict or None
        None when there is no such file, or a keyed file has no entry for ``path.name``.
    """
    file = path.parent / PALM_FILE
    if not file.is_file():
        return None
    try:
        palm = json.loads(file.read_text())
    except (OSError, ValueError) as exc:
        raise ModelError(f"{file}: unreadable ({exc})") from None
    if not isinstance(palm, dict):
        raise ModelError(f"{file}: expected a JSON object (a palm frame), got {type(palm)}")
    if not is_keyed(palm):
        return palm
    return palm.get(path.name)


def is_keyed(palm: dict) -> bool:
    """Whether a ``palm_frame.json`` object is keyed by model file name (every value an
    object: a palm frame's own values are numbers, lists and strings)."""
    return bool(palm) and all(isinstance(value, dict) for value in palm.values())


def missing_palm_fix(source: str | None) -> tuple[str | Fix, ...]:
    """The fix for a model file without a palm frame, as the error of `Hand` and
    ``exactgrasp inspect`` both give it: write ``palm_frame.json``, or pass ``palm=``.

    Parameters
    ----------
    source : str, optional
        The model file (None: a model compiled from text).

    Returns
    -------
    tuple of (str or Fix)
        Message parts, in the user's terms: where to write the palm frame and what it holds,
        or the ``palm=`` argument (a front end spells it as its own option).
    """
    file = Path(source).parent / PALM_FILE if source else None
    keyed = file is not None and file.is_file() and _keyed_file(file)
    if keyed:
        where = f'add "{Path(source).name}": {PALM_KEYS} to {file} (keyed by model file name)'
    else:
        into = "beside the model file" if file is None else str(file)
        where = f"write the palm frame into {into}: {PALM_KEYS}"
    return (
        f"{where} in the model's coordinates (metres): the centre of the palm's face, the "
        "direction out of the palm, the direction along the palm towards the thumb (or a "
        "chosen side), and the distance from the palm to the outside of the loosely closed "
        "fingers (see docs/tutorial.md, 'The palm frame')",
        Fix("palm", form="pass", shown=PALM_KEYS, before=", or "),
    )


def _keyed_file(file: Path) -> bool:
    try:
        palm = json.loads(file.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(palm, dict) and is_keyed(palm)


def palm_axis(value: Any, R: np.ndarray, what: str) -> np.ndarray:
    """An axis given as "+z"/"-y"/... of frame ``R`` (3, 3) or as a 3-vector in that frame.

    Returns
    -------
    numpy.ndarray, shape (3,)
        The axis in the coordinates ``R`` is expressed in.
    """
    if isinstance(value, str):
        key = value.strip().lower()
        if key not in AXES:
            raise ModelError(
                f"palm {what} {value!r}: use one of +x, -x, +y, -y, +z, -z or a 3-vector"
            )
        i = AXES[key]
        return R[:, i] if i >= 0 else -R[:, -i - 1]
    return R @ np.asarray(value, dtype=np.float64).reshape(3)


def resolve_palm(model: Any, palm: Any) -> PalmSpec | None:
    """Turn a `PalmSpec`, a dict (optionally naming a body or site) or None into a PalmSpec.

    Parameters
    ----------
    model : exactgrasp.hands.model.KinematicModel
        Anything with ``frame_in_hand(kind, name) -> (R (3, 3), p (3,))``; asked only when
        the dict names a body or site (evaluated at the default joints).
    palm : PalmSpec, dict or None
        See `exactgrasp.hands.loading.load_model`.

    Returns
    -------
    PalmSpec or None
    """
    if palm is None or isinstance(palm, PalmSpec):
        return palm
    if not isinstance(palm, Mapping):
        raise ModelError(f"palm must be a PalmSpec or a dict, got {type(palm)}")
    unknown = set(palm) - {"body", "site", "origin", "normal", "up", "depth", "note"}
    missing = {"normal", "up", "depth"} - set(palm)
    if unknown or missing or ("body" in palm and "site" in palm):
        raise ModelError(
            f"palm dict {dict(palm)}: expected keys normal, up, depth, optional origin and "
            "one of body/site (axes and origin are then in that frame); "
            f"unknown {sorted(unknown)}, missing {sorted(missing)}"
        )
    R, p = np.eye(3), np.zeros(3)
    for kind in ("body", "site"):
        if kind in palm:  # evaluated at the default joints
            R, p = model.frame_in_hand(kind, palm[kind])
    origin = p + R @ np.asarray(palm.get("origin", (0.0, 0.0, 0.0)), dtype=np.float64)
    return PalmSpec(
        origin,
        palm_axis(palm["normal"], R, "normal"),
        palm_axis(palm["up"], R, "up"),
        palm["depth"],
    )


def missing_palm(name: str, source: str | None) -> FrameError:
    """The error of a hand ``name`` (model file ``source``) built without a frame or a palm
    frame: write ``palm_frame.json`` or pass ``palm=`` (`missing_palm_fix`)."""
    return FrameError(f"{name} has no palm frame; ", *missing_palm_fix(source), ".")


def palm_missing(path: Path, palm: Any) -> bool:
    """Whether a model file loaded with ``palm`` has no palm frame (an unreadable
    ``palm_frame.json`` is a problem of its own, reported by the load)."""
    if palm is not None:
        return palm is False
    try:
        return palm_from_file(path) is None
    except ModelError:
        return False
