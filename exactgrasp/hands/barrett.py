"""The built-in Barrett hand: a three-finger hand of primitives, roughly BH8-280 sized.

Nothing is downloaded: the model is the MJCF text below, compiled by MuJoCo. It follows the
conventions of the real BH8-280 URDF shipped with the Barrett grasp data (same joint names,
axes, joint origins and limits), so a joint dict recorded for the real hand poses this one the
same way, only with coarser link shapes:

* hand frame: origin at the palm's mounting face, +z out of the palm, +y from the
  finger-1/finger-2 pair towards finger 3, +x from finger 1 to finger 2;
* palm: a 90 x 90 x 80 mm box, its face at z = 0.08; knuckles at z = 0.0754;
* fingers 1 and 2: knuckle (``finger_i_prox``, a box), proximal (``finger_i_med``, a box)
  and distal (``finger_i_dist``, a capsule bent 38 degrees towards +z as on the real hand)
  links; finger 3 has no knuckle link;
* limits: spread 0 .. pi, medial 0 .. 2.44, distal 0 .. 0.837 rad; positive values close;
* palm frame: origin (0, 0, 0.08), normal +z, up +y, depth d = 0.085 m.

The spread is one motor on the real hand: ``finger_2_prox_joint`` follows
``finger_1_prox_joint`` (an MJCF joint equality, ratio 1; the opposite axes make the fingers
turn in opposite senses), so the user-facing spread joint is ``finger_1_prox_joint``. A dict
that also sets ``finger_2_prox_joint`` is accepted when both agree. The distal joints are
independent by default, since the real hand's 12/35 distal/medial coupling breaks away on
contact; ``distal_coupling=True`` couples them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.cache import LRUCache
from exactgrasp.hands.mjcf import primitive_hand_mjcf

if TYPE_CHECKING:
    from exactgrasp.hands.hand import Hand
    from exactgrasp.hands.model import KinematicModel

__all__ = ["BARRETT_MJCF", "BARRETT_PALM", "DISTAL_RATIO", "barrett", "barrett_model"]

#: Distal/medial ratio of the real hand's built-in finger coupling.
DISTAL_RATIO = 12.0 / 35.0

#: The built-in hand's palm frame, read by `exactgrasp.hands.loading.load_model` from the site.
BARRETT_PALM = {"site": "palm_face", "normal": "+z", "up": "+y", "depth": 0.085}

# The medial and distal links of a finger: ``a`` the sign of the joints' x axis, ``y`` that
# of the direction the finger points in (fingers 1 and 2 point to -y, finger 3 to +y).
_MED_DIST = """
<body name="finger_{i}_med" pos="{pos}">
  <joint name="finger_{i}_med_joint" axis="{a}1 0 0" range="0 2.44"/>
  <geom name="finger_{i}_med" type="box" pos="0 {y}0.0335 0.001" size="0.0105 0.046 0.0135"/>
  <body name="finger_{i}_dist" pos="0 {y}0.06994 0.003">
    <joint name="finger_{i}_dist_joint" axis="{a}1 0 0" range="0 0.837"/>
    <geom name="finger_{i}_dist" type="capsule" fromto="0 0 0 0 {y}0.0394 0.0308" size="0.009"/>
  </body>
</body>"""

# Fingers 1 and 2: a knuckle link turning about z (the spread) that holds the others.
_FINGER_12 = """
<body name="finger_{i}_prox" pos="{x} 0 0.0754">
  <joint name="finger_{i}_prox_joint" axis="0 0 {s}" range="0 3.14159265"/>
  <geom name="finger_{i}_prox" type="box" pos="0 -0.024 -0.004" size="0.012 0.036 0.016"/>
  {med_dist}
</body>"""


def _finger_12(i: int, x: str, s: str) -> str:
    return _FINGER_12.format(
        i=i, x=x, s=s, med_dist=_MED_DIST.format(i=i, pos="0 -0.05 0", a="-", y="-")
    )


BARRETT_MJCF = primitive_hand_mjcf(
    "barrett_builtin",
    palm=("0 0 0.04", "0.045 0.045 0.04"),
    face="0 0 0.08",
    fingers=_finger_12(1, "-0.025", "-1")
    + _finger_12(2, "0.025", "1")
    + _MED_DIST.format(i=3, pos="0 0.05 0.0754", a="", y=""),
    mirrored=("finger_2_prox_joint", "finger_1_prox_joint"),
)


#: Compiled models by (distal_coupling, tessellation).
_MODELS = LRUCache(8)


def barrett_model(distal_coupling: bool = False, tessellation: int = 32) -> KinematicModel:
    """The built-in Barrett hand as a `KinematicModel` (compiled once, then cached).

    Parameters
    ----------
    distal_coupling : bool
        Couple each distal joint to its medial joint by 12/35, leaving four user-facing
        joints (spread and three medials) instead of seven.
    tessellation : int
        Segments around the distal capsules.

    Returns
    -------
    KinematicModel
        Joints ``finger_1_prox_joint`` (spread), ``finger_{1,2,3}_med_joint``,
        ``finger_{1,2,3}_dist_joint`` (unless coupled); links named as in the real URDF.
    """
    couplings = (
        {f"finger_{i}_dist_joint": (f"finger_{i}_med_joint", DISTAL_RATIO) for i in (1, 2, 3)}
        if distal_coupling
        else None
    )
    # MuJoCo and the mesh code load with the first hand, not with the MJCF text (which
    # ``exactgrasp inspect --help`` lists by name).
    from exactgrasp.hands.loading import load_model

    return _MODELS.get(
        (distal_coupling, tessellation),
        lambda: load_model(
            "barrett_builtin.xml",
            xml=BARRETT_MJCF,
            palm=BARRETT_PALM,
            couplings=couplings,
            tessellation=tessellation,
        ),
    )


def barrett(
    joints: dict[str, float] | None = None,
    *,
    distal_coupling: bool = False,
    tessellation: int = 32,
    **hand_kwargs,
) -> Hand:
    """The built-in three-finger Barrett hand, posed.

    Parameters
    ----------
    joints : dict of str to float, optional
        Joint values in radians (see `barrett_model` for the names); missing ones are 0
        (fingers stretched out flat, spread 0).
    distal_coupling, tessellation
        See `barrett_model`.
    **hand_kwargs
        Passed to `exactgrasp.hands.hand.Hand` (``frame``, ``on_limit``).

    Returns
    -------
    exactgrasp.hands.hand.Hand
        With the hand's palm frame unless ``frame=`` is given.
    """
    model = barrett_model(bool(distal_coupling), int(tessellation))
    source = {
        "type": "builtin",
        "name": "barrett",
        "options": {"distal_coupling": bool(distal_coupling), "tessellation": int(tessellation)},
    }
    from exactgrasp.hands.hand import Hand

    return Hand(model, joints=joints, source=source, **hand_kwargs)
