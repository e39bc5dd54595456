"""The exact fallback for a pose whose volume the kernel reads within its bound of zero: the
volume of the two surfaces' arrangement, in rational arithmetic.

The kernel's bound (typically 1e-15 to 1e-12 of the scene's size cubed) covers every rounding
of its sums, so an overlap thinner than that (a sliver made by rounding where surfaces touch
far from the origin, or an object smaller than the bound inside the hand) reads within the
bound of zero, and the kernel cannot tell its size. Such a pose is computed again without
rounding: the hand's surface and the moved object's, given as one closed surface, have
winding number 2 exactly where both solids are (each is a 2-manifold, winding number 0 or 1),
and `exactgrasp.geometry.exact_solid.level_volume` gives that set's volume exactly from the
surfaces' exact arrangement. The object is moved with the kernel's own arithmetic
(`pose.move_object`), so the scene is the one the kernel read; the one rounding is the
volume's, to the nearest float.

That scene is the given one up to the rounding that took it into local coordinates and moved
the object there (`scene_rounding`), which the bound adds as both surfaces' areas times the
farthest a vertex can have moved: 0 where that rounding is none (a scene whose shift to local
coordinates is exact, the object at the identity pose).
"""

from __future__ import annotations

import numpy as np

from exactgrasp.geometry.exact_solid import level_volume

__all__ = ["arranged_volume", "moved_like_the_kernel", "scene_rounding", "shift_rounding"]

#: Unit roundoff of float64.
U = 2.0**-53


def moved_like_the_kernel(vertices: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``R x + t`` for each vertex, rounded as `pose.move_object` rounds it: each coordinate
    ``((r0 x + r1 y) + r2 z) + t``, one rounding per operation, no fused multiply-add.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    pose : numpy.ndarray, shape (4, 4), float64

    Returns
    -------
    numpy.ndarray, shape (n, 3), float64
    """
    x, y, z = vertices[:, 0], vertices[:, 1], vertices[:, 2]
    R, t = pose[:3, :3], pose[:3, 3]
    return np.stack([R[k, 0] * x + R[k, 1] * y + R[k, 2] * z + t[k] for k in range(3)], axis=1)


def arranged_volume(
    hand_vertices: np.ndarray,
    hand_faces: np.ndarray,
    object_vertices: np.ndarray,
    object_faces: np.ndarray,
    pose: np.ndarray,
    moved_by: float = 0.0,
    area: float = 0.0,
) -> tuple[float, float]:
    """The volume of hand ∩ (pose · object), exactly, and the bound of its one rounding.

    Parameters
    ----------
    hand_vertices, object_vertices : numpy.ndarray, shape (n, 3), float64
    hand_faces, object_faces : numpy.ndarray, shape (m, 3), int64
        Two closed, outward-oriented 2-manifolds in the kernel's local coordinates (the
        object in its own frame).
    pose : numpy.ndarray, shape (4, 4)
        The object's pose, in local coordinates.
    moved_by, area : float
        How far rounding may have moved the scene's vertices from the given ones
        (`scene_rounding`), and both surfaces' areas: their product joins the bound.

    Returns
    -------
    volume, bound : float
        The exact volume rounded to the nearest float (cubed units), and its bound: half a
        unit in its last place, plus ``moved_by * area``.
    """
    moved = moved_like_the_kernel(object_vertices, pose)
    V = np.concatenate([hand_vertices, moved])
    F = np.concatenate([hand_faces, np.asarray(object_faces, np.int64) + len(hand_vertices)])
    volume = float(level_volume(V, F, 2))
    return volume, float(np.spacing(volume)) / 2 + moved_by * area


def shift_rounding(meshes, origin: np.ndarray) -> float:
    """The largest error of ``V - origin`` over the meshes' vertices (error-free difference:
    0 when every shift is exact), in the meshes' units.

    Parameters
    ----------
    meshes : list of (vertices (n, 3) float64, faces)
    origin : numpy.ndarray, shape (3,)
    """
    worst = 0.0
    for V, _ in meshes:
        a = np.asarray(V, dtype=np.float64)
        d = a - origin
        # Knuth's two-sum of a and -origin: the rounding error of d, exactly.
        b_virtual = d - a
        a_virtual = d - b_virtual
        err = (a - a_virtual) + (-origin - b_virtual)
        worst = max(worst, float(np.abs(err).max(initial=0.0)))
    return worst


def scene_rounding(pose: np.ndarray, shift_error: float, size: float, origin: np.ndarray):
    """A bound on how far a vertex of the scene the kernel reads at ``pose`` (local
    coordinates) lies from where the given meshes and pose put it, in length units.

    The shift into local coordinates errs by ``shift_error``; converting the pose to them
    (``t' = R c + t - c``) and moving the object (`moved_like_the_kernel`) round each of
    their few operations by at most `U` of magnitudes below ``|c| + |t'| + size``: 16 `U`
    of that, times √3 for a length. Nothing where the pose is the identity (exact moves).

    Parameters
    ----------
    pose : numpy.ndarray, shape (4, 4)
    shift_error : float
        `shift_rounding` of hand and object.
    size : float
        Bound on every local coordinate of hand and object.
    origin : numpy.ndarray, shape (3,)
    """
    if np.array_equal(pose, np.eye(4)):
        return shift_error * 3**0.5
    scale = float(np.abs(origin).max() + np.abs(pose[:3, 3]).max() + size)
    return (shift_error + 16.0 * U * scale) * 3**0.5
