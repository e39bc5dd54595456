"""Built-in hand models, available without downloading anything."""

from collections.abc import Callable

from exactgrasp.hands.barrett import barrett, barrett_model

#: Built-in hands by name (the ``"builtin"`` hand type of grasp files).
BUILTIN_HANDS: dict[str, Callable] = {"barrett": barrett}


def get(name: str) -> Callable:
    """The constructor of a built-in hand by name (e.g. ``"barrett"``)."""
    from exactgrasp.errors import ModelError

    try:
        return BUILTIN_HANDS[name]
    except KeyError:
        raise ModelError(
            f"unknown built-in hand {name!r}; built-in hands: {sorted(BUILTIN_HANDS)}."
        ) from None


__all__ = ["BUILTIN_HANDS", "barrett", "barrett_model", "get"]
