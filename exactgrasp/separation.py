"""Penetration removed by the smallest rigid motion of the object: `separate`.

The exact volume's twist gradient (`ExactBackend.volume_gradients`) says how a rigid motion
of the object changes the volume to first order; a Newton step to zero along it,
``ξ = -V W g / (g · W g)`` (``W`` weighing a radian as `ROTATION_SCALE` canonical units), is the
smallest motion (in that metric) that the linear model says removes the volume. Steps repeat
from where they land until the volume reads exactly 0; the last one, which crosses into
contact, is bisected on the exact volume until the object sits within ``tolerance_mm`` of the
hand along it. Where the fingers are buried in the object (`buried_links`; the default
``fingers="auto"`` decides so, or ``fingers="reclose"`` asks for it), the fingers open first and
close again after (`close_fingers`). Nothing is random: the same grasp gives the same result.
See ``docs/penetration-volume.md``.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from exactgrasp.backends.exact import ExactBackend
from exactgrasp.backends.registry import as_backend
from exactgrasp.errors import ClosingError, SeparationError
from exactgrasp.geometry.se3 import exp_se3
from exactgrasp.grasp.closing import close_fingers_result, closing_directions
from exactgrasp.grasp.grasp import Grasp

__all__ = [
    "BURIED_FRACTION",
    "CONTACT_SHARE",
    "FINGERS",
    "PUSH_MM",
    "ROTATION_SCALE",
    "Separation",
    "buried_links",
    "in_contact",
    "separate",
]

#: A radian of rotation weighs as much as this many canonical units of translation (1: the
#: palm-to-centre half-depth, so a radian moves a point at the grasp's centre about as far).
ROTATION_SCALE = 1.0
#: "In contact": the volume is at most `CONTACT_SHARE` of what this push (mm) back along the
#: separating direction makes it, which is positive.
PUSH_MM = 1.0
#: The exact volume of surfaces put in contact by a computed pose is often a sliver (the pose
#: composed into the grasp's frame rounds, and the volume is exact), not 0: this share of the
#: push's volume (an overlap about a nanometre deep) still counts as contact.
CONTACT_SHARE = 1e-6
#: The largest Newton step, canonical units (translation) and radians (rotation).
MAX_STEP = 0.25
#: Samples per round of the bisection of the last step.
BRACKET = 16
#: What `separate` does with the fingers.
FINGERS = ("auto", "keep", "reclose")
#: A finger link is buried when more than this fraction of its own volume lies inside the
#: object (`buried_links`): far above a finger stopped at the surface (none inside) and far
#: below a finger closed through it (the measurements: ``docs/penetration-volume.md``).
BURIED_FRACTION = 1e-3
#: What a refusal with the joints kept suggests.
RECLOSE_HINT = "fingers='reclose' (--fingers reclose on the command line)"


@dataclass(frozen=True)
class Separation:
    """What `separate` did.

    Attributes
    ----------
    grasp : Grasp
        The separated grasp (the same hand and object, a new object pose and joints).
    translation_mm : float
        How far the object's centroid moved, mm.
    rotation_deg : float
        The object's rotation, degrees.
    motion : numpy.ndarray, shape (4, 4)
        The rigid motion in hand coordinates (m): new ``object_pose = motion @ old``.
    joint_changes : dict of str to float
        New minus old value of every joint that changed (rad, m for slides).
    volume_before : float
        The hand ∩ object volume of the input grasp, m^3.
    in_contact : bool
        A `PUSH_MM` push back along `direction` penetrates, and the volume is at most
        `CONTACT_SHARE` of what that push makes it.
    steps : int
        Gradient steps taken.
    direction : numpy.ndarray, shape (6,)
        The separating direction: the last step's unit twist (canonical frame, ``(v, ω)``),
        or, where no step was needed, the one down the input grasp's volume gradient.
    fingers : {"keep", "reclose"}
        What was done with the fingers (``fingers="auto"`` resolved).
    buried_links : tuple of str or None
        With ``fingers="auto"``, the finger links found buried (`buried_links`); None where
        nothing was measured (the mode was given, or the hand's closing joints cannot be
        told).
    """

    grasp: Grasp
    translation_mm: float
    rotation_deg: float
    motion: np.ndarray
    joint_changes: dict[str, float]
    volume_before: float
    in_contact: bool
    steps: int
    direction: np.ndarray = field(repr=False)
    fingers: str = "keep"
    buried_links: tuple[str, ...] | None = None


def _metric(rotation: bool) -> np.ndarray:
    w = np.array([1.0, 1.0, 1.0] + [1.0 / ROTATION_SCALE**2] * 3)
    if not rotation:
        w[3:] = 0.0
    return w


def _norm(xi: np.ndarray) -> float:
    return float(np.sqrt(xi[:3] @ xi[:3] + ROTATION_SCALE**2 * (xi[3:] @ xi[3:])))


def _volumes(backend: ExactBackend, grasp: Grasp, poses: np.ndarray) -> np.ndarray:
    return np.asarray(backend.volumes(grasp, poses))


def _bracket(backend, grasp, pose, xi, tol) -> float:
    """The fraction s of step ``xi`` from ``pose`` (penetrating) to where the volume first reads
    0 along it (the last sample with a volume, and the next), to ``tol`` canonical units."""
    lo, hi = 0.0, 1.0
    length = _norm(xi)
    while (hi - lo) * length > tol:
        s = np.linspace(lo, hi, BRACKET + 1)[1:-1]
        vols = _volumes(backend, grasp, exp_se3(s[:, None] * xi[3:], s[:, None] * xi[:3]) @ pose)
        inside = np.flatnonzero(vols > 0)
        if len(inside):
            lo = float(s[inside[-1]])
        hi = float(s[inside[-1] + 1]) if len(inside) and inside[-1] + 1 < len(s) else hi
        if not len(inside):
            hi = float(s[0])
    return hi


def _exact_backend(backend: str | ExactBackend) -> ExactBackend:
    """``backend`` as an `ExactBackend` (a name means the library defaults)."""
    if backend != "exact" and not isinstance(backend, ExactBackend):
        raise SeparationError(
            f"backend={backend!r}; separation follows the exact volume's gradient: use "
            "backend='exact' (the default) or backend=ExactBackend(...)."
        )
    return as_backend(backend)


def in_contact(grasp: Grasp, direction: np.ndarray, backend: str | ExactBackend = "exact") -> bool:
    """Whether the grasp is in contact: moving the object `PUSH_MM` back along ``direction``
    (a twist, canonical frame, separating sense) penetrates, and its exact volume is at most
    `CONTACT_SHARE` of that push's (0, or a sliver of rounding)."""
    backend = _exact_backend(backend)
    push = PUSH_MM * 1e-3 * grasp.frame.scale * direction / _norm(direction)
    back = exp_se3(-push[3:], -push[:3])
    here, pushed = _volumes(backend, grasp, np.stack([np.eye(4), back]))
    return bool(pushed > 0 and here <= CONTACT_SHARE * pushed)


def _opened(grasp: Grasp):
    """The hand with its closing joints at their open limits (the other joints kept)."""
    hand = grasp.hand
    senses = closing_directions(hand, object=grasp.object, object_pose=grasp.object_pose)
    limits = hand.joint_limits
    return hand.with_joints(
        {j: limits[j][0] if s > 0 else limits[j][1] for j, s in senses.items()}
    )


def buried_links(grasp: Grasp, backend: str | ExactBackend = "exact") -> tuple[str, ...]:
    """The finger links buried in the object: those the closing joints move (the links that
    opening them to their limits moves) with more than `BURIED_FRACTION` of their own volume
    inside the object, by the exact volume of each link alone against the object.

    Parameters
    ----------
    grasp : Grasp
    backend : "exact" or ExactBackend
        As for `separate`.

    Returns
    -------
    tuple of str
        Link names, in the hand's link order; empty for a hand without joints.

    Raises
    ------
    ClosingError
        The hand's closing joints cannot be told (no palm frame and no closing joints set on
        its model).
    """
    backend = _exact_backend(backend)
    if not grasp.hand.joint_names:
        return ()
    hand, opened = grasp.hand, _opened(grasp)
    bodies = grasp.canonical_object_bodies()
    found = []
    for name, link, (v, _), (w, _) in zip(
        hand.link_names, hand.canonical_links(), hand.link_arrays(), opened.link_arrays(),
        strict=True,
    ):  # fmt: skip
        if np.array_equal(v, w):
            continue  # not a finger link: opening the closing joints leaves it where it is
        intersector = backend.intersector_of([link], bodies)
        inside = float(intersector.volumes(np.eye(4)[None])[0])
        if inside > BURIED_FRACTION * intersector.hand_volume:
            found.append(name)
    return tuple(found)


def _resolve_fingers(grasp, fingers, backend) -> tuple[str, tuple[str, ...] | None]:
    """``fingers`` as "keep" or "reclose", with the buried links ``"auto"`` found (None where
    it measured nothing: a mode given, or a hand whose closing joints cannot be told, whose
    joints ``"auto"`` keeps)."""
    if fingers != "auto":
        return fingers, None
    try:
        buried = buried_links(grasp, backend)
    except ClosingError:
        return "keep", None
    return ("reclose" if buried else "keep"), buried


def separate(
    grasp: Grasp,
    *,
    fingers: str = "auto",
    rotation: bool = True,
    tolerance_mm: float = 0.01,
    max_steps: int = 60,
    backend: str | ExactBackend = "exact",
) -> Separation:
    """Move the object out of the hand by the smallest rigid motion the exact volume's
    gradient finds, leaving it in contact.

    Parameters
    ----------
    grasp : Grasp
    fingers : {"auto", "keep", "reclose"}
        ``"keep"``: the joints stay. ``"reclose"``: the closing joints open to their limits
        first, the object is moved out of the open hand, and the fingers close onto it again
        (`close_fingers`, no back-off); for grasps whose fingers are buried in the object.
        ``"auto"`` (default): ``"reclose"`` where a finger link is buried (more than
        `BURIED_FRACTION`, a thousandth, of its own volume inside the object:
        `buried_links`), else ``"keep"``, and ``"reclose"`` after all where keeping the
        joints is refused (fingers closed around the object without entering it); always
        ``"keep"`` for a hand without joints or whose closing joints cannot be told. A raw
        recorded grasp with its fingers closed through the object is re-closed; a grasp
        whose only penetration is the palm's keeps its joints.
    rotation : bool
        Let the object rotate as well as translate.
    tolerance_mm : float
        Largest gap (mm, along the separating direction) left between hand and object.
    max_steps : int
        Gradient steps before giving up.
    backend : "exact" or ExactBackend
        The name means the library defaults; an instance sets the broad phase and threads,
        e.g. ``ExactBackend(n_jobs=1)``. The result does not depend on either.

    Returns
    -------
    Separation

    Raises
    ------
    SeparationError
        The object enclosed by the hand (or the hand by the object: the volume's gradient
        vanishes while the volume does not), no step that sheds volume, or more than
        ``max_steps`` steps; the message says which, and what to try.
    """
    if fingers not in FINGERS:
        raise SeparationError(f"fingers={fingers!r}; use 'auto', 'keep' or 'reclose'.")
    if not (isinstance(tolerance_mm, int | float) and 0 < tolerance_mm < PUSH_MM):
        raise SeparationError(
            f"tolerance_mm={tolerance_mm!r}; use a gap in mm above 0 and below {PUSH_MM}."
        )
    backend = _exact_backend(backend)
    mode, buried = _resolve_fingers(grasp, fingers, backend)
    try:
        done = _separated(grasp, mode, backend, rotation, tolerance_mm, max_steps)
    except SeparationError:
        # "auto" kept the joints (no finger link buried), but fingers closed around the object
        # without entering it can still leave no rigid way out: then it re-closes them.
        if fingers != "auto" or mode != "keep" or buried is None or not grasp.hand.joint_names:
            raise
        mode = "reclose"
        done = _separated(grasp, mode, backend, rotation, tolerance_mm, max_steps)
    return dataclasses.replace(done, fingers=mode, buried_links=buried)


def _separated(grasp, fingers, backend, rotation, tolerance_mm, max_steps) -> Separation:
    """`separate` with ``fingers`` "keep" or "reclose" (checked options, an `ExactBackend`)."""
    scale = grasp.frame.scale
    start = backend.volume_gradients(grasp, np.eye(4)[None])
    before = float(start.volumes[0]) / scale**3
    weights = _metric(rotation)
    # Until a step is taken (the open hand may be clear already), the direction that sheds
    # the input grasp's volume fastest separates it.
    direction = -weights * start.twist[0]
    if not np.any(direction):
        direction = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    direction = direction / _norm(direction)
    work = grasp
    if fingers == "reclose" and grasp.hand.joint_names:
        work = Grasp(_opened(grasp), grasp.object, grasp.object_pose, name=grasp.name)
    # What a refusal suggests: re-closing, unless that is what failed.
    hint = RECLOSE_HINT if fingers == "keep" and grasp.hand.joint_names else ""
    pose = np.eye(4)
    steps = 0
    while True:
        result = backend.volume_gradients(work, pose[None])
        volume, g = float(result.volumes[0]), result.twist[0]
        if volume == 0:
            break
        if steps >= max_steps:
            raise SeparationError(
                f"grasp {grasp.name!r}: still {volume / scale**3:.3g} m^3 inside after "
                f"{max_steps} steps; the hand may hold the object in a way no small rigid "
                f"motion undoes; try {hint + ' or ' if hint else ''}a larger max_steps."
            )
        wg = weights * g
        gg = float(g @ wg)
        if not gg > 1e-12 * volume ** (4 / 3):
            raise SeparationError(
                f"grasp {grasp.name!r}: the object is enclosed by the hand (or the hand by "
                "the object): the volume's gradient vanishes, so no rigid motion sheds "
                f"volume to first order{'; try ' + hint + ' to open the fingers' if hint else ''}."
            )
        xi = -volume * wg / gg
        big = max(np.linalg.norm(xi[:3]), np.linalg.norm(xi[3:])) / MAX_STEP
        xi = xi / max(big, 1.0)
        steps += 1
        for _ in range(24):
            step = exp_se3(xi[3:], xi[:3]) @ pose
            after = float(_volumes(backend, work, step[None])[0])
            if after < volume:
                break
            xi = xi / 2
        else:
            raise SeparationError(
                f"grasp {grasp.name!r}: no step along the volume's gradient sheds volume "
                f"(volume {volume / scale**3:.3g} m^3); the object is wedged in the hand"
                f"{'; try ' + hint if hint else ''}."
            )
        direction = xi / _norm(xi)
        if after == 0:
            s = _bracket(backend, work, pose, xi, tolerance_mm * 1e-3 * scale)
            pose = exp_se3(s * xi[3:], s * xi[:3]) @ pose
            break
        pose = step
    return _finish(grasp, work, pose, fingers, before, steps, direction, backend)


def _finish(grasp, work, pose, fingers, before, steps, direction, backend) -> Separation:
    """The `Separation` of the canonical motion ``pose`` of the object of ``work``."""
    frame = grasp.frame.matrix
    motion = np.linalg.inv(frame) @ pose @ frame
    new_pose = motion @ grasp.object_pose
    hand = work.hand
    if fingers == "reclose" and grasp.hand.joint_names:
        # The exact volume reads 0 up to its certified bound; the closing's distance test
        # may still see the touching surfaces cross and back off along the palm normal by
        # a hair (its warning is this function's business: the motion reports it).
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            closed = close_fingers_result(hand, grasp.object, new_pose, backoff=True)
        hand, new_pose = closed.hand, closed.object_pose
        motion = new_pose @ np.linalg.inv(grasp.object_pose)
    out = Grasp(hand, grasp.object, new_pose, name=grasp.name)
    centre = grasp.object_pose[:3, :3] @ grasp.object.centroid + grasp.object_pose[:3, 3]
    moved = motion[:3, :3] @ centre + motion[:3, 3]
    cos = (np.trace(motion[:3, :3]) - 1.0) / 2.0
    changes = {
        n: hand.joints[n] - grasp.hand.joints[n]
        for n in hand.joint_names
        if hand.joints[n] != grasp.hand.joints[n]
    }
    return Separation(
        grasp=out,
        translation_mm=float(np.linalg.norm(moved - centre) * 1e3),
        rotation_deg=math.degrees(math.acos(min(1.0, max(-1.0, cos)))),
        motion=motion,
        joint_changes=changes,
        volume_before=before,
        in_contact=in_contact(out, direction, backend),
        steps=steps,
        direction=direction,
    )
