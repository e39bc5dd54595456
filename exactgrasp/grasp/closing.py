"""Closing a hand's fingers onto an object until they touch it, GraspIt!-style (auto-grasp).

`close_fingers` opens the closing joints, moves the object out along the palm normal if the
open hand still penetrates it (repairing recorded grasps that sink into their objects), then
closes each finger until its links touch the object within a tolerance or its joints reach
their closing limits. Each joint closes towards its upper limit (+1) or its lower one (-1):
given, set on the model, or inferred per finger (the sense that brings the finger's tip
towards the hand's centre). Contact is found by conservative advancement on exact
mesh distances (coal or python-fcl BVHs, built once per link and per object), with bisection
as the safety net, so no step passes through the object. See ``docs/closing.md``.

This module holds the public API and the choice of closing joints, fingers and directions; the
geometric engine is `exactgrasp.grasp.contact`. The geometry (bvh, solid, the hand, the grasp
and the contact engine) loads inside the functions, so that ``exactgrasp close --help`` reads
the defaults without it. Long because those imports repeat in each public function; the API,
its checks and the choice of fingers and directions read best as one module.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from exactgrasp.errors import ClosingError, Fix, JointError, warn_caller
from exactgrasp.geometry.bvh import DEFAULT_ENGINE, ENGINES

if TYPE_CHECKING:
    from exactgrasp.geometry.solid import Solid
    from exactgrasp.grasp.grasp import Grasp
    from exactgrasp.hands.hand import Hand
__all__ = [
    "SPREAD_AXIS_ANGLE",
    "ClosingError",
    "ClosingResult",
    "FingerResult",
    "close_fingers",
    "close_fingers_result",
    "close_grasp",
    "closing_directions",
]

PASS_JOINTS = Fix("joints", form="pass", shown="[...]")
#: A joint whose axis is within this angle of the palm normal spreads or twists the fingers
#: (Barrett spread: 0 degrees) instead of flexing them (Barrett medial/distal: 90 degrees).
SPREAD_AXIS_ANGLE = math.radians(45.0)


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
        Joints that closed to their closing limit without their links touching.
    gap : float
        Smallest distance from the finger's links to the object at the end (m).
    directions : tuple of int
        Per joint of `joints`: +1 closed towards the upper limit, -1 towards the lower one.
    inferred : tuple of bool
        Per joint: was its direction inferred (True) or given / set on the model (False)?
    """

    joints: tuple[str, ...]
    contact_links: tuple[str, ...]
    at_limit: tuple[str, ...]
    gap: float
    directions: tuple[int, ...] = ()
    inferred: tuple[bool, ...] = ()

    def describe(self) -> str:
        """One line: joints with their directions, contacts or limits, gap."""
        senses = self.directions or (1,) * len(self.joints)
        inferred = self.inferred or (False,) * len(self.joints)
        joints = ", ".join(
            f"{n} {'+' if d > 0 else '-'}{' (inferred)' if i else ''}"
            for n, d, i in zip(self.joints, senses, inferred, strict=True)
        )
        ends = f"touching {', '.join(self.contact_links)}" if self.contact_links else "missed"
        limit = f", at limit: {', '.join(self.at_limit)}" if self.at_limit else ""
        return f"{joints}: {ends}{limit}, gap {self.gap * 1e3:.3g} mm"


@dataclass(frozen=True, repr=False)
class ClosingResult:
    """What `close_fingers_result` did.

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

    @property
    def directions(self) -> dict[str, int]:
        """``{closing joint: +1 | -1}``: the sense each joint closed in (+1: towards upper)."""
        return {
            n: d
            for f in self.fingers
            for n, d in zip(f.joints, f.directions or (1,) * len(f.joints), strict=True)
        }

    def summary(self) -> str:
        """Several lines: the hand, the back-off and each finger (directions, contacts)."""
        lines = [
            f"closed {self.hand.model.name}: back-off {self.backoff_distance * 1e3:.3g} mm; "
            "joint directions: + closes towards the upper limit, - towards the lower"
        ]
        lines += [f"  finger {k}: {f.describe()}" for k, f in enumerate(self.fingers, 1)]
        return "\n".join(lines)

    def __repr__(self) -> str:
        fingers = "; ".join(f.describe() for f in self.fingers)
        return (
            f"ClosingResult({self.hand.model.name!r}, backoff {self.backoff_distance * 1e3:.3g}"
            f" mm, fingers: [{fingers}])"
        )


def close_fingers(
    hand: Hand, object: Solid, object_pose: Any = None, joints: Any = None, **options: Any
) -> Hand:
    """Close the fingers until they touch the object, never penetrating it: the closed hand.

    Parameters
    ----------
    hand, object, object_pose, joints
        As for `close_fingers_result`.
    **options
        `close_fingers_result`'s keyword options (``tolerance``, ``step``, ``backoff``,
        ``engine``, ``direction``).

    Returns
    -------
    Hand
        `close_fingers_result`'s ``hand``; that function also returns the moved object pose,
        the back-off and each finger's contacts and directions.
    """
    return close_fingers_result(hand, object, object_pose, joints, **options).hand


def close_fingers_result(
    hand: Hand,
    object: Solid,
    object_pose: Any = None,
    joints: Any = None,
    *,
    tolerance: float = 1e-4,
    step: float = 0.05,
    backoff: bool = True,
    engine: str = DEFAULT_ENGINE,
    direction: Any = None,
) -> ClosingResult:
    """Close the fingers until they touch the object, never penetrating it: what it did.

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
        They close in their ``direction``; the other joints keep their values.
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
    direction : dict of str to int, optional
        ``{joint: +1 | -1}``: close towards the upper (+1) or the lower (-1) limit. Joints
        not named take the model's ``closing_directions`` if set, else the direction that
        moves their finger's tip towards the hand's centre (the palm frame's centre, else
        the object's centroid), compared at the two limits. Coupled joints follow their
        driver. See ``docs/closing.md``.

    Returns
    -------
    ClosingResult
        The closed hand, the moved object pose, the back-off, per-finger contacts and
        directions.

    Raises
    ------
    ClosingError
        Bad options, a penetrating open hand with ``backoff=False``, or no finger that can
        reach the object.
    JointError
        Unknown, coupled or unlimited joint names in ``joints``; a ``direction`` that is not
        a dict of closing joints to +1 / -1.
    """
    _check_inputs(hand, object, tolerance, step, engine)
    from exactgrasp.grasp import contact
    from exactgrasp.grasp.grasp import check_pose

    pose = check_pose(np.eye(4) if object_pose is None else object_pose)
    model = hand.model
    chosen = _closing_joints(hand, joints)
    moves = _links_moved(model, chosen)
    fingers = _fingers(chosen, moves)
    sense, inferred = _directions(hand, object, pose, chosen, fingers, moves, direction)
    closed = {
        **hand.joints,
        **{n: contact.open_value(model.joint_limits[n], sense[n]) for n in chosen},
    }
    scene = contact.ContactScene(model, object, pose, engine)
    offset = contact.backoff(scene, hand, closed, tolerance, backoff)
    if offset > 0:
        warn_caller(
            f"close_fingers: the open hand penetrates {object.name}; the object was moved "
            f"{offset * 1e3:.3f} mm out along the palm normal (close_fingers_result or "
            "close_grasp return the moved pose)"
        )
    results = [
        FingerResult(
            finger,
            *contact.close_finger(scene, closed, finger, moves, tolerance, step, sense),
            directions=tuple(sense[n] for n in finger),
            inferred=tuple(n in inferred for n in finger),
        )
        for finger in fingers
    ]
    if not any(r.contact_links for r in results):
        gaps = ", ".join(f"{'+'.join(r.joints)}: {r.gap * 1e3:.1f} mm" for r in results)
        raise ClosingError(
            f"{object.name} does not fit inside the reach of {model.name}: every finger closed "
            f"to its limits without touching it (closest gaps {gaps}); move the object closer "
            "to the palm (along the palm normal) or between the fingers."
        )
    hand = hand.with_joints(closed)
    return ClosingResult(hand, scene.object_pose.copy(), offset, tuple(results))


def closing_directions(
    hand: Hand,
    joints: Any = None,
    direction: Any = None,
    object: Solid | None = None,
    object_pose: Any = None,
) -> dict[str, int]:
    """The joints `close_fingers` would close and the sense of each, without closing.

    Parameters
    ----------
    hand : Hand
    joints, direction
        As for `close_fingers_result`.
    object : Solid, optional
        Needed only when the hand has no palm frame (directions are then inferred towards
        the object's centroid).
    object_pose : array_like, shape (4, 4), optional

    Returns
    -------
    dict of str to int
        ``{joint: +1 | -1}`` finger by finger; +1 closes towards the upper limit.
    """
    from exactgrasp.grasp.grasp import check_pose

    pose = check_pose(np.eye(4) if object_pose is None else object_pose)
    chosen = _closing_joints(hand, joints)
    moves = _links_moved(hand.model, chosen)
    fingers = _fingers(chosen, moves)
    sense, _ = _directions(hand, object, pose, chosen, fingers, moves, direction)
    return {n: sense[n] for finger in fingers for n in finger}


def close_grasp(grasp: Grasp, **options: Any) -> Grasp:
    """`close_fingers_result` on a grasp: the closed hand with the (possibly moved) object
    pose.

    Parameters
    ----------
    grasp : Grasp
    **options
        `close_fingers_result` keyword arguments (``joints``, ``tolerance``, ``backoff``,
        ...).

    Returns
    -------
    Grasp
    """
    try:
        result = close_fingers_result(grasp.hand, grasp.object, grasp.object_pose, **options)
    except (ClosingError, JointError) as exc:
        raise exc.prefixed(f"grasp {grasp.name!r}: ") from exc
    from exactgrasp.grasp.grasp import Grasp

    return Grasp(result.hand, grasp.object, result.object_pose, name=grasp.name)


# -- choosing joints and fingers ---------------------------------------------------------------


def _check_inputs(hand, obj, tolerance, step, engine) -> None:
    from exactgrasp.geometry.solid import Solid
    from exactgrasp.hands.hand import Hand

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
            raise ClosingError(Fix(label), f" must be a positive number ({unit}), got {value!r}")
        if not math.isfinite(value):
            raise ClosingError(Fix(label), f" must be finite, got {value!r}")
    if engine not in ENGINES:
        raise ClosingError(f"engine must be 'coal' or 'fcl', got {engine!r}")


def _closing_joints(hand: Hand, joints: Any) -> tuple[str, ...]:
    from exactgrasp.grasp import contact

    model, limits = hand.model, hand.joint_limits
    joints = getattr(model, "closing_joints", None) if joints is None else joints
    if joints is None:
        normal = contact.palm_normal(hand)
        if normal is None:
            raise ClosingError(
                f"{model.name} names no palm frame, so its flexion joints cannot be told from "
                "its spread joints; ",
                PASS_JOINTS,
                " (the joints that close the fingers)",
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
            raise ClosingError(f"{model.name}: no limited flexion joint found; ", PASS_JOINTS)
        return chosen
    if isinstance(joints, str) or not all(isinstance(n, str) for n in joints):
        raise JointError(f"joints must be a list of joint names, got {joints!r}")
    if not joints:
        raise JointError(
            Fix("joints"), " is empty; name at least one joint to close, or pass None"
        )
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


def _directions(hand, obj, pose, chosen, fingers, moves, given) -> tuple[dict, set]:
    """``{joint: +1 | -1}`` for the closing joints, and the set of those inferred."""
    from exactgrasp.grasp import contact

    model = hand.model
    given = {} if given is None else given
    if not isinstance(given, Mapping):
        raise JointError(f"direction must be a dict {{joint: +1 | -1}}, got {given!r}")
    couplings = getattr(model, "couplings", {})
    for n, d in given.items():
        if n in couplings:
            raise JointError(
                f"direction of {n!r}: it follows {couplings[n][0]!r} (coupled); give the "
                f"direction of {couplings[n][0]!r}"
            )
        if n not in chosen:
            raise JointError(
                f"direction of {n!r}: not a closing joint of this call; closing joints: "
                f"{', '.join(chosen)}"
            )
        if isinstance(d, bool) or d not in (1, -1):
            raise JointError(f"direction of {n!r} must be +1 or -1, got {d!r}")
    preset = getattr(model, "closing_directions", None) or {}
    sense = {n: int(given.get(n, preset.get(n, 0))) for n in chosen}
    todo = [n for n in chosen if sense[n] == 0]
    if todo:
        sense.update(contact.infer_directions(hand, obj, pose, todo, fingers, moves))
    return sense, set(todo)


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
