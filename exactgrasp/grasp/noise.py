"""The paper's noise models (section IV-A): object-pose noise and joint noise.

Both are seeded: the same ``rng`` seed gives the same perturbations on every machine.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial.transform import Rotation

from exactgrasp.errors import NoiseError

if TYPE_CHECKING:
    from exactgrasp.grasp import Grasp
    from exactgrasp.hands.hand import Hand


def _rng(rng: Any) -> np.random.Generator:
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
    rng = _rng(rng)
    vectors = rng.normal(size=(n, 3))
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def object_pose_noise(grasp: Grasp, eps: float, delta: float, rng: Any = None) -> np.ndarray:
    """A perturbed object pose: the paper's object-pose noise.

    The object's centre (its volume centroid) moves by ``eps`` times the object's longest
    length (longest side of its bounding box) in a uniformly random direction, and the object
    turns about its centre by ``pi / delta`` about a uniformly random axis.

    Parameters
    ----------
    grasp : Grasp
    eps : float
        Translation as a fraction of the object's longest length (paper: 0.0125, 0.025).
    delta : float
        Rotation angle is ``pi / delta`` (paper: 64, 32). ``inf`` for no rotation.
    rng : numpy.random.Generator or int, optional

    Returns
    -------
    numpy.ndarray, shape (4, 4)
        New object pose (object -> hand coordinates).
    """
    if not np.isfinite(eps) or eps < 0:
        raise NoiseError(f"eps must be a non-negative number, got {eps!r}.")
    if not (delta > 0):
        raise NoiseError(f"delta must be positive (the angle is pi/delta), got {delta!r}.")
    rng = _rng(rng)
    direction = random_unit_vectors(1, rng)[0]
    axis = random_unit_vectors(1, rng)[0]
    pose = np.asarray(grasp.object_pose, dtype=np.float64)
    obj = grasp.object
    centre_hand = pose[:3, :3] @ obj.centroid + pose[:3, 3]
    turn = np.eye(4)
    turn[:3, :3] = Rotation.from_rotvec(axis * (np.pi / delta)).as_matrix()
    about_centre = np.eye(4)
    about_centre[:3, 3] = centre_hand - turn[:3, :3] @ centre_hand
    shift = np.eye(4)
    shift[:3, 3] = direction * eps * obj.extent
    return shift @ (about_centre @ turn) @ pose


def joint_noise(hand: Hand, fraction: float, rng: Any = None) -> dict[str, float]:
    """Joint values with the paper's joint noise.

    Each joint moves by ``u * fraction * (upper - lower)`` with ``u`` uniform in [-1, 1],
    independently per joint, then is clipped to its limits.

    Parameters
    ----------
    hand : Hand
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
    rng = _rng(rng)
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
