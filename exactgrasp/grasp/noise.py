"""The paper's noise models (section IV-A): object-pose noise here, joint noise re-exported.

Both are seeded: the same ``rng`` seed gives the same perturbations on every machine. The one
public noise module: `joint_noise` lives in `exactgrasp.hands.noise` (a hand operation) and is
re-exported.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.spatial.transform import Rotation

from exactgrasp.errors import NoiseError
from exactgrasp.hands.noise import as_rng, joint_noise, random_unit_vectors

if TYPE_CHECKING:
    from exactgrasp.grasp.grasp import Grasp

__all__ = ["NoiseError", "joint_noise", "object_pose_noise", "random_unit_vectors"]


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
    rng = as_rng(rng)
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
