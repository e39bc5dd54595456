"""Closing a hand's fingers onto an object until they touch it, GraspIt!-style (auto-grasp).

`close_fingers` opens the closing joints to their lower limits, moves the object out along the
palm normal if the open hand still penetrates it (repairing recorded grasps that sink into
their objects), then closes each finger until its links touch the object within a tolerance
or its joints reach their upper limits. Contact is found by conservative advancement on exact
mesh distances (coal or python-fcl BVHs, built once per link and per object), with bisection
as the safety net, so no step passes through the object. See ``docs/closing.md``.
"""

from __future__ import annotations

import math
import numbers
import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np

from exactgrasp.errors import ClosingError, JointError, require, warn_caller
from exactgrasp.geometry.solid import Solid
from exactgrasp.grasp import Grasp, check_pose
from exactgrasp.hands.hand import Hand

__all__ = ["ClosingError", "ClosingResult", "FingerResult", "close_fingers", "close_grasp"]

#: A joint whose axis is within this angle of the palm normal spreads or twists the fingers
#: (Barrett spread: 0 degrees) instead of flexing them (Barrett medial/distal: 90 degrees).
SPREAD_AXIS_ANGLE = math.radians(45.0)
#: Grid (m) on which the back-off looks for the first clear object position; a clear slot
#: along the palm normal narrower than this may be stepped over.
BACKOFF_STEP = 1e-3
#: Fraction of the conservative-advancement step taken, so that gaps stay strictly positive.
_ADVANCE = 0.9
_MAX_STEPS = 20_000
_BVH_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class FingerResult:
    """How one finger (closing joints that move common links) ended.

    Attributes
    ----------
    joints : tuple of str
        Its closing joints, in model order.
    contact_links : tuple of str
        Links that stopped within ``tolerance`` of the object (empty: the finger missed it).
    at_limit : tuple of str
        Joints that closed to their upper limit without their links touching.
    gap : float
        Smallest distance from the finger's links to the object at the end (m).
    """

    joints: tuple[str, ...]
    contact_links: tuple[str, ...]
    at_limit: tuple[str, ...]
    gap: float


@dataclass(frozen=True)
class ClosingResult:
    """What `close_fingers` did (``full_output=True``).

    Attributes
    ----------
    hand : Hand
        The closed hand.
    object_pose : numpy.ndarray, shape (4, 4)
        Object -> hand pose after the back-off (the input pose when ``backoff_distance`` is 0).
    backoff_distance : float
        How far the object was moved out along the palm normal (m).
    fingers : tuple of FingerResult
    """

    hand: Hand
    object_pose: np.ndarray
    backoff_distance: float
    fingers: tuple[FingerResult, ...]


def close_fingers(
    hand: Hand,
    object: Solid,
    object_pose: Any = None,
    joints: Any = None,
    *,
    tolerance: float = 1e-4,
    step: float = 0.05,
    backoff: bool = True,
    engine: str = "coal",
    full_output: bool = False,
) -> Hand | ClosingResult:
    """Close the fingers until they touch the object, never penetrating it.

    Parameters
    ----------
    hand : Hand
        An articulated hand (`Hand.from_urdf`, `Hand.from_mjcf`, `exactgrasp.hands`).
    object : Solid
        In its own coordinates (m).
    object_pose : array_like, shape (4, 4), optional
        Object -> hand coordinates (identity by default).
    joints : sequence of str, optional
        Closing joints. Default: the model's ``closing_joints`` if set, else every limited
        joint whose axis is more than 45 degrees from the palm normal (flexion, not spread).
        They close towards their upper limits; the other joints keep their values.
    tolerance : float
        Largest gap (m) left between a touching link and the object; gaps stay > 0.
    step : float
        Largest change of any joint per advancement step (rad, or m for slide joints).
    backoff : bool
        If the hand penetrates the object even with the closing joints open, move the object
        out along the palm normal until the gap is within ``tolerance`` (with a warning); with
        False raise `ClosingError` naming the depth instead.
    engine : {"coal", "fcl"}
        Distance library.
    full_output : bool
        Return a `ClosingResult` (hand, moved object pose, back-off, per-finger contacts).

    Returns
    -------
    Hand or ClosingResult

    Raises
    ------
    ClosingError
        Bad options, a penetrating open hand with ``backoff=False``, or no finger that can
        reach the object.
    JointError
        Unknown, coupled or unlimited joint names in ``joints``.
    """
    _check_inputs(hand, object, tolerance, step, engine)
    pose = check_pose(np.eye(4) if object_pose is None else object_pose)
    model = hand.model
    chosen = _closing_joints(hand, joints)
    moves = _links_moved(model, chosen)
    closed = {**hand.joints, **{n: model.joint_limits[n][0] for n in chosen}}
    scene = _Scene(model, object, pose, engine)
    offset = _backoff(scene, hand, closed, tolerance, backoff)
    if offset > 0:
        warn_caller(
            f"close_fingers: the open hand penetrates {object.name}; the object was moved "
            f"{offset * 1e3:.3f} mm out along the palm normal (full_output=True or close_grasp "
            "return the moved pose)"
        )
    results = [
        _close_finger(scene, closed, finger, moves, tolerance, step)
        for finger in _fingers(chosen, moves)
    ]
    if not any(r.contact_links for r in results):
        gaps = ", ".join(f"{'+'.join(r.joints)}: {r.gap * 1e3:.1f} mm" for r in results)
        raise ClosingError(
            f"{object.name} does not fit inside the reach of {model.name}: every finger closed "
            f"to its limits without touching it (closest gaps {gaps}); move the object closer "
            "to the palm (along the palm normal) or between the fingers."
        )
    hand = hand.with_joints(closed)
    result = ClosingResult(hand, scene.object_pose.copy(), offset, tuple(results))
    return result if full_output else hand


def close_grasp(grasp: Grasp, **options: Any) -> Grasp:
    """`close_fingers` on a grasp: the closed hand with the (possibly moved) object pose.

    Parameters
    ----------
    grasp : Grasp
    **options
        `close_fingers` keyword arguments (``joints``, ``tolerance``, ``backoff``, ...).

    Returns
    -------
    Grasp
    """
    options["full_output"] = True
    try:
        result = close_fingers(grasp.hand, grasp.object, grasp.object_pose, **options)
    except (ClosingError, JointError) as exc:
        raise type(exc)(f"grasp {grasp.name!r}: {exc}") from exc
    return Grasp(result.hand, grasp.object, result.object_pose, name=grasp.name)


# -- choosing joints and fingers ---------------------------------------------------------------


def _check_inputs(hand, obj, tolerance, step, engine) -> None:
    if not isinstance(hand, Hand):
        raise ClosingError(f"hand must be an exactgrasp Hand, got {type(hand).__name__}")
    if not isinstance(obj, Solid):
        raise ClosingError(f"object must be an exactgrasp Solid, got {type(obj).__name__}")
    if not hasattr(hand.model, "link_poses") or not hand.joint_names:
        raise ClosingError(
            f"{hand.model.name} has no joints to close (a rigid hand built from meshes); load "
            "an articulated model with Hand.from_urdf / Hand.from_mjcf"
        )
    for label, value, unit in (("tolerance", tolerance, "m"), ("step", step, "rad")):
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not value > 0:
            raise ClosingError(f"{label} must be a positive number ({unit}), got {value!r}")
        if not math.isfinite(value):
            raise ClosingError(f"{label} must be finite, got {value!r}")
    if engine not in ("coal", "fcl"):
        raise ClosingError(f"engine must be 'coal' or 'fcl', got {engine!r}")


def _palm_normal(hand: Hand) -> np.ndarray | None:
    """Unit palm normal in hand coordinates: the hand frame's, else the model's, else None."""
    palm = hand.frame.palm or {}
    if "normal" in palm:
        return np.asarray(palm["normal"], dtype=np.float64)
    spec = getattr(hand.model, "palm", None)
    return None if spec is None else np.asarray(spec.normal, dtype=np.float64)


def _closing_joints(hand: Hand, joints: Any) -> tuple[str, ...]:
    model, limits = hand.model, hand.joint_limits
    joints = getattr(model, "closing_joints", None) if joints is None else joints
    if joints is None:
        normal = _palm_normal(hand)
        if normal is None:
            raise ClosingError(
                f"{model.name} names no palm frame, so its flexion joints cannot be told from "
                "its spread joints; pass joints=[...] (the joints that close the fingers)"
            )
        frames, moves = model.joint_frames(hand.joints), _links_moved(model, hand.joint_names)
        chosen = tuple(
            n
            for n in hand.joint_names
            if all(map(math.isfinite, limits[n]))
            and moves[n]
            and abs(frames[n][2] @ normal) < math.cos(SPREAD_AXIS_ANGLE)
        )
        if not chosen:
            raise ClosingError(f"{model.name}: no limited flexion joint found; pass joints=[...]")
        return chosen
    if isinstance(joints, str) or not all(isinstance(n, str) for n in joints):
        raise JointError(f"joints must be a list of joint names, got {joints!r}")
    if not joints:
        raise JointError("joints is empty; name at least one joint to close, or pass None")
    couplings = getattr(model, "couplings", {})
    for n in joints:
        if n in couplings:
            driver = couplings[n][0]
            raise JointError(f"joint {n!r} follows {driver!r} (coupled); name {driver!r}")
        if n not in limits:
            raise JointError(
                f"unknown joint name {n!r} for hand {model.name!r}; valid names: "
                f"{', '.join(hand.joint_names)}"
            )
        if not all(map(math.isfinite, limits[n])):
            raise JointError(f"joint {n!r} has no finite limits {limits[n]}, so cannot close")
    return tuple(n for n in hand.joint_names if n in set(joints))


def _links_moved(model, names) -> dict[str, frozenset[int]]:
    """Links each user-facing joint moves, through itself and the joints coupled to it."""
    per_joint, out = model.joint_links(), {}
    for n in names:
        deps = [d for d, (driver, _, _) in model.couplings.items() if driver == n]
        out[n] = frozenset().union(*(per_joint[k] for k in (n, *deps)))
    return out


def _fingers(chosen, moves) -> list[tuple[str, ...]]:
    """Closing joints grouped into fingers: joints that move a common link close together."""
    groups: list[set[str]] = []
    for n in chosen:
        joined = [g for g in groups if any(moves[n] & moves[m] for m in g)]
        groups = [g for g in groups if g not in joined] + [set().union({n}, *joined)]
    fingers = [tuple(n for n in chosen if n in g) for g in groups]
    return sorted(fingers, key=lambda finger: chosen.index(finger[0]))


# -- geometry queries --------------------------------------------------------------------------


class _Scene:
    """Link and object BVHs (built once, cached per model and per solid) and the object pose."""

    def __init__(self, model, obj: Solid, object_pose: np.ndarray, engine: str):
        self.model, self.obj, self.engine, self.object_pose = model, obj, engine, object_pose
        package = "python-fcl" if engine == "fcl" else "coal"
        self.lib = require(engine, f"close_fingers(engine={engine!r})", package=package)
        local = model.link_local_meshes()
        self.names = [name for name, _, _ in local]
        self.meshes = [(V, F) for _, V, F in local]
        centres = [0.5 * (V.min(axis=0) + V.max(axis=0)) for V, _ in self.meshes]
        radii = [
            np.linalg.norm(V - c, axis=1).max()
            for c, (V, _) in zip(centres, self.meshes, strict=True)
        ]
        self.spheres = list(zip(centres, radii, strict=True))  # link frame, for the speed bound
        self.links = self._cached(model, lambda: [self._bvh(V, F) for V, F in self.meshes])
        self.object_bvh = self._cached(obj, lambda: self._bvh(obj.vertices, obj.faces))

    def _cached(self, owner, build):
        per_owner = _BVH_CACHE.setdefault(owner, {})
        if self.engine not in per_owner:
            per_owner[self.engine] = build()
        return per_owner[self.engine]

    def _bvh(self, V, F):
        V, F = np.ascontiguousarray(V, np.float64), np.ascontiguousarray(F, np.int64)
        if self.engine == "coal":
            bvh = self.lib.BVHModelOBBRSS()
            bvh.beginModel(len(F), len(V))
            bvh.addVertices(V)
            bvh.addTriangles(F)
        else:
            bvh = self.lib.BVHModel()
            bvh.beginModel(len(V), len(F))
            bvh.addSubModel(V, F.astype(np.int32))
        bvh.endModel()
        return bvh

    def distance(self, i: int, link_pose: np.ndarray) -> float:
        """Distance from link ``i`` to the object (m); 0 when their surfaces cross."""
        T, P = link_pose, self.object_pose
        if self.engine == "coal":
            tf = self.lib.Transform3s
            link, target = tf(T[:3, :3].copy(), T[:3, 3].copy()), tf(P[:3, :3].copy(), P[:3, 3])
            req, res = self.lib.DistanceRequest(), self.lib.DistanceResult()
            d = self.lib.distance(self.links[i], link, self.object_bvh, target, req, res)
        else:
            tf, obj = self.lib.Transform, self.lib.CollisionObject
            link = obj(self.links[i], tf(T[:3, :3], T[:3, 3]))
            target = obj(self.object_bvh, tf(P[:3, :3], P[:3, 3]))
            d = self.lib.distance(
                link, target, self.lib.DistanceRequest(), self.lib.DistanceResult()
            )
        return max(float(d), 0.0)

    def penetrates(self, i: int, link_pose: np.ndarray) -> bool:
        """Surfaces cross, or one solid lies wholly inside the other (BVH distance > 0 then)."""
        if self.distance(i, link_pose) <= 0.0:
            return True
        V, F = self.meshes[i]
        to_object = np.linalg.inv(self.object_pose) @ link_pose
        point = V[0] @ to_object[:3, :3].T + to_object[:3, 3]
        if _winding_number(point, self.obj.vertices, self.obj.faces) > 0.5:
            return True
        to_link = np.linalg.inv(to_object)
        point = self.obj.vertices[0] @ to_link[:3, :3].T + to_link[:3, 3]
        return _winding_number(point, V, F) > 0.5

    def speed(self, i: int, link_pose: np.ndarray, motions) -> float:
        """Bound on the speed of any point of link ``i`` per unit closing parameter (m)."""
        centre, radius = self.spheres[i]
        centre = link_pose[:3, :3] @ centre + link_pose[:3, 3]
        total = 0.0
        for kind, anchor, rate, links in motions:  # |v| <= sum |dq/dt| * lever arm
            if i in links:
                lever = np.linalg.norm(centre - anchor) + radius if kind == "hinge" else 1.0
                total += abs(rate) * lever
        return total


def _winding_number(point: np.ndarray, V: np.ndarray, F: np.ndarray) -> float:
    """Generalised winding number at ``point`` (3,) of the closed mesh V (n, 3), F (m, 3).

    1 inside, 0 outside (van Oosterom and Strackee's solid angle of each triangle, summed).
    """
    a, b, c = (V[F[:, k]] - point for k in range(3))
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    dots = la * lb * lc + np.einsum("ij,ij->i", a, b) * lc
    dots += np.einsum("ij,ij->i", b, c) * la + np.einsum("ij,ij->i", c, a) * lb
    return float(np.arctan2(det, dots).sum() / (2.0 * np.pi))


# -- back-off and closing ----------------------------------------------------------------------


def _backoff(scene: _Scene, hand: Hand, open_joints, tolerance: float, allowed: bool) -> float:
    """Move the object out along the palm normal until the open hand clears it; the distance."""
    poses = scene.model.link_poses(open_joints)
    stuck = [scene.names[i] for i in range(len(poses)) if scene.penetrates(i, poses[i])]
    if not stuck:
        return 0.0
    normal, start = _palm_normal(hand), scene.object_pose
    if normal is None:
        raise ClosingError(
            f"the open hand penetrates {scene.obj.name} (links {', '.join(stuck)}) and "
            f"{hand.model.name} names no palm normal to back off along; move the object"
        )

    def clear(shift: float) -> bool:
        scene.object_pose = start.copy()
        scene.object_pose[:3, 3] += shift * normal
        return not any(scene.penetrates(i, poses[i]) for i in range(len(poses)))

    # Past the sum of both bounding-box diagonals the two cannot overlap any more.
    hand_points = np.concatenate(
        [V @ T[:3, :3].T for (V, _), T in zip(scene.meshes, poses, strict=True)]
    )
    limit = sum(np.linalg.norm(np.ptp(x, axis=0)) for x in (hand_points, scene.obj.vertices))
    low, high = 0.0, BACKOFF_STEP
    while not clear(high):
        low, high = high, high + BACKOFF_STEP
        if high > limit:
            raise ClosingError(
                f"the open hand penetrates {scene.obj.name} however far the object moves out "
                f"along the palm normal (up to {limit:.3f} m); check the object pose"
            )
    while high - low > tolerance:  # the gap at `high` is at most high - low
        mid = 0.5 * (low + high)
        low, high = (mid, high) if not clear(mid) else (low, mid)
    if not allowed:
        raise ClosingError(
            f"the open hand penetrates {scene.obj.name} by {high * 1e3:.3f} mm along the palm "
            f"normal (links {', '.join(stuck)}); pass backoff=True to move the object out by "
            "that much, or move it yourself"
        )
    clear(high)
    return high


def _close_finger(scene: _Scene, joints: dict, finger, moves, tol: float, step: float):
    """Close one finger, updating ``joints`` in place: range-proportional, with breakaway.

    Every active joint follows ``lower + t * (upper - lower)`` for one parameter t in [0, 1];
    a link within ``tol`` stops every joint that moves it, the others go on.
    """
    model, limits, per_joint = scene.model, scene.model.joint_limits, scene.model.joint_links()
    span = {n: limits[n][1] - limits[n][0] for n in finger}
    deps = {n: [(d, r) for d, (drv, r, _) in model.couplings.items() if drv == n] for n in finger}
    active, contacts, t = list(finger), [], 0.0

    def state(t_new: float):
        for n in active:
            joints[n] = limits[n][0] + min(t_new, 1.0) * span[n]
        poses = model.link_poses(joints)
        return poses, {
            i: scene.distance(i, poses[i]) for i in set().union(*map(moves.get, active))
        }

    poses, gaps = state(t)
    t_prev = t
    for _ in range(_MAX_STEPS):
        touch = tol
        if min(gaps.values()) <= 0.0:  # the speed bound was beaten: bisect back to contact
            t_low, t_high = t_prev, t
            while min(gaps.values()) <= 0.0 or min(gaps.values()) > tol:
                if t_high - t_low < 1e-12:  # float limit: take the clear end, closest link
                    t = t_low
                    poses, gaps = state(t)
                    touch = min(gaps.values())
                    break
                t = 0.5 * (t_low + t_high)
                poses, gaps = state(t)
                t_low, t_high = (t_low, t) if min(gaps.values()) <= 0.0 else (t, t_high)
        touching = {i for i, d in gaps.items() if 0.0 < d <= touch}
        contacts += [scene.names[i] for i in sorted(touching)]
        active = [n for n in active if not moves[n] & touching]
        if not active or t >= 1.0:
            break
        frames = model.joint_frames(joints)
        motions = [
            (frames[k][0], frames[k][1], span[n] * ratio, per_joint[k])
            for n in active
            for k, ratio in [(n, 1.0), *deps[n]]
        ]
        advance = min(
            _ADVANCE * gaps[i] / max(scene.speed(i, poses[i], motions), 1e-12)
            for i in set().union(*map(moves.get, active))
        )
        t_prev, t = t, min(t + min(advance, step / max(span[n] for n in active)), 1.0)
        poses, gaps = state(t)
    else:
        raise ClosingError(f"closing {finger} did not converge in {_MAX_STEPS} steps")
    poses = model.link_poses(joints)
    gap = min(scene.distance(i, poses[i]) for i in set().union(*map(moves.get, finger)))
    at_limit = tuple(n for n in active if joints[n] >= limits[n][1])
    return FingerResult(tuple(finger), tuple(dict.fromkeys(contacts)), at_limit, gap)
