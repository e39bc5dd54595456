"""Palm frames of hand models: `PalmSpec` and turning a palm description into one."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.errors import ModelError

__all__ = ["AXES", "PalmSpec", "missing_palm_fix", "palm_axis", "resolve_palm"]

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


def missing_palm_fix(source: str | None) -> str:
    """The one fix for a model file without a palm frame, as the error of `Hand` and
    ``exactgrasp inspect`` both give it.

    Parameters
    ----------
    source : str, optional
        The model file (None: a model compiled from text).

    Returns
    -------
    str
        Where to write ``palm_frame.json`` and what it holds, in the user's terms.
    """
    where = "beside the model file" if not source else str(Path(source).parent / "palm_frame.json")
    return (
        f"write the palm frame into {where}: "
        '{"origin": [x, y, z], "normal": [x, y, z], "up": [x, y, z], "depth": d} in the '
        "model's coordinates (metres): the centre of the palm's face, the direction out of the "
        "palm, the direction along the palm towards the thumb (or a chosen side), and the "
        "distance from the palm to the outside of the loosely closed fingers "
        "(see docs/tutorial.md, 'The palm frame')"
    )


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
