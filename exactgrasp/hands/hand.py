"""Hands: posed link meshes, joints, and the canonical frame.

A `Hand` wraps a kinematic model (a rigid set of meshes, or an MJCF/URDF model compiled by
mujoco, see `exactgrasp.hands.model`) at one joint configuration, with its `HandFrame`. Its volume
is the volume of the UNION of its links: real link meshes overlap and an overlap is hand once.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from functools import cached_property
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import trimesh

from exactgrasp.errors import JointError, MeshError
from exactgrasp.geometry.manifold import union_volume
from exactgrasp.geometry.solid import Solid
from exactgrasp.hands.frame import FrameError, HandFrame


class KinematicModel(Protocol):
    """What a `Hand` needs of a model (see `exactgrasp.hands.model.KinematicModel`)."""

    name: str
    joint_names: tuple[str, ...]
    joint_limits: dict[str, tuple[float, float]]
    default_joints: dict[str, float]
    palm: Any

    def check_joints(self, joints: dict, on_limit: str = "error") -> dict[str, float]: ...

    def link_meshes(
        self, joints: dict[str, float]
    ) -> list[tuple[str, np.ndarray, np.ndarray]]: ...


class RigidModel:
    """A hand without joints: a fixed set of closed link meshes in hand coordinates.

    Parameters
    ----------
    links : sequence of (name, Solid)
    name : str
    """

    joint_names: tuple[str, ...] = ()
    joint_limits: dict[str, tuple[float, float]] = {}  # noqa: RUF012 - read-only by use
    default_joints: dict[str, float] = {}  # noqa: RUF012
    palm = None

    def __init__(self, links: Sequence[tuple[str, Solid]], name: str = "rigid hand"):
        self.name = name
        self._links = list(links)

    def check_joints(self, joints: dict | None, on_limit: str = "error") -> dict[str, float]:
        if joints:
            raise JointError(
                f"{self.name} is a rigid hand (built from meshes) and has no joints, but "
                f"joints {sorted(joints)} were given; load an MJCF/URDF model with "
                "Hand.from_mjcf/Hand.from_urdf for an articulated hand."
            )
        return {}

    def link_meshes(self, joints: dict[str, float]) -> list[tuple[str, np.ndarray, np.ndarray]]:
        return [(name, solid.vertices, solid.faces) for name, solid in self._links]


class Hand:
    """A hand at one joint configuration, with its canonical frame.

    Parameters
    ----------
    model : KinematicModel
        Rigid meshes or an articulated model.
    joints : dict of str to float, optional
        Joint values (rad, or m for slide joints); missing joints take the model's defaults.
    frame : HandFrame, optional
        Defaults to the model's palm frame; a model without one needs it explicitly.
    on_limit : {"error", "clip"}
        Joint values outside the limits raise `JointError`, or are clipped with a warning.
    source : dict, optional
        How to rebuild this hand from files (for `Grasp.save`); set by the constructors.
    """

    def __init__(
        self,
        model: KinematicModel,
        joints: dict[str, float] | None = None,
        frame: HandFrame | None = None,
        on_limit: str = "error",
        source: dict | None = None,
    ):
        self.model = model
        self.on_limit = on_limit
        self.joints: dict[str, float] = model.check_joints(dict(joints or {}), on_limit=on_limit)
        if frame is None:
            palm = getattr(model, "palm", None)
            if palm is None:
                raise FrameError(
                    f"{model.name} names no palm frame; pass frame=HandFrame.from_palm(origin, "
                    "normal, up, depth) (the paper's frame) or frame=HandFrame.identity()."
                )
            frame = _frame_from_palm(palm)
        if not isinstance(frame, HandFrame):
            raise FrameError(f"frame must be a HandFrame, got {type(frame).__name__}.")
        self.frame = frame
        self.source = source

    # -- constructors -------------------------------------------------------------------------

    @classmethod
    def from_file(
        cls,
        path: str | os.PathLike,
        frame: HandFrame | None = None,
        units: str = "m",
        repair: bool = False,
    ) -> Hand:
        """A rigid hand from one mesh file: one link, the solid its closed shells bound.

        Overlapping shells are merged into one solid with a warning and a shell crossing
        itself is refused (see `exactgrasp.geometry.shells.resolve_shells`).

        Parameters
        ----------
        path : path-like
            Any mesh file trimesh reads.
        frame : HandFrame
            Required: a mesh file names no palm.
        units : {"m", "cm", "mm", "inch"}
        repair : bool
            See `Solid`.

        Returns
        -------
        Hand
        """
        solid = Solid.from_file(path, units=units, repair=repair)
        model = RigidModel([(Path(path).stem, solid)], name=str(path))
        source = {"type": "file", "path": str(Path(path)), "units": units, "repair": repair}
        return cls(model, frame=frame, source=source)

    @classmethod
    def from_meshes(
        cls,
        meshes: Sequence[Any],
        frame: HandFrame | None = None,
        names: Sequence[str] | None = None,
        units: str = "m",
    ) -> Hand:
        """A rigid hand from several link meshes (trimesh meshes, Solids, or (V, F) pairs).

        Parameters
        ----------
        meshes : sequence
            Closed link meshes in hand coordinates; links may overlap each other, and a link
            of several overlapping shells is merged into the solid they bound (with a
            warning; see `exactgrasp.geometry.solid.Solid`).
        frame : HandFrame
            Required.
        names : sequence of str, optional
            Link names (default ``link0``, ``link1``, ...).
        units : str
            Unit of meshes that are not already `Solid`.

        Returns
        -------
        Hand
        """
        if len(meshes) == 0:
            raise MeshError("from_meshes needs at least one link mesh, got none.")
        names = list(names) if names is not None else [f"link{i}" for i in range(len(meshes))]
        if len(names) != len(meshes):
            raise JointError(f"{len(names)} names for {len(meshes)} meshes; give one per mesh.")
        links = [
            (name, _as_solid(mesh, units, name)) for name, mesh in zip(names, meshes, strict=True)
        ]
        return cls(RigidModel(links, name="hand from meshes"), frame=frame)

    @classmethod
    def from_mjcf(
        cls,
        path: str | os.PathLike,
        joints: dict[str, float] | None = None,
        frame: HandFrame | None = None,
        on_limit: str = "error",
        **model_kwargs: Any,
    ) -> Hand:
        """An articulated hand from an MJCF model, compiled by mujoco.

        Parameters
        ----------
        path : path-like
        joints : dict, optional
        frame : HandFrame, optional
            Defaults to the model's palm frame (see `exactgrasp.hands.model.load_model`).
        on_limit : {"error", "clip"}
        **model_kwargs
            `exactgrasp.hands.model.load_model` options: ``root_body``, ``geometry``,
            ``tessellation``, ``palm``, ``couplings``.

        Returns
        -------
        Hand
        """
        model = _load_model_cached(Path(path), model_kwargs)
        source = {"type": "model", "path": str(Path(path)), "options": _jsonable(model_kwargs)}
        return cls(model, joints=joints, frame=frame, on_limit=on_limit, source=source)

    from_urdf = from_mjcf

    # -- joints -------------------------------------------------------------------------------

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Independent joints, in model order."""
        return tuple(self.model.joint_names)

    @property
    def joint_limits(self) -> dict[str, tuple[float, float]]:
        """``{name: (lower, upper)}``, radians (metres for slide joints)."""
        return dict(self.model.joint_limits)

    def with_joints(self, joints: dict[str, float], on_limit: str | None = None) -> Hand:
        """A copy with some joints changed (the others keep their values).

        Parameters
        ----------
        joints : dict of str to float
        on_limit : {"error", "clip"}, optional
            Defaults to this hand's setting.

        Returns
        -------
        Hand
        """
        # Unknown names are reported by the model's own check (it lists the valid ones).
        merged = {**self.joints, **joints}
        return Hand(
            self.model,
            joints=merged,
            frame=self.frame,
            on_limit=on_limit or self.on_limit,
            source=self.source,
        )

    def perturb_joints(self, fraction: float, rng: Any = None) -> Hand:
        """A copy with every joint moved by noise of ``fraction`` of its range.

        See `exactgrasp.grasp.noise.joint_noise` for the distribution; values are clipped to the
        limits.

        Parameters
        ----------
        fraction : float
            E.g. 0.01 .. 0.05 for the paper's 1-5 %.
        rng : numpy.random.Generator or int, optional

        Returns
        -------
        Hand
        """
        from exactgrasp.grasp.noise import joint_noise

        return self.with_joints(joint_noise(self, fraction, rng), on_limit="clip")

    # -- geometry -----------------------------------------------------------------------------

    @cached_property
    def _posed_links(self) -> list[tuple[str, np.ndarray, np.ndarray]]:
        return [
            (name, np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64))
            for name, v, f in self.model.link_meshes(self.joints)
        ]

    @property
    def link_names(self) -> list[str]:
        """Names of the posed links, in `link_meshes` order."""
        return [name for name, _, _ in self._posed_links]

    def link_arrays(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Posed links as arrays: ``[(vertices (n, 3) m, faces (m, 3)), ...]``, hand frame."""
        return [(v, f) for _, v, f in self._posed_links]

    def link_meshes(self) -> list[trimesh.Trimesh]:
        """Posed links as trimesh meshes, in hand coordinates (m)."""
        return [
            trimesh.Trimesh(v.copy(), f.copy(), process=False, metadata={"name": name})
            for name, v, f in self._posed_links
        ]

    def canonical_links(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Posed links in the canonical frame: ``[(vertices (n, 3), faces (m, 3)), ...]``."""
        return [(self.frame.apply(v), f) for v, f in self.link_arrays()]

    @cached_property
    def volume(self) -> float:
        """Volume of the union of the posed links, m^3."""
        return union_volume(self.link_arrays(), name=self.model.name)

    @cached_property
    def geometry_hash(self) -> str:
        """SHA-256 of the posed link arrays and the frame (hex)."""
        import hashlib

        digest = hashlib.sha256()
        for v, f in self.link_arrays():
            digest.update(np.ascontiguousarray(v).tobytes())
            digest.update(np.ascontiguousarray(f).tobytes())
        digest.update(self.frame.matrix.tobytes())
        return digest.hexdigest()

    def __repr__(self) -> str:
        joints = ", ".join(f"{k}={v:.4g}" for k, v in self.joints.items())
        return f"Hand({self.model.name!r}, {len(self._posed_links)} links, joints: {{{joints}}})"


#: Compiled file models, keyed by file identity and options: reading many grasps of one hand
#: (34 cereal-box grasps, a batch) compiles its URDF once, not once per grasp.
_MODEL_CACHE: dict[tuple, Any] = {}
_MODEL_CACHE_SIZE = 8


def _file_identity(path: Path) -> tuple:
    try:
        stat = path.stat()
    except OSError:
        return (str(path), None)
    return (str(path.resolve()), stat.st_mtime_ns, stat.st_size)


def _load_model_cached(path: Path, options: dict) -> KinematicModel:
    """`exactgrasp.hands.model.load_model`, memoised while the file (and its palm_frame.json) is
    unchanged. Models are shared read-only: a Hand never changes its model."""
    import json

    from exactgrasp.hands.model import load_model

    key = (
        _file_identity(path),
        _file_identity(path.parent / "palm_frame.json"),
        json.dumps(_jsonable(options), sort_keys=True, default=repr),
    )
    if key not in _MODEL_CACHE:
        if len(_MODEL_CACHE) >= _MODEL_CACHE_SIZE:
            _MODEL_CACHE.pop(next(iter(_MODEL_CACHE)))
        _MODEL_CACHE[key] = load_model(path, **options)
    return _MODEL_CACHE[key]


def _frame_from_palm(palm: Any) -> HandFrame:
    if isinstance(palm, HandFrame):
        return palm
    if isinstance(palm, dict):
        return HandFrame.from_dict(palm)
    return HandFrame.from_palm(palm.origin, palm.normal, palm.up, palm.depth)


def _as_solid(mesh: Any, units: str, name: str) -> Solid:
    if isinstance(mesh, Solid):
        return mesh
    if isinstance(mesh, trimesh.Trimesh):
        return Solid(mesh.vertices, mesh.faces, units=units, name=name)
    if isinstance(mesh, tuple | list) and len(mesh) == 2:
        return Solid(mesh[0], mesh[1], units=units, name=name)
    raise JointError(
        f"link {name}: expected a trimesh.Trimesh, a Solid or a (vertices, faces) pair, got "
        f"{type(mesh).__name__}."
    )


def _jsonable(options: dict) -> dict:
    out = {}
    for key, value in options.items():
        if hasattr(value, "__dataclass_fields__"):
            value = {k: getattr(value, k) for k in value.__dataclass_fields__}
        elif isinstance(value, HandFrame):
            value = value.to_dict()
        out[key] = value
    return out
