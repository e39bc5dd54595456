"""The geometric engine of finger closing: the contact scene, the back-off, one finger's advance.

`ContactScene` holds the BVHs of a hand model's links and of the object (built once per
content by `exactgrasp.geometry.bvh.cached_bvh`) and the object pose; `backoff` moves the
object out of an open hand that penetrates it; `close_finger` closes one finger by
conservative advancement on exact mesh distances, with bisection as the safety net, each
joint in its direction (`infer_directions` when none is given). The public API is
`exactgrasp.grasp.closing`.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.errors import ClosingError, Fix
from exactgrasp.geometry.bvh import cached_bvh, distance, require_engine
from exactgrasp.geometry.solid import Solid
from exactgrasp.geometry.winding import winding_number
from exactgrasp.hands.hand import Hand

__all__ = [
    "ADVANCE",
    "BACKOFF_STEP",
    "MAX_STEPS",
    "ContactScene",
    "backoff",
    "close_finger",
    "closing_target",
    "infer_directions",
    "open_value",
    "palm_normal",
]

#: Grid (m) on which the back-off looks for the first clear object position; a clear slot
#: along the palm normal narrower than this may be stepped over.
BACKOFF_STEP = 1e-3
#: Fraction of the conservative-advancement step taken, so that gaps stay strictly positive.
ADVANCE = 0.9
#: Most advancement steps per finger before giving up.
MAX_STEPS = 20_000


def palm_normal(hand: Hand) -> np.ndarray | None:
    """Unit palm normal (3,) in hand coordinates: the hand frame's, else the model's, else None."""
    palm = hand.frame.palm or {}
    if "normal" in palm:
        return np.asarray(palm["normal"], dtype=np.float64)
    spec = getattr(hand.model, "palm", None)
    return None if spec is None else np.asarray(spec.normal, dtype=np.float64)


class ContactScene:
    """Link and object BVHs (built once per geometry, then cached) and the object pose.

    Parameters
    ----------
    model : exactgrasp.hands.model.KinematicModel
        Needs ``link_local_meshes()``, ``link_poses``, ``joint_frames``, ``joint_links``.
    obj : Solid
    object_pose : numpy.ndarray, shape (4, 4)
        Object -> hand coordinates; `backoff` moves it.
    engine : {"coal", "fcl"}
    """

    def __init__(self, model, obj: Solid, object_pose: np.ndarray, engine: str):
        self.model, self.obj, self.engine, self.object_pose = model, obj, engine, object_pose
        require_engine(engine, f"close_fingers(engine={engine!r})")
        local = model.link_local_meshes()
        self.names = [name for name, _, _ in local]
        self.meshes = [(V, F) for _, V, F in local]
        centres = [0.5 * (V.min(axis=0) + V.max(axis=0)) for V, _ in self.meshes]
        radii = [
            np.linalg.norm(V - c, axis=1).max()
            for c, (V, _) in zip(centres, self.meshes, strict=True)
        ]
        self.spheres = list(zip(centres, radii, strict=True))  # link frame, for the speed bound
        self.links = [cached_bvh(engine, V, F) for V, F in self.meshes]
        self.object_bvh = cached_bvh(engine, obj.vertices, obj.faces)

    def distance(self, i: int, link_pose: np.ndarray) -> float:
        """Distance from link ``i`` to the object (m); 0 when their surfaces cross."""
        d = distance(self.engine, self.links[i], link_pose, self.object_bvh, self.object_pose)
        return max(d, 0.0)

    def penetrates(self, i: int, link_pose: np.ndarray) -> bool:
        """Surfaces cross, or one solid lies wholly inside the other (BVH distance > 0 then)."""
        if self.distance(i, link_pose) <= 0.0:
            return True
        V, F = self.meshes[i]
        to_object = np.linalg.inv(self.object_pose) @ link_pose
        point = V[0] @ to_object[:3, :3].T + to_object[:3, 3]
        if winding_number(point, self.obj.vertices, self.obj.faces) > 0.5:
            return True
        to_link = np.linalg.inv(to_object)
        point = self.obj.vertices[0] @ to_link[:3, :3].T + to_link[:3, 3]
        return winding_number(point, V, F) > 0.5

    def speed(self, i: int, link_pose: np.ndarray, motions) -> float:
        """Bound on the speed of any point of link ``i`` per unit closing parameter (m).

        ``motions`` holds ``(kind, anchor (3,), rate, links)`` per moving joint.
        """
        centre, radius = self.spheres[i]
        centre = link_pose[:3, :3] @ centre + link_pose[:3, 3]
        total = 0.0
        for kind, anchor, rate, links in motions:  # |v| <= sum |dq/dt| * lever arm
            if i in links:
                lever = np.linalg.norm(centre - anchor) + radius if kind == "hinge" else 1.0
                total += abs(rate) * lever
        return total


def backoff(
    scene: ContactScene, hand: Hand, open_joints: dict, tolerance: float, allowed: bool
) -> float:
    """Move the object out along the palm normal until the open hand clears it.

    Parameters
    ----------
    scene : ContactScene
        Its ``object_pose`` is moved to the first clear position.
    hand : Hand
    open_joints : dict of str to float
        The configuration with the closing joints open.
    tolerance : float
        Largest gap (m) left between the cleared hand and the object.
    allowed : bool
        False: raise `ClosingError` naming the depth instead of moving the object.

    Returns
    -------
    float
        How far the object moved (m); 0 when the open hand was clear.
    """
    poses = scene.model.link_poses(open_joints)
    stuck = [scene.names[i] for i in range(len(poses)) if scene.penetrates(i, poses[i])]
    if not stuck:
        return 0.0
    normal, start = palm_normal(hand), scene.object_pose
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
            f"normal (links {', '.join(stuck)}); ",
            Fix("backoff", True, "pass"),
            " to move the object out by that much, or move it yourself",
        )
    clear(high)
    return high


def open_value(limits: tuple[float, float], direction: int) -> float:
    """Where a closing joint starts: its lower limit when it closes upwards (+1), else its
    upper limit."""
    return limits[0] if direction > 0 else limits[1]


def close_finger(
    scene: ContactScene,
    joints: dict,
    finger: tuple[str, ...],
    moves,
    tol: float,
    step: float,
    directions: dict[str, int] | None = None,
) -> tuple[tuple[str, ...], tuple[str, ...], float]:
    """Close one finger, updating ``joints`` in place: range-proportional, with breakaway.

    Every active joint follows ``open + t * direction * (upper - lower)`` for one parameter t
    in [0, 1], from its open limit to its closing limit (`open_value`); a link within ``tol``
    stops every joint that moves it, the others go on.

    Parameters
    ----------
    scene : ContactScene
    joints : dict of str to float
        The hand's joint values; the finger's joints are set to where they stop.
    finger : tuple of str
        Its closing joints.
    moves : dict of str to frozenset of int
        Links each joint moves (through itself and the joints coupled to it).
    tol : float
        Largest gap (m) of a touching link.
    step : float
        Largest change of any joint per step (rad, or m).
    directions : dict of str to int, optional
        ``{joint: +1 | -1}``: +1 closes towards the upper limit (the default), -1 towards
        the lower one.

    Returns
    -------
    contact_links : tuple of str
        Links that stopped within ``tol`` of the object.
    at_limit : tuple of str
        Joints that reached their closing limit without their links touching.
    gap : float
        Smallest distance from the finger's links to the object at the end (m).
    """
    model, limits, per_joint = scene.model, scene.model.joint_limits, scene.model.joint_links()
    span = {n: limits[n][1] - limits[n][0] for n in finger}
    sense = {n: 1 if (directions or {}).get(n, 1) > 0 else -1 for n in finger}
    start = {n: open_value(limits[n], sense[n]) for n in finger}
    end = {n: open_value(limits[n], -sense[n]) for n in finger}
    deps = {n: [(d, r) for d, (drv, r, _) in model.couplings.items() if drv == n] for n in finger}
    active, contacts, t = list(finger), [], 0.0

    def state(t_new: float):
        for n in active:
            joints[n] = end[n] if t_new >= 1.0 else start[n] + sense[n] * t_new * span[n]
        poses = model.link_poses(joints)
        return poses, {
            i: scene.distance(i, poses[i]) for i in set().union(*map(moves.get, active))
        }

    poses, gaps = state(t)
    t_prev = t
    for _ in range(MAX_STEPS):
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
            ADVANCE * gaps[i] / max(scene.speed(i, poses[i], motions), 1e-12)
            for i in set().union(*map(moves.get, active))
        )
        t_prev, t = t, min(t + min(advance, step / max(span[n] for n in active)), 1.0)
        poses, gaps = state(t)
    else:
        raise ClosingError(f"closing {finger} did not converge in {MAX_STEPS} steps")
    poses = model.link_poses(joints)
    gap = min(scene.distance(i, poses[i]) for i in set().union(*map(moves.get, finger)))
    at_limit = tuple(n for n in active if joints[n] == end[n])
    return tuple(dict.fromkeys(contacts)), at_limit, gap


def closing_target(hand: Hand, obj: Solid | None, pose: np.ndarray) -> np.ndarray:
    """The point (3,) fingers close towards, hand frame (m): the palm frame's centre (half
    the depth out along the normal), or the object's centroid when there is no palm frame."""
    palm = hand.frame.palm or {}
    spec = getattr(hand.model, "palm", None)
    if "origin" in palm:
        origin, normal, depth = palm["origin"], palm["normal"], palm["depth"]
    elif spec is not None:
        origin, normal, depth = spec.origin, spec.normal, spec.depth
    elif obj is not None:
        return pose[:3, :3] @ obj.centroid + pose[:3, 3]
    else:
        raise ClosingError(
            f"{hand.model.name} names no palm frame, so the closing directions cannot be "
            "inferred without an object; pass direction={joint: +1 | -1}"
        )
    return np.asarray(origin) + 0.5 * depth * np.asarray(normal)


def infer_directions(
    hand: Hand, obj: Solid, pose: np.ndarray, todo, fingers, moves
) -> dict[str, int]:
    """Per joint, the sense (+1 or -1) whose limit puts its finger's tip nearer the target.

    The tip is the finger's links moved by most of its joints; each joint is set to either
    limit with the others at the hand's joints, and the mean distance of the tip links'
    box centres to `closing_target` compared (a tie keeps +1).

    Parameters
    ----------
    hand : Hand
    obj : Solid
    pose : numpy.ndarray, shape (4, 4)
        Object -> hand.
    todo : collection of str
        The joints whose direction is wanted.
    fingers : list of tuple of str
        Closing joints grouped into fingers.
    moves : dict of str to frozenset of int
        Links each joint moves (through itself and the joints coupled to it).

    Returns
    -------
    dict of str to int
    """
    model, limits = hand.model, hand.joint_limits
    target = closing_target(hand, obj, pose)
    local = model.link_local_meshes()
    centres = [np.append(0.5 * (V.min(axis=0) + V.max(axis=0)), 1.0) for _, V, _ in local]
    out = {}
    for finger in fingers:
        counts: dict[int, int] = {}
        for n in finger:
            for i in moves[n]:
                counts[i] = counts.get(i, 0) + 1
        most = max(counts.values())
        tip = {i for i, c in counts.items() if c == most}
        for n in (n for n in finger if n in todo):
            links = sorted(tip & moves[n] or moves[n])
            reach = []
            for q in limits[n]:
                poses = model.link_poses({**hand.joints, n: q})
                reach.append(
                    np.mean([np.linalg.norm((poses[i] @ centres[i])[:3] - target) for i in links])
                )
            out[n] = -1 if reach[0] < reach[1] - 1e-12 else 1
    return out
