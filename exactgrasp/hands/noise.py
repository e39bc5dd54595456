"""The paper's joint noise (section IV-A) and the seeded random helpers the noise models share.

Seeded: the same ``rng`` seed gives the same perturbations on every machine.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from exactgrasp.errors import NoiseError

__all__ = ["as_rng", "joint_noise", "random_unit_vectors"]


def as_rng(rng: Any) -> np.random.Generator:
    """``rng`` itself if it is a `numpy.random.Generator`, else a new one seeded with it."""
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def random_unit_vectors(n: int, rng: Any = None) -> np.ndarray:
    """Directions uniform on the sphere.

    Parameters
    ----------
    n : int
    rng : numpy.random.Generator or int, optional

    Returns
    -------
    numpy.ndarray, shape (n, 3)
    """
    rng = as_rng(rng)
    vectors = rng.normal(size=(n, 3))
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def joint_noise(hand: Any, fraction: float, rng: Any = None) -> dict[str, float]:
    """Joint values with the paper's joint noise.

    Each joint moves by ``u * fraction * (upper - lower)`` with ``u`` uniform in [-1, 1],
    independently per joint, then is clipped to its limits.

    Parameters
    ----------
    hand : exactgrasp.hands.hand.Hand
    fraction : float
        Noise as a fraction of each joint's range (paper: 0.01 .. 0.05).
    rng : numpy.random.Generator or int, optional

    Returns
    -------
    dict of str to float
        New values of every independent joint.
    """
    if not np.isfinite(fraction) or fraction < 0:
        raise NoiseError(f"fraction must be a non-negative number, got {fraction!r}.")
    if not hand.joint_names:
        raise NoiseError(f"{hand.model.name} has no joints to perturb.")
    rng = as_rng(rng)
    out = {}
    for name in hand.joint_names:
        lower, upper = hand.joint_limits[name]
        if not (np.isfinite(lower) and np.isfinite(upper)):
            raise NoiseError(
                f"joint {name!r} has no finite range ({lower}, {upper}), so a fraction of its "
                "range is undefined; give the model joint limits."
            )
        value = hand.joints[name] + rng.uniform(-1.0, 1.0) * fraction * (upper - lower)
        out[name] = float(np.clip(value, lower, upper))
    return out
