"""The exact fallback for a pose whose volume the kernel reads within its bound of zero: the
volume of the two surfaces' arrangement, in rational arithmetic.

The kernel's bound (typically 1e-15 to 1e-12 of the scene's size cubed) covers every rounding
of its sums, so an overlap thinner than that (a sliver made by rounding where surfaces touch
far from the origin, or an object smaller than the bound inside the hand) reads within the
bound of zero, and the kernel cannot tell its size. Such a pose is computed again without
rounding: the hand's surface and the moved object's, given as one closed surface, have
winding number 2 exactly where both solids are (each is a 2-manifold, winding number 0 or 1),
and `exactgrasp.geometry.level_sets.level_set` gives that set's volume exactly from the
surfaces' exact arrangement near the moved object's box (`exactgrasp.geometry.exact_window`:
the set lies in the object), with its boundary's triangles, whose moments
(`arranged_moments`) give the volume's derivatives there as the kernel's would. The object
is moved with the kernel's own arithmetic (`_pose.move_object`), so the scene is the one the
kernel read; the one rounding is the volume's, to the nearest float.

That scene is the given one up to the rounding that took it into local coordinates and moved
the object there (`scene_rounding`), which the bound adds as both surfaces' areas times the
farthest a vertex can have moved: 0 where that rounding is none (a scene whose shift to local
coordinates is exact, the object at the identity pose). A volume within that term of zero is
no more certain than 0 and reads 0, as contacts do in the kernel.
"""

from __future__ import annotations

import threading

import numpy as np

from exactgrasp.backends.exact.tables import MomentTables
from exactgrasp.backends.exact.tolerances import U
from exactgrasp.geometry.exact_window import face_boxes
from exactgrasp.geometry.level_sets import LevelSet, level_set

__all__ = [
    "ArrangedHand",
    "arranged_moments",
    "moved_like_the_kernel",
    "scene_rounding",
    "shift_rounding",
]


def moved_like_the_kernel(vertices: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``R x + t`` for each vertex, rounded as `_pose.move_object` rounds it: each coordinate
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


class ArrangedHand:
    """A hand's surface for the exact volume of its intersection with an object at any pose
    (`volume`): the hand welded, and its faces' boxes, made at the first pose.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
        A closed, outward-oriented 2-manifold in the kernel's local coordinates.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        self.vertices, self.faces = vertices, faces
        self._welded: tuple | None = None
        self._lock = threading.Lock()

    def volume(
        self,
        object_vertices: np.ndarray,
        object_faces: np.ndarray,
        pose: np.ndarray,
        moved_by: float = 0.0,
        area: float = 0.0,
    ) -> tuple[float, float, LevelSet]:
        """The volume of hand ∩ (pose · object), exactly, and the bound of its one rounding.

        The intersection is level 2 of the two surfaces together, which lies in the moved
        object's box: only the faces near it are cut (`exactgrasp.geometry.exact_window`).

        Parameters
        ----------
        object_vertices : numpy.ndarray, shape (k, 3), float64
        object_faces : numpy.ndarray, shape (l, 3), int64
            A closed, outward-oriented 2-manifold, in the object's own frame.
        pose : numpy.ndarray, shape (4, 4)
            The object's pose, in local coordinates.
        moved_by, area : float
            How far rounding may have moved the scene's vertices from the given ones
            (`scene_rounding`), and both surfaces' areas: their product joins the bound.

        Returns
        -------
        volume, bound : float
            The exact volume rounded to the nearest float (cubed units), and its bound: half
            a unit in its last place, plus ``moved_by * area``. A volume no larger than
            ``moved_by * area`` is 0, with twice that as its bound.
        found : exactgrasp.geometry.level_sets.LevelSet
            The intersection; its triangles' sources number the hand's faces first, then
            the object's.
        """
        moved = moved_like_the_kernel(object_vertices, pose)
        V, F, boxes = self._scene(moved, np.asarray(object_faces, np.int64))
        found = level_set(V, F, 2, (moved.min(0), moved.max(0), boxes))
        volume = float(found.volume)
        rounding = moved_by * area
        if volume <= rounding:
            # No larger than what rounding the scene may have made: 0 is as true, and a
            # contact reads 0 as the kernel's do.
            empty = LevelSet(found.volume, found.triangles[:0], found.sources[:0])
            return 0.0, 2.0 * rounding, empty
        return volume, float(np.spacing(volume)) / 2 + rounding, found

    def _scene(self, moved: np.ndarray, object_faces: np.ndarray):
        """The welded scene: distinct points (the hand's, then the object's not among them),
        the hand's faces then the object's into them, and the hand faces' boxes (lowest and
        highest coordinates along each axis, (3, m) each)."""
        with self._lock:
            if self._welded is None:
                W, inverse = np.unique(self.vertices, axis=0, return_inverse=True)
                H = inverse.reshape(-1)[np.asarray(self.faces, np.int64)]
                self._welded = W, np.ascontiguousarray(W.T), H, face_boxes(W, H)
            W, columns, H, boxes = self._welded
        # A hand vertex equal to an object's lies in the object's box.
        lo, hi = moved.min(0), moved.max(0)
        inside = (columns[0] >= lo[0]) & (columns[0] <= hi[0])
        for k in (1, 2):
            inside &= (columns[k] >= lo[k]) & (columns[k] <= hi[k])
        there = np.flatnonzero(inside)
        points, first, back = np.unique(
            np.concatenate([W[there], moved]), axis=0, return_index=True, return_inverse=True
        )
        handed = first < len(there)
        index = np.empty(len(points), np.int64)
        index[handed] = there[first[handed]]
        index[~handed] = len(W) + np.arange(int((~handed).sum()))
        faces = index[back.reshape(-1)[len(there) :]][object_faces]
        V = np.concatenate([W, points[~handed]])
        return V, np.concatenate([H, faces]), boxes


def arranged_moments(
    found: LevelSet, hand_faces: int, tables: MomentTables, rows: int, pose: np.ndarray
) -> np.ndarray:
    """The moments ``(∫ n dA, ∫ x × n dA)`` of the intersection's boundary, by the kernel's
    rows: each link's boundary inside the object (the triangles on hand faces, by
    ``tables.face_link``) and, from row ``tables.object_from`` (where it is not -1), each
    object face's part inside the hand, in the object's own frame as the kernel's
    (``_object_moments.pxd``: the triangles moved back by the pose's inverse).

    Parameters
    ----------
    found : LevelSet
        `ArrangedHand.volume`'s intersection.
    hand_faces : int
        The hand's faces (the object's are numbered after them).
    tables : tables.MomentTables
        The kernel's moment tables (``face_link``: the row of each hand face).
    rows : int
    pose : numpy.ndarray, shape (4, 4)
        The object's pose, in local coordinates.

    Returns
    -------
    numpy.ndarray, shape (rows, 6), float64
        Local coordinates, length units squared and cubed.
    """
    hand = found.sources < hand_faces
    out = np.zeros((rows, 6))
    np.add.at(out, tables.face_link[found.sources[hand]], _triangle_moments(found.triangles[hand]))
    object_from = int(tables.object_from[0])
    if object_from >= 0:
        R, t = pose[:3, :3], pose[:3, 3]
        T = (found.triangles[~hand] - t) @ R
        np.add.at(out, object_from + found.sources[~hand] - hand_faces, _triangle_moments(T))
    return out


def _triangle_moments(T: np.ndarray) -> np.ndarray:
    """``(∫ n dA, ∫ x × n dA)`` of triangles (t, 3, 3): a flat triangle's ∫ n dA is its area
    vector, and ∫ x × n dA its centroid × that."""
    area = 0.5 * np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    return np.hstack([area, np.cross(T.mean(axis=1), area)])


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
