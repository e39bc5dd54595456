"""Starting configurations: the hand's symmetries as maps of the paths, the object's for poses.

The paper's suggestion for comparing grasps is to "try all possible starting configurations
and take the minimum distance". Two kinds of symmetry could matter:

- *The object's.* The descriptor is computed in the hand's canonical frame and depends on the
  object only as a set of points there, so turning the object by one of its own symmetries
  changes nothing: the descriptor is already invariant (``tests/test_evaluation.py`` checks it
  with the exact backend). Object symmetries matter only for comparing object *poses* (the
  pose baseline, `object_symmetries`).
- *The hand's.* A hand with a mirror plane (the Barrett: fingers 1 and 2 mirror each other
  across the plane x = 0 of its canonical frame) grasps the mirror image of a scene with the
  mirror image of its grasp. The mirrored grasp's descriptor along the sampler's paths is the
  original grasp's along the mirrored paths ``S exp(t twist) S^-1``, so it is computed
  exactly from the original grasp with `symmetric_poses`, without building a mirrored hand or
  object, and with no nearest-path re-mapping (the phyllotaxis paths are not closed under a
  mirror, so re-mapping path indices would only be approximate).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from exactgrasp.errors import EvaluationError
from exactgrasp.geometry.solid import Solid
from exactgrasp.hands.hand import Hand

__all__ = [
    "HAND_SYMMETRIES",
    "SYMMETRIES",
    "as_symmetries",
    "hand_symmetry_mismatch",
    "object_symmetries",
    "symmetric_poses",
]


def _turn(axis: int) -> np.ndarray:
    m = -np.eye(3)
    m[axis, axis] = 1.0
    return m


def _mirror(axis: int) -> np.ndarray:
    m = np.eye(3)
    m[axis, axis] = -1.0
    return m


#: Symmetries of the canonical frame by name: orthogonal 3 x 3 matrices.
SYMMETRIES: dict[str, np.ndarray] = {
    "mirror-x": _mirror(0),
    "mirror-y": _mirror(1),
    "mirror-z": _mirror(2),
    "turn-x": _turn(0),
    "turn-y": _turn(1),
    "turn-z": _turn(2),
}

#: The symmetries of the built-in hands (and of the shared data's Barrett URDF), by hand
#: name; `hand_symmetry_mismatch` measures how exact each is.
HAND_SYMMETRIES: dict[str, tuple[str, ...]] = {
    "barrett": ("mirror-x",),
    "parallel_gripper": ("mirror-x", "mirror-y", "turn-z"),
}


def as_symmetries(value: Any) -> list[tuple[str, np.ndarray]]:
    """Named symmetries from names, matrices or None.

    Parameters
    ----------
    value : None or str or sequence of str or array_like (3, 3)
        Names of `SYMMETRIES` (a comma-separated string is split), or matrices.

    Returns
    -------
    list of (str, numpy.ndarray (3, 3))
        Without the identity.
    """
    if value is None:
        return []
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",") if v.strip()]
    out = []
    for item in value:
        if isinstance(item, str):
            if item not in SYMMETRIES:
                raise EvaluationError(
                    f"symmetry {item!r} is unknown; use names from {sorted(SYMMETRIES)}."
                )
            out.append((item, SYMMETRIES[item]))
            continue
        m = np.asarray(item, dtype=np.float64)
        if m.shape != (3, 3) or not np.allclose(m @ m.T, np.eye(3), atol=1e-9):
            raise EvaluationError(
                f"a symmetry must be an orthogonal 3 x 3 matrix of the canonical frame, got {m}."
            )
        out.append(("matrix", m))
    return out


def symmetric_poses(poses: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """The paths seen through a symmetry: ``S P S^-1`` for every pose ``P``.

    Parameters
    ----------
    poses : numpy.ndarray, shape (..., 4, 4)
        Canonical-frame poses (`PathSampler.poses`).
    matrix : numpy.ndarray, shape (3, 3)
        Orthogonal; a mirror (determinant -1) turns the rotation sense of each path.

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4)
        Proper rigid motions.
    """
    s = np.eye(4)
    s[:3, :3] = matrix
    return s @ poses @ s.T


def hand_symmetry_mismatch(hand: Hand, matrix: np.ndarray) -> float:
    """How far the hand's surface is from its image under a symmetry, canonical units.

    The largest distance from a vertex of the symmetric image of the posed hand to the nearest
    vertex of the hand (both in the canonical frame). Pose the hand symmetrically first (e.g.
    equal joints on mirrored fingers); 0 means the symmetry is exact to the mesh.

    Returns
    -------
    float
    """
    points = np.vstack([v for v, _ in hand.canonical_links()])
    image = points @ np.asarray(matrix, dtype=np.float64).T
    gap, _ = cKDTree(points).query(image)
    return float(gap.max())


def object_symmetries(obj: Solid, tolerance: float = 1e-3) -> list[np.ndarray]:
    """The object's proper rotational symmetries among half turns about its principal axes.

    Parameters
    ----------
    obj : Solid
    tolerance : float
        Largest distance of a turned vertex from the surface, as a fraction of the object's
        extent.

    Returns
    -------
    list of numpy.ndarray, shape (4, 4)
        Object-frame rigid maps, the identity first (a box: 4; a generic shape: 1).
    """
    mesh = obj.to_trimesh()
    centre = np.asarray(mesh.center_mass, dtype=np.float64)
    _, axes = np.linalg.eigh(np.asarray(mesh.moment_inertia, dtype=np.float64))
    points = mesh.vertices
    if len(points) > 2000:
        points = points[np.random.default_rng(0).choice(len(points), 2000, replace=False)]
    query = mesh.nearest
    found = [np.eye(4)]
    for k in range(3):
        turn = axes @ _turn(k) @ axes.T
        m = np.eye(4)
        m[:3, :3] = turn
        m[:3, 3] = centre - turn @ centre
        moved = points @ turn.T + m[:3, 3]
        _, gap, _ = query.on_surface(moved)
        if np.max(gap) <= tolerance * obj.extent:
            found.append(m)
    return found
