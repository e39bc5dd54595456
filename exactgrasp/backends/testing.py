"""Conformance checks for intersection backends: `check_backend` runs them all.

Every backend, built-in or from another package, must pass these: result shapes and dtypes,
finite non-negative volumes, refusal of poses that are not rigid motions (naming the pose),
zero for a far pose, the object's volume when it lies inside a hand link, the same volume
whatever units the meshes were given in, JSON parameters that rebuild the backend, and
repeatable results. The test grasps are built here from primitive boxes (no files).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from typing import NamedTuple

import numpy as np

from exactgrasp.backends.base import Backend
from exactgrasp.errors import BackendError
from exactgrasp.geometry import primitives
from exactgrasp.geometry.solid import Solid
from exactgrasp.grasp.grasp import Grasp
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.hand import Hand

__all__ = ["CHECKS", "NOT_RIGID", "Scene", "check_backend", "scene"]

#: Half sides (m) of the hand's two links, the second centred at `LINK_OFFSET`, and the object.
PALM_HALF = (0.05, 0.05, 0.02)
FINGER_HALF = (0.02, 0.02, 0.02)
LINK_OFFSET = (0.2, 0.0, 0.0)
OBJECT_HALF = (0.01, 0.01, 0.01)
#: Volumes given in two units may differ by rounding only: this fraction of the object volume.
UNITS_ATOL = 1e-6

#: Poses that are not rigid motions -> a phrase the refusal must contain.
NOT_RIGID = {
    "scaled": "not orthonormal",
    "slightly scaled": "not orthonormal",
    "sheared": "not orthonormal",
    "reflected": "a reflection",
    "projective last row": "last row",
    "NaN": "NaN",
}


class Scene(NamedTuple):
    """The test grasps and poses of the checks (lengths in m, volumes in m^3).

    Attributes
    ----------
    grasp : Grasp
        A two-link box hand (identity frame: canonical units are metres) and a cube inside
        its first link at the identity pose.
    grasp_mm : Grasp
        The same grasp with hand and object given in millimetres.
    poses : numpy.ndarray, shape (6, 4, 4)
        Identity (object inside link 0), half out of link 0 along +x, half out and turned
        30 degrees about z, inside link 1, far from the hand, three quarters out along -y.
    inside : tuple of int
        Indices of the poses that put the whole object inside one link.
    far : int
        Index of the pose with the object far from the hand.
    object_volume : float
        The cube's volume.
    """

    grasp: Grasp
    grasp_mm: Grasp
    poses: np.ndarray
    inside: tuple[int, ...]
    far: int
    object_volume: float


def _moved(mesh: tuple[np.ndarray, np.ndarray], offset) -> tuple[np.ndarray, np.ndarray]:
    V, F = mesh
    return V + np.asarray(offset, float), F


def _grasp(scale: float, units: str) -> Grasp:
    links = [
        primitives.box(np.multiply(PALM_HALF, scale)),
        _moved(primitives.box(np.multiply(FINGER_HALF, scale)), np.multiply(LINK_OFFSET, scale)),
    ]
    hand = Hand.from_meshes(links, frame=HandFrame.identity(), units=units)
    obj = Solid(*primitives.box(np.multiply(OBJECT_HALF, scale)), units=units, name="cube")
    return Grasp(hand, obj, name=f"conformance cube ({units})")


def _pose(offset=(0.0, 0.0, 0.0), turn_deg: float = 0.0) -> np.ndarray:
    c, s = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
    pose = np.eye(4)
    pose[:2, :2] = [[c, -s], [s, c]]
    pose[:3, 3] = offset
    return pose


def scene() -> Scene:
    """Build the grasps and poses every check uses.

    Returns
    -------
    Scene
    """
    grasp = _grasp(1.0, "m")
    poses = np.stack(
        [
            _pose(),
            _pose((PALM_HALF[0], 0.0, 0.0)),
            _pose((PALM_HALF[0], 0.0, 0.0), turn_deg=30.0),
            _pose(LINK_OFFSET),
            _pose((1.0, 1.0, 1.0)),
            _pose((0.0, -PALM_HALF[1] - OBJECT_HALF[1] / 2, 0.0)),
        ]
    )
    return Scene(grasp, _grasp(1000.0, "mm"), poses, (0, 3), 4, grasp.object.volume)


def _fail(backend: Backend, check: str, what: str) -> None:
    raise AssertionError(f"{type(backend).__name__} fails {check!r}: {what}")


def _volumes(backend: Backend, grasp: Grasp, poses: np.ndarray, check: str) -> np.ndarray:
    out = backend.volumes(grasp, poses)
    if not isinstance(out, np.ndarray | np.floating):
        _fail(backend, check, f"volumes returned a {type(out).__name__}, not a numpy array")
    out = np.asarray(out)
    if out.shape != poses.shape[:-2] or out.dtype != np.float64:
        _fail(
            backend,
            check,
            f"poses of shape {poses.shape} gave volumes of shape {out.shape} and dtype "
            f"{out.dtype}; expected shape {poses.shape[:-2]}, float64",
        )
    if not (np.isfinite(out).all() and (out >= 0).all()):
        _fail(backend, check, f"volumes must be finite and >= 0, got {out.tolist()}")
    return out


def check_shapes(backend: Backend, sc: Scene, rtol: float | None) -> None:
    """Shape ``poses.shape[:-2]``, float64, finite and >= 0 for (4, 4), (n, 4, 4), (a, b, 4, 4);
    the same values whatever the stacking."""
    flat = _volumes(backend, sc.grasp, sc.poses, "shapes")
    single = _volumes(backend, sc.grasp, sc.poses[1], "shapes")
    grid = _volumes(backend, sc.grasp, sc.poses.reshape(2, 3, 4, 4), "shapes")
    if not (np.array_equal(single, flat[1]) and np.array_equal(grid.ravel(), flat)):
        _fail(backend, "shapes", "a pose's volume depends on how the poses are stacked")


def _bad_pose(kind: str) -> np.ndarray:
    pose = np.eye(4)
    if kind == "scaled":
        pose[:3, :3] *= 1.5
    elif kind == "slightly scaled":
        pose[:3, :3] *= 1.0 + 1e-7
    elif kind == "sheared":
        pose[0, 1] = 0.3
    elif kind == "reflected":
        pose[0, 0] = -1.0
    elif kind == "projective last row":
        pose[3, 0] = 0.2
    elif kind == "NaN":
        pose[1, 2] = np.nan
    return pose


def _refusal(backend: Backend, sc: Scene, poses: np.ndarray, what: str) -> str:
    try:
        backend.volumes(sc.grasp, poses)
    except BackendError as exc:
        return str(exc)
    except Exception as exc:
        _fail(backend, "rigid poses", f"{what} raised {type(exc).__name__}, not BackendError")
    _fail(backend, "rigid poses", f"{what} was accepted")
    return ""


def check_rigid_poses(backend: Backend, sc: Scene, rtol: float | None) -> None:
    """Refuses each kind of non-rigid pose with a `BackendError` naming it (``poses[2]``, or
    ``poses`` for a single pose) and a wrong shape; accepts rigid poses within rounding."""
    for kind, phrase in NOT_RIGID.items():
        poses = np.tile(np.eye(4), (4, 1, 1))
        poses[2] = _bad_pose(kind)
        message = _refusal(backend, sc, poses, f"a {kind} pose at index 2")
        if "poses[2]" not in message or phrase not in message:
            _fail(
                backend,
                "rigid poses",
                f"the refusal of a {kind} pose must name poses[2] and say {phrase!r}: {message}",
            )
        message = _refusal(backend, sc, _bad_pose(kind), f"a single {kind} pose")
        if "poses[" in message or phrase not in message:
            _fail(
                backend,
                "rigid poses",
                f"a single {kind} pose must be named without an index: {message}",
            )
    for shape in ((4, 3, 3), (4,), (3, 4)):
        message = _refusal(backend, sc, np.zeros(shape), f"poses of shape {shape}")
        if "shape" not in message:
            _fail(backend, "rigid poses", f"the refusal of shape {shape} must say so: {message}")
    rounded = np.tile(np.eye(4), (2, 1, 1))
    rounded[1, :3, :3] *= 1.0 + 1e-12
    _volumes(backend, sc.grasp, rounded, "rigid poses")


def check_far_pose(backend: Backend, sc: Scene, rtol: float | None) -> None:
    """A pose that puts the object far from the hand gives exactly zero."""
    far = _volumes(backend, sc.grasp, sc.poses[sc.far], "far pose")
    if far != 0.0:
        _fail(backend, "far pose", f"the object 1.7 m from the hand gave volume {float(far)!r}")


def check_containment(backend: Backend, sc: Scene, rtol: float | None) -> None:
    """The object inside a hand link gives its own volume within ``rtol`` (the backend's
    `volume_rtol` by default); a backend that claims no accuracy must give more than zero."""
    tol = backend.volume_rtol if rtol is None else rtol
    got = _volumes(backend, sc.grasp, sc.poses[list(sc.inside)], "containment")
    if tol is None:
        ok = (got > 0).all()
        want = "more than 0"
    else:
        ok = (np.abs(got - sc.object_volume) <= tol * sc.object_volume).all()
        want = f"{sc.object_volume:.6g} m^3 within {tol:g} relative"
    if not ok:
        _fail(backend, "containment", f"the object inside a link gave {got.tolist()}; want {want}")


def check_units(backend: Backend, sc: Scene, rtol: float | None) -> None:
    """The grasp given in millimetres gives the same volumes (canonical m^3) as in metres."""
    metres = _volumes(backend, sc.grasp, sc.poses, "units")
    millimetres = _volumes(backend, sc.grasp_mm, sc.poses, "units")
    if not np.allclose(millimetres, metres, rtol=0, atol=UNITS_ATOL * sc.object_volume):
        _fail(
            backend,
            "units",
            f"the grasp in mm gave {millimetres.tolist()}, in m {metres.tolist()}",
        )


def check_params(backend: Backend, sc: Scene, rtol: float | None) -> None:
    """A name; `params` survive a JSON round trip and rebuild an equal backend."""
    if not (isinstance(backend.name, str) and backend.name):
        _fail(backend, "params", f"the backend's name must be a non-empty str: {backend.name!r}")
    params = backend.params
    try:
        text = json.dumps(params, sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as exc:
        _fail(backend, "params", f"params {params!r} are not JSON ({exc})")
    if json.loads(text) != params:
        _fail(backend, "params", f"params {params!r} change in a JSON round trip")
    rebuilt = type(backend)(**json.loads(text))
    if rebuilt.params != params:
        _fail(backend, "params", f"rebuilt from {params!r}, the backend has {rebuilt.params!r}")


def check_repeatable(backend: Backend, sc: Scene, rtol: float | None) -> None:
    """The same poses give the same volumes again, and from a backend rebuilt from `params`."""
    first = _volumes(backend, sc.grasp, sc.poses, "repeatable")
    again = _volumes(backend, sc.grasp, sc.poses, "repeatable")
    rebuilt = _volumes(type(backend)(**backend.params), sc.grasp, sc.poses, "repeatable")
    if not (np.array_equal(first, again) and np.array_equal(first, rebuilt)):
        _fail(
            backend,
            "repeatable",
            f"volumes {first.tolist()}, then {again.tolist()}, rebuilt {rebuilt.tolist()}",
        )


#: Every check by name, in the order `check_backend` runs them.
CHECKS: dict[str, Callable[[Backend, Scene, float | None], None]] = {
    "params": check_params,
    "shapes": check_shapes,
    "rigid poses": check_rigid_poses,
    "far pose": check_far_pose,
    "containment": check_containment,
    "units": check_units,
    "repeatable": check_repeatable,
}


def check_backend(
    backend: Backend, rtol: float | None = None, checks: Iterable[str] | None = None
) -> None:
    """Run the conformance checks on a backend instance.

    Parameters
    ----------
    backend : Backend
        The instance to check, with the parameters it will be used with.
    rtol : float, optional
        Relative accuracy demanded where the object lies inside a hand link; default the
        backend's ``volume_rtol`` (None there: only a positive volume is demanded).
    checks : iterable of str, optional
        Names from `CHECKS` to run; default all.

    Raises
    ------
    AssertionError
        At the first failed check, naming the backend, the check and what was wrong.
    """
    if not isinstance(backend, Backend):
        raise TypeError(f"check_backend needs a Backend instance, got {type(backend).__name__}.")
    names = list(CHECKS) if checks is None else list(checks)
    unknown = sorted(set(names) - set(CHECKS))
    if unknown:
        raise ValueError(f"unknown checks {unknown}; choose from {list(CHECKS)}.")
    sc = scene()
    for name in names:
        CHECKS[name](backend, sc, rtol)
