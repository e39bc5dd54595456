"""Distances computed from the grasps themselves, to set the descriptor's numbers beside.

- ``"joints"``: Euclidean distance of the hand's joint values (radians, or metres for slide
  joints); only between grasps of one hand model.
- ``"position"``: distance of the object's centre of volume in the hand's canonical frame
  (canonical units, the paths' own unit of length).
- ``"origin"``: distance of the origin of the object's own coordinates in the canonical frame
  (the translation of ``object_pose``). Not invariant to the object's symmetries: for a box
  whose file puts the origin at a corner, it also tells which way round the box is.
- ``"pose"``: ``position`` plus the rotation angle (radians) between the two object
  orientations, the smallest over the object's symmetries
  (`exactgrasp.evaluation.symmetry.object_symmetries`): one radian weighs like one canonical
  unit, as along the paths.
- ``"contacts"``: Jaccard distance of the sets of hand links within ``gap`` of the object
  (1 - shared / either); 0 when both touch with the same links.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.distance import cdist

from exactgrasp.errors import EvaluationError
from exactgrasp.evaluation.names import BASELINES
from exactgrasp.evaluation.symmetry import object_symmetries
from exactgrasp.geometry.bvh import DEFAULT_ENGINE, build_bvh, distance
from exactgrasp.grasp import Grasp

__all__ = [
    "BASELINES",
    "CONTACT_GAP",
    "baseline_matrix",
    "contact_links",
    "joint_vectors",
    "object_placements",
]

#: The baselines by name.
#: A link closer than this (m) to the object touches it.
CONTACT_GAP = 1e-3


def joint_vectors(grasps: Sequence[Grasp]) -> np.ndarray:
    """Joint values of each grasp, shape (n, n_joints), in the first grasp's joint order."""
    names = tuple(grasps[0].hand.joint_names)
    rows = []
    for g in grasps:
        if tuple(g.hand.joint_names) != names and set(g.hand.joint_names) != set(names):
            raise EvaluationError(
                f"the joints baseline compares grasps of one hand only; grasp {g.name!r} has "
                f"joints {sorted(g.hand.joint_names)}, grasp {grasps[0].name!r} has "
                f"{sorted(names)}. Leave 'joints' out of the baselines for mixed hands."
            )
        joints = g.hand.joints
        rows.append([float(joints[n]) for n in names])
    return np.asarray(rows, dtype=np.float64).reshape(len(grasps), len(names))


def object_placements(grasps: Sequence[Grasp]) -> tuple[np.ndarray, np.ndarray]:
    """Object centres (canonical units) and rotations (object -> canonical) of each grasp.

    Returns
    -------
    centres : numpy.ndarray, shape (n, 3)
    rotations : numpy.ndarray, shape (n, 3, 3)
    """
    centres, rotations = [], []
    for g in grasps:
        m = g.frame.matrix @ g.object_pose
        centres.append(m[:3, :3] @ g.object.centroid + m[:3, 3])
        rotations.append(m[:3, :3] / g.frame.scale)
    return np.asarray(centres), np.asarray(rotations)


def _rotation_angles(rotations: np.ndarray, symmetries: list[np.ndarray]) -> np.ndarray:
    n = len(rotations)
    best = np.full((n, n), np.inf)
    for s in symmetries:
        turned = rotations @ s[:3, :3]
        # trace(R_i^T R_j S) for all i, j
        trace = np.einsum("iab,jab->ij", rotations, turned)
        angle = np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0))
        best = np.minimum(best, angle)
    return np.minimum(best, best.T)


def contact_links(grasp: Grasp, gap: float = CONTACT_GAP, engine: str = DEFAULT_ENGINE) -> set:
    """Names of the hand links within ``gap`` (m) of the object (touching or crossing it)."""
    obj = build_bvh(engine, grasp.object.vertices, grasp.object.faces)
    touching = set()
    for name, (v, f) in zip(grasp.hand.link_names, grasp.hand.link_arrays(), strict=True):
        link = build_bvh(engine, v, f)
        if distance(engine, link, np.eye(4), obj, grasp.object_pose) <= gap:
            touching.add(name)
    return touching


def baseline_matrix(grasps: Sequence[Grasp], name: str, gap: float = CONTACT_GAP) -> np.ndarray:
    """Pairwise distances of one baseline.

    Parameters
    ----------
    grasps : sequence of Grasp, length n
    name : {"joints", "position", "origin", "pose", "contacts"}
    gap : float
        Contact distance (m) of the ``"contacts"`` baseline.

    Returns
    -------
    numpy.ndarray, shape (n, n)
    """
    grasps = list(grasps)
    if name == "joints":
        x = joint_vectors(grasps)
        return cdist(x, x)
    if name == "origin":
        origins = np.array([(g.frame.matrix @ g.object_pose)[:3, 3] for g in grasps])
        return cdist(origins, origins)
    if name in ("position", "pose"):
        centres, rotations = object_placements(grasps)
        matrix = cdist(centres, centres)
        if name == "pose":
            objects = {g.object.hash: g.object for g in grasps}
            if len(objects) > 1:
                raise EvaluationError(
                    "the pose baseline compares orientations of one object only; these grasps "
                    f"hold {len(objects)} different objects. Use 'position' instead."
                )
            symmetries = object_symmetries(next(iter(objects.values())))
            matrix = matrix + _rotation_angles(rotations, symmetries)
        return matrix
    if name == "contacts":
        sets = [contact_links(g, gap) for g in grasps]
        n = len(sets)
        matrix = np.zeros((n, n))
        for i in range(n):
            for j in range(i + 1, n):
                union = sets[i] | sets[j]
                shared = sets[i] & sets[j]
                matrix[i, j] = matrix[j, i] = 1.0 - len(shared) / len(union) if union else 0.0
        return matrix
    raise EvaluationError(f"baseline {name!r} is unknown; use one of {BASELINES}.")
