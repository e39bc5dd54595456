"""The built-in parallel-jaw gripper: two prismatic fingers, 0.08 m stroke, closing to 0.

Nothing is downloaded: the model is the MJCF text below, compiled by MuJoCo. It follows the
convention of common two-finger grippers (the Franka hand's URDF among them): each finger's
joint value is its jaw's distance from the centre plane, 0 = shut and 0.04 m = open, so the
gripper closes towards the LOWER limit. The second finger follows the first, as a URDF
``<mimic>`` would make it (an MJCF joint equality, ratio 1), so ``finger_1_joint`` is the only
user-facing joint.

* hand frame: origin at the centre of the palm face, +z out of the palm (between the
  fingers), +y from finger 2 to finger 1 (the closing axis), +x = y × z;
* palm: a 60 x 200 x 40 mm box below z = 0; fingers: 20 x 12 x 50 mm boxes on the palm face,
  inner faces at y = +/-q;
* limits: 0 .. 0.04 m per finger; the default pose is open (q = 0.04, a 0.08 m gap);
* palm frame from the site ``palm_face``: origin (0, 0, 0), normal +z, up +y, depth 0.05 m
  (the finger length).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.cache import LRUCache
from exactgrasp.hands.mjcf import primitive_hand_mjcf

if TYPE_CHECKING:
    from exactgrasp.hands.hand import Hand
    from exactgrasp.hands.model import KinematicModel

__all__ = [
    "GRIPPER_MJCF",
    "GRIPPER_PALM",
    "GRIPPER_STROKE",
    "parallel_gripper",
    "parallel_gripper_model",
]

#: Largest jaw gap (m): both fingers at their upper limit.
GRIPPER_STROKE = 0.08

#: The gripper's palm frame, read by `exactgrasp.hands.loading.load_model` from the site.
GRIPPER_PALM = {"site": "palm_face", "normal": "+z", "up": "+y", "depth": 0.05}

# The bodies are written open (ref = 0.04: the XML pose is q = 0.04), so that the model's
# reference pose, and with it the default joints, is the open gripper.
_FINGER = """
      <body name="finger_{i}">
        <joint name="finger_{i}_joint" type="slide" axis="0 {s} 0" range="0 0.04" ref="0.04"/>
        <geom name="finger_{i}" type="box" pos="0 {y} 0.025" size="0.01 0.006 0.025"/>
      </body>"""

GRIPPER_MJCF = primitive_hand_mjcf(
    "parallel_gripper",
    palm=("0 0 -0.02", "0.03 0.1 0.02"),
    face="0 0 0",
    fingers=_FINGER.format(i=1, s=1, y=0.046) + _FINGER.format(i=2, s=-1, y=-0.046),
    mirrored=("finger_2_joint", "finger_1_joint"),
)


#: The compiled model (boxes only, so there is nothing to tessellate).
_MODELS = LRUCache(1)


def parallel_gripper_model() -> KinematicModel:
    """The built-in parallel-jaw gripper as a `KinematicModel` (compiled once, then cached).

    Returns
    -------
    KinematicModel
        One user-facing joint, ``finger_1_joint`` (0 .. 0.04 m, 0 = shut);
        ``finger_2_joint`` follows it. Links ``palm``, ``finger_1``, ``finger_2``.
    """
    # MuJoCo and the mesh code load with the first hand, not with the MJCF text (which
    # ``exactgrasp inspect --help`` lists by name).
    from exactgrasp.hands.loading import load_model

    return _MODELS.get(
        "gripper",
        lambda: load_model("parallel_gripper.xml", xml=GRIPPER_MJCF, palm=GRIPPER_PALM),
    )


def parallel_gripper(joints: dict[str, float] | None = None, **hand_kwargs) -> Hand:
    """The built-in parallel-jaw gripper, posed.

    Parameters
    ----------
    joints : dict of str to float, optional
        ``{"finger_1_joint": q}``, each jaw's distance from the centre (m); default open
        (0.04 m, a 0.08 m gap).
    **hand_kwargs
        Passed to `exactgrasp.hands.hand.Hand` (``frame``, ``on_limit``).

    Returns
    -------
    exactgrasp.hands.hand.Hand
        With the gripper's palm frame unless ``frame=`` is given.
    """
    source = {"type": "builtin", "name": "parallel_gripper", "options": {}}
    from exactgrasp.hands.hand import Hand

    return Hand(parallel_gripper_model(), joints=joints, source=source, **hand_kwargs)
