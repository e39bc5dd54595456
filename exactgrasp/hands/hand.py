"""Hands: posed link meshes, joints, and the canonical frame.

A `Hand` wraps a hand model (a `RigidModel` of fixed meshes, or an MJCF/URDF model compiled by
mujoco, see `exactgrasp.hands.model`) at one joint configuration, with its `HandFrame`. Its volume
is the volume of the UNION of its links: real link meshes overlap and an overlap is hand once.
`HandModel` is what a Hand needs of its model.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from functools import cached_property
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import trimesh

from exactgrasp.errors import Fix, FrameError, JointError, MeshError, ModelError
from exactgrasp.geometry.intake import REPAIR
from exactgrasp.geometry.solid import Solid
from exactgrasp.given import given
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.loading import jsonable, load_model_cached
from exactgrasp.hands.noise import joint_noise
from exactgrasp.hands.palm import missing_palm, palm_missing
from exactgrasp.hands.prepared import union_volume_of_links

__all__ = ["Hand", "HandModel", "RigidModel"]


class HandModel(Protocol):
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
    model : HandModel
        Rigid meshes (`RigidModel`) or an articulated model
        (`exactgrasp.hands.model.KinematicModel`).
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
        model: HandModel,
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
            if palm is None and isinstance(model, RigidModel):
                raise FrameError(
                    f"{model.name} names no palm frame; ",
                    Fix(
                        "frame",
                        form="pass",
                        python="pass frame=HandFrame.from_palm(origin, normal, up, depth) "
                        "(the paper's frame) or frame=HandFrame.identity()",
                    ),
                    ".",
                )
            if palm is None:
                source = getattr(model, "source", None)
                raise missing_palm(model.name, source)
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
        repair: bool = REPAIR,
    ) -> Hand:
        """A rigid hand from one mesh file: one link, the solid its closed shells bound.

        Overlapping shells are merged into one solid with a warning, and a shell crossing or
        touching itself is cut into the solid it bounds (see
        `exactgrasp.geometry.shells.resolve_shells`).

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
            raise MeshError(f"{len(names)} names for {len(meshes)} meshes; give one per mesh.")
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
        *,
        root_body: str | None = None,
        geometry: str | None = None,
        tessellation: int | None = None,
        palm: Any = None,
        couplings: dict | None = None,
        package_dirs: Any = None,
        repair: bool | None = None,
        angle: str | None = None,
    ) -> Hand:
        """An articulated hand from an MJCF or URDF model, compiled by mujoco.

        ``Hand.from_urdf`` is the same constructor. The model options are those of
        `exactgrasp.hands.loading.load_model`; None leaves an option at its default (and out
        of ``Hand.source``, which `Grasp.save` writes as ``hand_options``).

        Parameters
        ----------
        path : path-like
        joints : dict, optional
        frame : HandFrame, optional
            Defaults to the model's palm frame (see `exactgrasp.hands.loading.load_model`).
        on_limit : {"error", "clip"}
        root_body : str, optional
            The hand's root body in a scene file.
        geometry : {"collision", "visual", "all"}, optional
        tessellation : int, optional
        palm : PalmSpec, dict or False, optional
        couplings : dict, optional
        package_dirs : dict or list of paths, optional
            Where ``package://NAME/...`` and ``model://NAME/...`` mesh names are found.
        repair : bool, optional
            Repair open mesh geoms of the hand (with a warning per geom).
        angle : {"degree", "radian"}, optional
            The unit of an MJCF file's angles; None: as the file says.

        Returns
        -------
        Hand
        """
        options = given(
            {
                "root_body": root_body,
                "geometry": geometry,
                "tessellation": tessellation,
                "palm": palm,
                "couplings": couplings,
                "package_dirs": package_dirs,
                "repair": repair,
                "angle": angle,
            }
        )
        try:
            model = load_model_cached(Path(path), options)
        except ModelError as exc:
            if frame is None and palm_missing(Path(path), palm):
                problem = missing_palm(Path(path).stem, str(path))
                raise ModelError.report(str(path), [exc, problem]) from exc
            raise
        source = {"type": "model", "path": str(Path(path)), "options": jsonable(options)}
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

        See `exactgrasp.hands.noise.joint_noise` for the distribution; values are clipped to the
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
        """Volume of the union of the posed links, m^3.

        Summed from the links' volumes and their overlaps, with each link's solid prepared
        once per process (`exactgrasp.hands.prepared`); a single link is its own volume.
        """
        return union_volume_of_links(self)

    @cached_property
    def geometry_hash(self) -> str:
        """SHA-256 of the posed link arrays and the frame (hex)."""
        digest = hashlib.sha256()
        for v, f in self.link_arrays():
            digest.update(np.ascontiguousarray(v).tobytes())
            digest.update(np.ascontiguousarray(f).tobytes())
        digest.update(self.frame.matrix.tobytes())
        return digest.hexdigest()

    def __repr__(self) -> str:
        joints = ", ".join(f"{k}={v:.4g}" for k, v in self.joints.items())
        return f"Hand({self.model.name!r}, {len(self._posed_links)} links, joints: {{{joints}}})"


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
    raise MeshError(
        f"link {name}: expected a trimesh.Trimesh, a Solid or a (vertices, faces) pair, got "
        f"{type(mesh).__name__}."
    )
