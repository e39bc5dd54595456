"""A grasp: a hand, an object and the object's pose in the hand, with JSON files.

Grasp files follow ``grasp-file.schema.json`` (`exactgrasp.grasp.schema`, described key by key
in ``docs/grasp-file.md``): the keys of the shared Barrett data (``object`` and ``hand_model``
relative to the file, ``object_units``, ``object_pose_in_hand`` from object metres to hand
coordinates, ``joints``) and those written here (``format``, ``hand`` for hands that are not a
model file, ``hand_options``, ``hand_frame``). Files are checked against the schema before
anything is read.
"""

from __future__ import annotations

import hashlib
import json
import os
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.errors import Fix, GraspError, GraspFileError
from exactgrasp.geometry.se3 import rigid_defect
from exactgrasp.geometry.solid import Solid
from exactgrasp.grasp.files import (
    OBJECT_KEYS,
    file_terms,
    read_hand,
    read_object,
    write_hand,
    write_object,
)
from exactgrasp.grasp.schema import check_grasp_data
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.hand import Hand

__all__ = ["FORMAT", "Grasp", "check_pose"]

#: The ``format`` tag of grasp files written here.
FORMAT = "exactgrasp.grasp/1"
#: Tolerance of `check_pose` on ``R^T R = I``, ``det R = 1`` and the last row, loose enough for
#: a rotation written out to six decimals.
POSE_ATOL = 1e-5


def check_pose(pose: Any, name: str = "object_pose") -> np.ndarray:
    """Validate a rigid 4x4 transform.

    Parameters
    ----------
    pose : array_like, shape (4, 4)
    name : str
        Used in the message.

    Returns
    -------
    numpy.ndarray, shape (4, 4), float64
    """
    arr = np.array(pose, dtype=np.float64)  # a copy: the caller's array may change later
    if arr.shape != (4, 4):
        raise GraspError(f"{name} must be a 4x4 matrix, got shape {arr.shape}.")
    if not np.all(np.isfinite(arr)):
        raise GraspError(f"{name} contains NaN or infinite entries.")
    what = rigid_defect(arr, POSE_ATOL)
    if what is not None:
        raise GraspError(
            f"{name} is not a rigid transform: {what}. Give a rotation (orthonormal, "
            f"determinant +1, to {POSE_ATOL:g}) and a translation in metres, last row 0 0 0 1; "
            "a mesh in other units takes ",
            # Where the object's length unit is set: a scale belongs there, not in the pose.
            Fix("units", form="where", python="Solid(..., units=...)"),
            ", not a scale in the pose, and a mirrored object a mirrored mesh.",
        )
    return arr


class Grasp:
    """A hand, an object and where the object sits in the hand.

    Parameters
    ----------
    hand : Hand
    object : Solid
        In its own coordinates (m).
    object_pose : array_like, shape (4, 4), optional
        Rigid map from object coordinates (m) to hand coordinates (m); identity by default.
    name : str, optional
    """

    def __init__(self, hand: Hand, object: Solid, object_pose: Any = None, name: str = ""):
        if not isinstance(hand, Hand):
            raise GraspError(f"hand must be an exactgrasp Hand, got {type(hand).__name__}.")
        if not isinstance(object, Solid):
            raise GraspError(
                f"object must be an exactgrasp Solid, got {type(object).__name__}; wrap meshes "
                "with Solid.from_trimesh or Solid.from_file."
            )
        self.hand = hand
        self.object = object
        self.object_pose = check_pose(np.eye(4) if object_pose is None else object_pose)
        self.name = name

    # -- what backends read -------------------------------------------------------------------

    @property
    def frame(self) -> HandFrame:
        """The hand's canonical frame."""
        return self.hand.frame

    @cached_property
    def _object_to_canonical(self) -> np.ndarray:
        return self.frame.matrix @ self.object_pose

    def canonical_hand_links(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Hand links in the canonical frame: ``[(vertices (n, 3), faces (m, 3) int64)]``."""
        return self.hand.canonical_links()

    def canonical_object_bodies(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The object at the grasp pose, canonical frame: ``[(vertices (n, 3), faces)]``.

        One entry holding every shell of the object (a hollow object's inner shell must stay
        with its outer one).
        """
        m = self._object_to_canonical
        return [(self.object.vertices @ m[:3, :3].T + m[:3, 3], self.object.faces)]

    def canonical_object_surface_samples(self) -> np.ndarray | None:
        """User-supplied surface samples of the object in the canonical frame, or None.

        Returns
        -------
        numpy.ndarray, shape (k, 3), or None
        """
        samples = self.object.surface_samples
        if samples is None:
            return None
        m = self._object_to_canonical
        return samples @ m[:3, :3].T + m[:3, 3]

    @property
    def canonical_hand_volume(self) -> float:
        """Hand volume (union of links) in canonical units: ``hand.volume * scale**3``."""
        return self.hand.volume * self.frame.scale**3

    @property
    def hand_key(self) -> str:
        """Hash of the hand's canonical geometry (for backend caches)."""
        return self.hand.geometry_hash

    @cached_property
    def object_key(self) -> str:
        """Hash of the object's canonical geometry and samples (for backend caches)."""
        digest = hashlib.sha256(self.object.hash.encode())
        digest.update(self._object_to_canonical.tobytes())
        return digest.hexdigest()

    @property
    def geometry_key(self) -> str:
        """Hash of everything a backend sees."""
        return hashlib.sha256((self.hand_key + self.object_key).encode()).hexdigest()

    # -- files --------------------------------------------------------------------------------

    @classmethod
    def from_file(cls, path: str | os.PathLike, **overrides: Any) -> Grasp:
        """Read a grasp JSON file (the shared Barrett data's schema, or one written by `save`).

        Parameters
        ----------
        path : path-like
        **overrides
            ``units`` (the object's), ``repair`` (object repair), ``on_limit``
            (``"error"``/``"clip"``), ``surface_samples`` (path or array) override what the
            file says (``object_units``, ``object_repair``, ``on_limit``,
            ``object_surface_samples``).

        Returns
        -------
        Grasp
        """
        path = Path(path)
        if not path.exists():
            raise GraspFileError(f"{path}: no such grasp file; check the path.")
        try:
            data = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise GraspFileError(f"{path}: not valid JSON ({exc}).") from exc
        if not isinstance(data, dict):
            raise GraspFileError(f"{path}: expected a JSON object at the top level.")
        # An absolute folder: paths read from the file stay valid if the working folder changes.
        base_dir = path.parent.resolve()
        return cls.from_dict(data, base_dir=base_dir, source=str(path), **overrides)

    @classmethod
    def from_dict(
        cls, data: dict, base_dir: str | os.PathLike = ".", source: str = "<dict>", **overrides
    ) -> Grasp:
        """Build from the parsed JSON (paths resolved against ``base_dir``).

        Parameters
        ----------
        data : dict
            A grasp file's content (see ``docs/grasp-file.md``).
        base_dir : path-like
            Folder the file's paths are relative to.
        source : str
            The file, for messages.
        **overrides
            As `from_file`.

        Returns
        -------
        Grasp

        Raises
        ------
        GraspFileError
            Keys that break the schema (unknown, missing, wrong type), missing files, and
            objects or hand models that cannot be read (naming the key and the fix).
        JointError
            Joint values the hand refuses.
        """
        base_dir = Path(base_dir)
        check_grasp_data(data, source)
        obj = read_object(data, base_dir, source, overrides)
        hand = read_hand(data, base_dir, source, overrides)
        try:
            pose = check_pose(data["object_pose_in_hand"], f"{source}: object_pose_in_hand")
        except GraspError as exc:
            raise exc.respelled(file_terms, keys=OBJECT_KEYS, cls=GraspFileError) from exc
        return cls(hand, obj, pose, name=data.get("name", Path(source).stem))

    def to_dict(self, base_dir: str | os.PathLike = ".", sidecar_stem: str = "grasp") -> dict:
        """JSON-serialisable form; meshes not read from files are written beside it.

        Parameters
        ----------
        base_dir : path-like
            Folder the JSON will live in (paths are written relative to it).
        sidecar_stem : str
            Stem for mesh files written for in-memory geometry.
        """
        base_dir = Path(base_dir)
        data: dict[str, Any] = {"format": FORMAT, "name": self.name}
        data.update(write_object(self.object, base_dir, sidecar_stem))
        data["object_pose_in_hand"] = self.object_pose.tolist()
        data.update(write_hand(self.hand, base_dir, sidecar_stem))
        return data

    def save(self, path: str | os.PathLike) -> Path:
        """Write the grasp as JSON (and sidecar meshes for in-memory geometry).

        Returns
        -------
        pathlib.Path
            The JSON file written.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        data = self.to_dict(path.parent, sidecar_stem=path.stem)
        path.write_text(json.dumps(data, indent=1))
        return path

    def __repr__(self) -> str:
        return f"Grasp({self.name!r}, hand={self.hand!r}, object={self.object!r})"
