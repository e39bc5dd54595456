"""The exact backend's reference: the plain manifold3d boolean, and the agreement rule.

`plain_volumes` is what the kernel is checked against (one ``Mesh64`` boolean of the whole hand
and the whole object per pose); `agrees` is the rule "to `RTOL` relative, floored at `FLOOR`
of the hand's volume" (see "Agreement" in ``docs/exact-backend.md``); `plain_error` is how far
`plain_volumes` itself may be from the truth.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.base import check_poses
from exactgrasp.backends.exact.tolerances import BOOLEAN_SLACK, RTOL
from exactgrasp.errors import BackendError
from exactgrasp.geometry.manifold import to_manifold, union_solids

#: Volumes below FLOOR times the hand volume are compared in absolute terms (see `agrees`).
FLOOR = 1e-6

#: manifold3d's tolerance, relative to the coordinates' magnitude (see `plain_error`).
MANIFOLD_TOLERANCE = 1e-12

#: A closed, outward-oriented triangle mesh: vertices (n, 3) float64, faces (m, 3) int.
Mesh = tuple[np.ndarray, np.ndarray]


def agrees(a: np.ndarray, b: np.ndarray, hand_volume: float, rtol: float = RTOL) -> np.ndarray:
    """Whether volumes `a` agree with reference volumes `b` "to `rtol` relative".

    ``|a - b| <= rtol * max(|b|, FLOOR * hand_volume)`` with ``FLOOR = 1e-6``: a volume is
    compared relative to itself, except that volumes under a millionth of the hand's are
    compared relative to that millionth (a relative difference of a volume that is, say,
    1e-20 of the hand carries no information; the floor keeps the test meaningful down to
    about 1e-15 of the hand volume in absolute terms).

    Parameters
    ----------
    a, b : numpy.ndarray
        Volumes to compare, same shape (cubed canonical units).
    hand_volume : float
        Volume of the hand (the union of its links).
    rtol : float
        Relative tolerance.

    Returns
    -------
    numpy.ndarray of bool, same shape.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.abs(a - b) <= rtol * np.maximum(np.abs(b), FLOOR * hand_volume)


def plain_error(volumes: np.ndarray, size: float, area: float) -> np.ndarray:
    """How far `plain_volumes` may lie from the true volumes: `RTOL` of each, plus what
    manifold3d's merging within its tolerance (`MANIFOLD_TOLERANCE` of the coordinates'
    magnitude) can move, `BOOLEAN_SLACK` times that tolerance times the surfaces' area.

    Parameters
    ----------
    volumes : numpy.ndarray
        `plain_volumes`' volumes (cubed units of the meshes).
    size : float
        The largest absolute coordinate of the meshes.
    area : float
        The surfaces' area (both meshes).

    Returns
    -------
    numpy.ndarray, same shape as ``volumes``
    """
    return RTOL * np.abs(volumes) + BOOLEAN_SLACK * MANIFOLD_TOLERANCE * size * area


def solids(meshes: list[Mesh], what: str, face_ids: bool = False) -> list:
    """manifold3d solids of meshes (`geometry.manifold.to_manifold`, with ``face_ids``), named
    ``"<what> <i>"`` in messages; refuses an empty list."""
    if not meshes:
        raise BackendError(f"no {what} meshes given; pass at least one (V, F) pair.")
    return [to_manifold(V, F, f"{what} {i}", face_ids=face_ids) for i, (V, F) in enumerate(meshes)]


def plain_volumes(hand_links: list[Mesh], object_bodies: list[Mesh], poses) -> np.ndarray:
    """Reference: one manifold3d boolean of (union of links) ∩ (moved object) per pose.

    Parameters
    ----------
    hand_links, object_bodies : list of (V (n, 3) float64, F (m, 3) int)
        Closed, outward-oriented meshes in the canonical frame.
    poses : numpy.ndarray, shape (..., 4, 4)
        Rigid transforms of the object (``x -> R @ x + t``).

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2]
        Intersection volumes in cubed canonical units.
    """
    poses = check_poses(poses)
    hand = union_solids(solids(hand_links, "hand link"))
    obj = union_solids(solids(object_bodies, "object body"))
    flat = poses.reshape(-1, 4, 4)
    out = np.array([(hand ^ obj.transform(p[:3, :])).volume() for p in flat])
    return out.reshape(poses.shape[:-2])
