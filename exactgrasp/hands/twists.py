"""How each user-facing joint moves each link: `link_twists`, the links' spatial twists per unit
joint change, couplings included, in the hand's canonical frame.

A hinge with unit axis ``a`` through ``p`` moves a point ``x`` of the links below it at
``a × (x - p)`` per radian, the twist ``(v, ω) = (p × a, a)``; a slide moves them at ``a`` per
metre, ``(a, 0)``. A user-facing joint drives itself and, through the couplings
``dependent = offset + ratio * driver``, its dependents, so its twist on a link is the sum of
the twists of the joints above that link, each times its rate (1 for itself, ``ratio`` for a
dependent). In the canonical frame ``x_c = s R x + T`` a hinge's twist keeps its form, with
the axis ``R a`` and the anchor mapped as a point; a slide's velocity is ``s R a``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["link_twists"]


def link_twists(hand: Any) -> tuple[tuple[str, ...], np.ndarray]:
    """Spatial twists of every link per unit change of every user-facing joint.

    Parameters
    ----------
    hand : exactgrasp.Hand
        At the configuration the twists are taken at (they change with the joints).

    Returns
    -------
    joint_names : tuple of str
        ``hand.joint_names`` (k), the independent joints; coupled (mimic) joints move with
        their drivers.
    twists : numpy.ndarray, shape (k, L, 6)
        For joint j and link l (in ``hand.canonical_links()`` order), ``(v, ω)`` such that a
        point ``x`` of link l (canonical coordinates) moves at ``v + ω × x`` per radian (per
        metre for a slide joint) of joint j. Zero where the joint does not move the link.
        ``(0, L, 6)`` for a rigid hand.
    """
    names = tuple(hand.joint_names)
    n_links = len(hand.link_names)
    twists = np.zeros((len(names), n_links, 6))
    model = hand.model
    if not names or not hasattr(model, "joint_frames"):
        return names, twists
    frames = model.joint_frames(hand.joints)
    moved = model.joint_links()
    frame = hand.frame
    rot = frame.matrix[:3, :3] / frame.scale
    # Each driven joint with its rate per unit of the user-facing joint.
    rates: dict[str, list[tuple[str, float]]] = {n: [(n, 1.0)] for n in names}
    for dep, (driver, ratio, _) in model.couplings.items():
        if driver is not None:
            rates[driver].append((dep, float(ratio)))
    for j, name in enumerate(names):
        for joint, rate in rates[name]:
            kind, anchor, axis = frames[joint]
            if kind == "slide":
                twist = np.concatenate([frame.scale * (rot @ axis), np.zeros(3)])
            else:
                a = rot @ axis
                p = frame.apply(np.asarray(anchor)[None])[0]
                twist = np.concatenate([np.cross(p, a), a])
            for link in moved[joint]:
                twists[j, link] += rate * twist
    return names, twists
