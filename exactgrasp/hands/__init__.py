"""Hands: models (rigid meshes, MJCF/URDF through MuJoCo), posed hands, built-in hands.

``eg.hands.barrett()`` builds the built-in Barrett hand, ``eg.hands.parallel_gripper()`` the
built-in parallel-jaw gripper, ``eg.hands.adroit()`` and ``eg.hands.shadow_hand()`` the
five-finger hands of the optional package ``gymnasium-robotics``; `load_model` compiles a
model file (URDF or MJCF as robotics packages ship them: ``package://`` mesh names, scenes
with ``root_body=``).
Modules here import `exactgrasp.errors`, `exactgrasp.cache`, `exactgrasp.geometry` and each
other (never grasps, paths or backends).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

# The built-in hands' modules are light (their MJCF text); and `barrett` must be bound here,
# or importing the submodule `exactgrasp.hands.barrett` would shadow the function.
from exactgrasp.hands.barrett import barrett, barrett_model
from exactgrasp.hands.builtins import BUILTIN_HANDS, available_hands, get_builtin
from exactgrasp.hands.dexterous import adroit, adroit_model, shadow_hand, shadow_hand_model
from exactgrasp.hands.gripper import parallel_gripper, parallel_gripper_model
from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.hands.frame import HandFrame
    from exactgrasp.hands.hand import Hand, HandModel, RigidModel
    from exactgrasp.hands.joints import JOINT_LIMIT_TOL
    from exactgrasp.hands.loading import load_model
    from exactgrasp.hands.model import KinematicModel
    from exactgrasp.hands.palm import PalmSpec

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.hands.frame": ("HandFrame",),
        "exactgrasp.hands.hand": ("Hand", "HandModel", "RigidModel"),
        "exactgrasp.hands.joints": ("JOINT_LIMIT_TOL",),
        "exactgrasp.hands.loading": ("load_model",),
        "exactgrasp.hands.model": ("KinematicModel",),
        "exactgrasp.hands.palm": ("PalmSpec",),
    },
)

__all__ = [
    "BUILTIN_HANDS",
    "JOINT_LIMIT_TOL",
    "Hand",
    "HandFrame",
    "HandModel",
    "KinematicModel",
    "PalmSpec",
    "RigidModel",
    "adroit",
    "adroit_model",
    "available_hands",
    "barrett",
    "barrett_model",
    "get_builtin",
    "load_model",
    "parallel_gripper",
    "parallel_gripper_model",
    "shadow_hand",
    "shadow_hand_model",
]
