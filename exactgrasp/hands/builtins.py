"""The built-in hands by name (the ``"builtin"`` hand type of grasp files)."""

from __future__ import annotations

from collections.abc import Callable

from exactgrasp.errors import ModelError
from exactgrasp.hands.barrett import BARRETT_MJCF, barrett
from exactgrasp.hands.dexterous import adroit, shadow_hand
from exactgrasp.hands.gripper import GRIPPER_MJCF, parallel_gripper

__all__ = ["BUILTIN_HANDS", "BUILTIN_MJCF", "available_hands", "get_builtin"]

#: Constructor of every built-in hand by name: ``BUILTIN_HANDS[name](joints=..., ...)``.
#: ``adroit`` and ``shadow_hand`` read their model from the optional package
#: ``gymnasium-robotics`` (see `exactgrasp.hands.dexterous`).
BUILTIN_HANDS: dict[str, Callable] = {
    "barrett": barrett,
    "parallel_gripper": parallel_gripper,
    "adroit": adroit,
    "shadow_hand": shadow_hand,
}

#: The MJCF text of the built-in hands written here, by name (what ``exactgrasp inspect NAME``
#: reads); the five-finger hands are files of their package.
BUILTIN_MJCF: dict[str, str] = {"barrett": BARRETT_MJCF, "parallel_gripper": GRIPPER_MJCF}


def available_hands() -> set[str]:
    """Names of the built-in hands."""
    return set(BUILTIN_HANDS)


def get_builtin(name: str) -> Callable:
    """The constructor of a built-in hand by name (e.g. ``"barrett"``)."""
    try:
        return BUILTIN_HANDS[name]
    except KeyError:
        raise ModelError(
            f"unknown built-in hand {name!r}; built-in hands: {sorted(BUILTIN_HANDS)}."
        ) from None
