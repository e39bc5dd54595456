"""Closed-form exponential map of SE(3), vectorised.

A twist is ``(omega, v)``: body angular velocity ``omega`` (rad per unit time) and body linear
velocity ``v`` (length per unit time). Its exponential is the rigid transform reached by moving
with that constant body velocity for unit time; this is the paper's ``exp(m t)`` (eq. 2).
"""

from __future__ import annotations

import numpy as np

# Below this rotation angle the series expansions are used: at 1e-4 the truncated terms are
# O(theta^4) ~ 1e-16, below double precision, while the closed forms lose digits to
# cancellation in (1 - cos) and (theta - sin).
_SMALL_ANGLE = 1e-4


def hat(omega: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrices of vectors.

    Parameters
    ----------
    omega : numpy.ndarray, shape (..., 3)

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)
        ``K`` with ``K @ x == cross(omega, x)``.
    """
    omega = np.asarray(omega, dtype=np.float64)
    k = np.zeros((*omega.shape[:-1], 3, 3))
    x, y, z = omega[..., 0], omega[..., 1], omega[..., 2]
    k[..., 0, 1], k[..., 0, 2] = -z, y
    k[..., 1, 0], k[..., 1, 2] = z, -x
    k[..., 2, 0], k[..., 2, 1] = -y, x
    return k


def twist_matrix(omega: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The 4x4 matrix ``m`` of the paper's eq. (1) for twists ``(omega, v)``.

    Parameters
    ----------
    omega, v : numpy.ndarray, shape (..., 3)

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4)
    """
    omega = np.asarray(omega, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    shape = np.broadcast_shapes(omega.shape, v.shape)
    m = np.zeros((*shape[:-1], 4, 4))
    m[..., :3, :3] = hat(np.broadcast_to(omega, shape))
    m[..., :3, 3] = np.broadcast_to(v, shape)
    return m


def exp_se3(omega: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Exponential of twists, in closed form (Rodrigues for SO(3), its integral for SE(3)).

    Parameters
    ----------
    omega : numpy.ndarray, shape (..., 3)
        Angular part (rad). Its norm is the rotation angle.
    v : numpy.ndarray, shape (..., 3)
        Linear part (length units of the frame).

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4)
        Homogeneous rigid transforms ``exp(twist_matrix(omega, v))``.
    """
    omega = np.asarray(omega, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    shape = np.broadcast_shapes(omega.shape, v.shape)
    omega = np.broadcast_to(omega, shape)
    v = np.broadcast_to(v, shape)

    theta = np.linalg.norm(omega, axis=-1)
    small = theta < _SMALL_ANGLE
    safe = np.where(small, 1.0, theta)
    t2 = theta * theta
    # a = sin/theta, b = (1-cos)/theta^2, c = (theta-sin)/theta^3, with Taylor series near 0.
    a = np.where(small, 1.0 - t2 / 6.0 + t2 * t2 / 120.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (1.0 - np.cos(safe)) / safe**2)
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0, (safe - np.sin(safe)) / safe**3)

    k = hat(omega)
    k2 = k @ k
    eye = np.eye(3)
    rot = eye + a[..., None, None] * k + b[..., None, None] * k2
    left_jacobian = eye + b[..., None, None] * k + c[..., None, None] * k2

    out = np.zeros((*shape[:-1], 4, 4))
    out[..., :3, :3] = rot
    out[..., :3, 3] = np.einsum("...ij,...j->...i", left_jacobian, v)
    out[..., 3, 3] = 1.0
    return out


def invert_rigid(transform: np.ndarray) -> np.ndarray:
    """Inverse of rigid (or similarity with orthogonal-times-scale) 4x4 transforms.

    Parameters
    ----------
    transform : numpy.ndarray, shape (..., 4, 4)
        Rigid transforms ``[R t; 0 1]`` with ``R`` a rotation.

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4)
    """
    transform = np.asarray(transform, dtype=np.float64)
    rot = transform[..., :3, :3]
    rot_t = np.swapaxes(rot, -1, -2)
    out = np.zeros_like(transform)
    out[..., :3, :3] = rot_t
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", rot_t, transform[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def rigid_defects(transforms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How far each 4x4 matrix is from a proper rigid transform.

    Parameters
    ----------
    transforms : numpy.ndarray, shape (..., 4, 4)

    Returns
    -------
    orthonormality : numpy.ndarray, shape (...)
        ``max |R^T R - I|`` of the rotation part R.
    determinant : numpy.ndarray, shape (...)
        ``det R`` (+1 for a rotation, -1 for a reflection).
    last_row : numpy.ndarray, shape (...)
        ``max |row 3 - (0, 0, 0, 1)|``.
    """
    transforms = np.asarray(transforms, dtype=np.float64)
    rot = transforms[..., :3, :3]
    gram = np.einsum("...ki,...kj->...ij", rot, rot)
    orthonormality = np.abs(gram - np.eye(3)).max(axis=(-2, -1))
    last_row = np.abs(transforms[..., 3, :] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=-1)
    return orthonormality, np.linalg.det(rot), last_row


def rigid_defect(transform: np.ndarray, atol: float) -> str | None:
    """What keeps one 4x4 matrix from a proper rigid transform within ``atol``, in the words
    of an error message ("its last row is ...", "... (a reflection)", "... a scale or a
    shear", "... determinant ..., ... from 1"), the first of those that applies; None when
    it is rigid.

    Parameters
    ----------
    transform : numpy.ndarray, shape (4, 4)
    atol : float
        Absolute tolerance on ``R^T R = I``, ``det R = 1`` and the last row.
    """
    transform = np.asarray(transform, dtype=np.float64)
    orthonormality, determinant, last_row = (float(x) for x in rigid_defects(transform))
    if last_row > atol:
        return f"its last row is {transform[3].tolist()}, not [0, 0, 0, 1]"
    if determinant < 0:
        return f"its rotation part has determinant {determinant:.6g} (a reflection)"
    if orthonormality > atol:
        return (
            f"its rotation part is not orthonormal (max |R^T R - I| = {orthonormality:.3g}: "
            "a scale or a shear)"
        )
    if abs(determinant - 1.0) > atol:
        return (
            f"its rotation part has determinant {determinant:.15g}, "
            f"{abs(determinant - 1.0):.3g} from 1"
        )
    return None


def is_rigid(transform: np.ndarray, atol: float = 1e-6) -> bool:
    """Whether a 4x4 matrix is a proper rigid transform (rotation with det +1, last row 0 0 0 1).

    Parameters
    ----------
    transform : numpy.ndarray, shape (4, 4)
    atol : float
        Absolute tolerance on ``R^T R = I``, ``det R = 1`` and the last row.

    Returns
    -------
    bool
    """
    transform = np.asarray(transform, dtype=np.float64)
    if transform.shape != (4, 4) or not np.all(np.isfinite(transform)):
        return False
    orthonormality, determinant, last_row = rigid_defects(transform)
    return bool(orthonormality <= atol and abs(determinant - 1.0) <= atol and last_row <= atol)
