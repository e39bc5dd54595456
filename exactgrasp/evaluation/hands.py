"""Other hands at the Barrett grasps' placements, for the report's hands section: placing and
closing a built-in hand there (`placed_grasps`), putting descriptors of different hands on one
scale (`NORMALISATIONS`), and the pairs that ask whether the same placement in two hands is
closer than two placements in one hand (`across_hand_pairs`). The section's numbers are
`exactgrasp.evaluation.study.hands_section`.
"""

from __future__ import annotations

import warnings

import numpy as np
import trimesh

from exactgrasp.errors import ExactGraspError
from exactgrasp.evaluation.pairs import LabelledPairs
from exactgrasp.grasp import Grasp
from exactgrasp.grasp.closing import close_fingers_result

__all__ = [
    "HAND_LABELS",
    "MAX_BACKOFF",
    "NORMALISATIONS",
    "OTHER_HANDS",
    "across_hand_pairs",
    "hull_volume",
    "normalised",
    "placed_grasps",
]


def placed_grasps(
    grasps: list[Grasp], hand_name: str, max_backoff: float
) -> tuple[list[Grasp], list[dict]]:
    """The same object placements, relative to the palm frame, in another built-in hand.

    A placement keeps its rotation and its position in metres relative to the palm frame (the
    canonical frame without its scale: the box does not shrink with the hand); the hand opens
    (its closing joints to their open limits), the object is backed off the palm where it
    penetrates, and the fingers close until they touch (`close_fingers`). Placements where no
    finger touches, that had to be backed off more than ``max_backoff`` (m), or that cannot
    be closed, are dropped.

    Parameters
    ----------
    grasps : list of Grasp
        The Barrett grasps whose placements are copied.
    hand_name : str
        A built-in hand (``"parallel_gripper"``, ``"adroit"``).
    max_backoff : float
        Largest back-off kept (m).

    Returns
    -------
    grasps : list of Grasp
        Named ``HAND/STEM`` after the Barrett grasp's ``adjusted/STEM``.
    notes : list of dict
        Per Barrett grasp: ``backoff_m`` and ``contacts`` (the links touching), or
        ``skipped`` (why it was dropped).
    """
    from exactgrasp.hands.builtins import get_builtin

    build = get_builtin(hand_name)
    label = HAND_LABELS.get(hand_name, hand_name)
    out, notes = [], []
    for g in grasps:
        hand = build()
        palm_b = g.frame.matrix / g.frame.scale
        palm_g = hand.frame.matrix / hand.frame.scale
        palm_b[3, 3] = palm_g[3, 3] = 1.0
        pose = np.linalg.inv(palm_g) @ palm_b @ g.object_pose
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                closed = close_fingers_result(hand, g.object, object_pose=pose)
        except ExactGraspError as exc:
            notes.append({"grasp": g.name, "skipped": str(exc)})
            continue
        links = sorted({link for f in closed.fingers for link in f.contact_links})
        if not links:
            notes.append({"grasp": g.name, "skipped": "the fingers close without touching"})
            continue
        if closed.backoff_distance > max_backoff:
            notes.append(
                {"grasp": g.name, "skipped": f"backed off {closed.backoff_distance * 1e3:.0f} mm"}
            )
            continue
        name = g.name.replace("adjusted/", f"{label}/")
        out.append(Grasp(closed.hand, g.object, closed.object_pose, name=name))
        notes.append(
            {"grasp": g.name, "backoff_m": float(closed.backoff_distance), "contacts": links}
        )
    return out, notes


#: Largest back-off (m) of a placement that is kept: most gripper placements need 17 .. 20 mm
#: to clear the open jaws (set after seeing that spread, before any AUC); the Adroit hand
#: opens flat, and a placement moved more than that off its palm is no longer the same
#: placement either.
MAX_BACKOFF = 0.02

#: The hands of the hands section by built-in name (the Barrett is the shared data's), with
#: the largest back-off kept for each.
OTHER_HANDS = {"parallel_gripper": MAX_BACKOFF, "adroit": MAX_BACKOFF}
#: Short names of the hands in the section's keys and grasp names.
HAND_LABELS = {"barrett": "barrett", "parallel_gripper": "gripper", "adroit": "adroit"}

#: How the hands section puts the descriptors of different hands on one scale.
NORMALISATIONS = ("hand volume", "none", "cubic metres", "hull volume", "own maximum")


def normalised(descriptor, hull: float, how: str) -> np.ndarray:
    values = descriptor.values
    hand = float(descriptor.metadata["hand_volume_canonical"])
    if how == "hand volume":
        return values
    if how == "none":
        return values * hand
    if how == "cubic metres":
        return values * float(descriptor.metadata["hand_volume_m3"])
    if how == "hull volume":
        return values * hand / hull
    if how == "own maximum":
        return values / max(float(values.max()), 1e-300)
    raise ValueError(how)


def across_hand_pairs(names: list[str], hand: np.ndarray, placement: np.ndarray) -> LabelledPairs:
    """Same placement in two hands ('same', 1) against two placements in one hand (0).

    Parameters
    ----------
    names : list of str, length n
        The grasps.
    hand, placement : numpy.ndarray, shape (n,)
        Each grasp's hand and placement index.

    Returns
    -------
    LabelledPairs
        Pairs of different placements in different hands are left out; the grasp groups
        are the placements.
    """
    i, j = np.triu_indices(len(names), 1)
    keep = (placement[i] == placement[j]) | (hand[i] == hand[j])
    i, j = i[keep], j[keep]
    label = (placement[i] == placement[j]).astype(float)
    return LabelledPairs(names, i, j, label, None, list(map(str, placement)))


def hull_volume(grasp: Grasp) -> float:
    """Volume of the convex hull of the grasp's hand links, canonical units (a normalisation
    of `NORMALISATIONS`)."""
    links = grasp.canonical_hand_links()
    return float(trimesh.Trimesh(np.vstack([v for v, _ in links])).convex_hull.volume)
