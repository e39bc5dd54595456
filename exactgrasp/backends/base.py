"""The interface every intersection backend implements."""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from exactgrasp.grasp import Grasp


def check_poses(poses: np.ndarray) -> np.ndarray:
    """Validate an array of rigid poses.

    Parameters
    ----------
    poses : array_like, shape (..., 4, 4)
        Homogeneous rigid transforms acting on the object in the canonical frame.

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4), float64
        The same poses as a C-contiguous float64 array.
    """
    from exactgrasp.errors import BackendError

    arr = np.ascontiguousarray(poses, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (4, 4):
        raise BackendError(
            f"poses must have shape (..., 4, 4), got {arr.shape}; "
            "pass PathSampler.poses() or a stack of 4x4 homogeneous matrices."
        )
    if not np.all(np.isfinite(arr)):
        raise BackendError("poses contain NaN or infinite entries; pass finite 4x4 matrices.")
    return arr


class Backend(abc.ABC):
    """An intersection-volume backend.

    A backend sees only validated geometry (through a `Grasp`) and an array of poses; it knows
    nothing of files, samplers or reports.

    Subclasses take every parameter in the constructor, validate it there, and expose them
    through `params` so that descriptors can record how they were made.
    """

    #: Registry name, e.g. ``"voxel"``.
    name: str = ""

    @property
    @abc.abstractmethod
    def params(self) -> dict[str, Any]:
        """Parameters that determine the result (JSON-serialisable)."""

    @abc.abstractmethod
    def volumes(self, grasp: Grasp, poses: np.ndarray) -> np.ndarray:
        """Intersection volume of the hand and the moved object for each pose.

        Parameters
        ----------
        grasp : Grasp
            Hand, object and object pose. The backend uses its canonical-frame geometry
            (`Grasp.canonical_hand_links`, `Grasp.canonical_object_bodies`).
        poses : numpy.ndarray, shape (..., 4, 4)
            Rigid transforms applied to the object in the canonical frame, about the frame's
            origin: a vertex ``x`` of the object moves to ``R @ x + t``.

        Returns
        -------
        numpy.ndarray, shape poses.shape[:-2], float64
            Volume of hand ∩ moved object in canonical units (cubed canonical lengths).
        """

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"{type(self).__name__}({args})"
