"""Derivatives of the exact volume: `volume_moments` (per pose, the moments of each link's
boundary inside the object) and `VolumeGradients`, what `ExactBackend.volume_gradients` returns.

The moments and the derivatives they give are explained in `moments`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from exactgrasp.backends.base import check_poses
from exactgrasp.backends.exact.intersector import ExactIntersector
from exactgrasp.backends.exact.moments import boolean_moments, shift_moments

__all__ = ["VolumeGradients", "boolean_volume_moments", "object_twist", "volume_moments"]


@dataclass(frozen=True)
class VolumeGradients:
    """Volumes of hand ∩ moved object and their derivatives, pose by pose.

    Attributes
    ----------
    volumes : numpy.ndarray, shape (n,)
        Cubed canonical units (as `ExactBackend.volumes`).
    twist : numpy.ndarray, shape (n, 6)
        ``d/dε volume(hand ∩ exp(ε ξ̂) · pose · object)`` at ε = 0 for ``ξ = (vx, vy, vz, ωx,
        ωy, ωz)``, a spatial twist in the canonical frame (the frame of the poses), applied on
        the left of each pose: dotted with ``ξ`` it gives the volume's rate when the object
        moves at ``v + ω × x``. Units: squared canonical units per canonical unit of ``v``
        (first three), cubed canonical units per radian (last three).
    joints : numpy.ndarray, shape (n, k)
        The volume's derivative by each of the hand's user-facing joints (couplings included:
        a driver moves its dependents), cubed canonical units per radian (per metre for a
        slide joint), the object held at the pose.
    joint_names : tuple of str
        The k joints, ``grasp.hand.joint_names``.

    A pose whose volume reads 0 has zero derivatives: at contact the derivative is one-sided
    (pushing in raises the volume at a rate that starts at 0 for smooth contact, pulling out
    leaves it 0), and the one reported is the outward one.
    """

    volumes: np.ndarray
    twist: np.ndarray
    joints: np.ndarray
    joint_names: tuple[str, ...]


def volume_moments(intersector: ExactIntersector, poses: np.ndarray) -> tuple[np.ndarray, ...]:
    """Volumes and, per link, ``(F_l, M_l)`` of its boundary inside the moved object, from the
    kernel (`ExactIntersector.volume_moments`; the boolean where the kernel hands a pose to
    it).

    Parameters
    ----------
    intersector : ExactIntersector
    poses : numpy.ndarray, shape (..., 4, 4), float64
        Rigid motions of the object (``x -> R x + t``), in the intersector's input frame, as
        `exactgrasp.backends.base.check_poses` returns them (not checked again here).

    Returns
    -------
    volumes : numpy.ndarray, shape poses.shape[:-2]
        The intersector's volumes (`ExactIntersector.volumes`).
    links : numpy.ndarray, shape poses.shape[:-2] + (L, 6)
        Moments in the input frame (area units, then area times length), zero where the
        volume reads 0. ``-links.sum(-2)`` are the object's moments (see `moments`).
    """
    return intersector.volume_moments(poses)


def boolean_volume_moments(
    intersector: ExactIntersector, poses: np.ndarray
) -> tuple[np.ndarray, ...]:
    """`volume_moments` from one manifold3d boolean per pose with a non-zero volume (the
    kernel's reference; volumes from the kernel, so that both read 0 at the same poses)."""
    poses = check_poses(poses)
    flat = poses.reshape(-1, 4, 4)
    volumes = np.asarray(intersector.volumes(flat), dtype=np.float64).reshape(-1)
    c = intersector.origin
    local = np.array(flat)
    local[:, :3, 3] += local[:, :3, :3] @ c - c
    links = np.zeros((len(flat), len(intersector.link_ids), 6))
    for i in np.flatnonzero(volumes > 0):
        _, links[i], _ = boolean_moments(
            intersector.hand_solid, intersector.link_ids, intersector.object_solid, local[i],
            intersector.areas,
        )  # fmt: skip
    links = shift_moments(links, c)
    shape = poses.shape[:-2]
    return volumes.reshape(shape), links.reshape(shape + links.shape[-2:])


def object_twist(links: np.ndarray) -> np.ndarray:
    """The object's twist gradient ``(F_O, M_O) = -Σ_l (F_l, M_l)`` from link moments
    (..., L, 6): shape (..., 6)."""
    return -np.asarray(links).sum(-2)
