"""The interface every intersection backend implements, and the rigid-pose check they share.

Imports `exactgrasp.errors`, `exactgrasp.geometry.se3` and the backends' parameter checks.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from exactgrasp.backends.params import Param
from exactgrasp.errors import BackendError
from exactgrasp.geometry.se3 import rigid_defects

if TYPE_CHECKING:
    from exactgrasp.grasp import Grasp


#: Tolerance of the rigid-motion check of `check_poses`: ``R^T R = I``, ``det R = 1`` and the
#: last row ``0 0 0 1`` must hold to this; products of sampled rotations stay within 1e-14.
RIGID_ATOL = 1e-9


def check_poses(poses: np.ndarray, name: str = "poses") -> np.ndarray:
    """Validate an array of rigid poses.

    Parameters
    ----------
    poses : array_like, shape (..., 4, 4)
        Homogeneous rigid transforms acting on the object in the canonical frame: rotation
        part orthonormal with determinant +1 and last row ``0 0 0 1``, each to `RIGID_ATOL`.
    name : str
        What the caller calls the argument, for messages.

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4), float64
        The same poses as a C-contiguous float64 array.

    Raises
    ------
    BackendError
        For a wrong shape, a non-finite entry, or a pose that is not a rigid motion (a
        reflection, a scale, a shear, a projective last row); the message names the first
        such pose by its index.
    """
    arr = np.ascontiguousarray(poses, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (4, 4):
        raise BackendError(
            f"{name} must have shape (..., 4, 4), got {arr.shape}; "
            "pass PathSampler.poses() or a stack of 4x4 homogeneous matrices."
        )
    finite = np.isfinite(arr).all(axis=(-2, -1))
    if not finite.all():
        raise BackendError(
            f"{_label(name, _first(~finite))} contains NaN or infinite entries; pass finite 4x4 "
            "matrices."
        )
    orthonormality, determinant, last_row = rigid_defects(arr)
    checks = (
        (
            last_row > RIGID_ATOL,
            lambda i: f"its last row is {arr[i][3].tolist()}, not [0, 0, 0, 1]",
        ),
        (
            determinant < 0,
            lambda i: f"its rotation part has determinant {determinant[i]:.6g} (a reflection)",
        ),
        (
            orthonormality > RIGID_ATOL,
            lambda i: (
                "its rotation part is not orthonormal (max |R^T R - I| = "
                f"{orthonormality[i]:.3g}: a scale or a shear)"
            ),
        ),
        (
            np.abs(determinant - 1.0) > RIGID_ATOL,
            lambda i: f"its rotation part has determinant {determinant[i]:.6g}, not 1",
        ),
    )
    for bad, what in checks:
        if bad.any():
            index = _first(bad)
            raise BackendError(
                f"{_label(name, index)} is not a rigid motion: {what(index)}. Backends move the "
                f"object rigidly; pass rotations (det +1, orthonormal to {RIGID_ATOL:g}) with a "
                "translation and last row 0 0 0 1, and scale meshes with units=..., not poses."
            )
    return arr


def _first(mask: np.ndarray) -> tuple[int, ...]:
    """Index of the first True entry of `mask` (as a tuple, for messages and indexing)."""
    return tuple(int(i) for i in np.unravel_index(int(np.argmax(mask)), mask.shape))


def _label(name: str, index: tuple[int, ...]) -> str:
    """``poses[3]`` for pose 3 of a stack, ``poses`` for a single pose."""
    return f"{name}[{', '.join(map(str, index))}]" if index else name


class Backend(abc.ABC):
    """An intersection-volume backend.

    A backend sees only validated geometry (through a `Grasp`) and an array of poses; it knows
    nothing of files, samplers or reports.

    Subclasses take every parameter in the constructor, declare what each may be in
    `parameter_constraints` and check them there with
    `exactgrasp.backends.params.validate_parameters`, and expose them through `params` so that
    descriptors can record how they were made (``type(b)(**b.params)`` rebuilds a backend).
    ``exactgrasp.backends.testing.check_backend`` checks an implementation against this
    contract.
    """

    #: Registry name, e.g. ``"voxel"``.
    name: str = ""
    #: Relative accuracy the backend claims for a volume (None: an estimate, no bound claimed).
    volume_rtol: ClassVar[float | None] = None
    #: What each constructor parameter may be: name -> `Param`.
    parameter_constraints: ClassVar[dict[str, Param]] = {}

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
