"""The built-in hands by name (the ``"builtin"`` hand type of grasp files)."""

from __future__ import annotations

from collections.abc import Callable

from exactgrasp.errors import ModelError
from exactgrasp.hands.barrett import BARRETT_MJCF, barrett
from exactgrasp.hands.gripper import GRIPPER_MJCF, parallel_gripper

__all__ = ["BUILTIN_HANDS", "BUILTIN_MJCF", "available_hands", "get_builtin"]

#: Constructor of every built-in hand by name: ``BUILTIN_HANDS[name](joints=..., ...)``.
BUILTIN_HANDS: dict[str, Callable] = {"barrett": barrett, "parallel_gripper": parallel_gripper}

#: The MJCF text of every built-in hand by name (what ``exactgrasp inspect NAME`` reads).
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
