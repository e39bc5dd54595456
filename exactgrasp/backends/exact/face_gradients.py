"""The exact volume's derivatives by every vertex of both meshes, from per-face moments.

Moving a point of a solid's boundary outward along ``δ`` adds ``δ · n`` of volume per unit
of area where the boundary lies inside the other solid. A vertex ``i`` of a triangle mesh
moves each face ``f`` around it with velocity ``φ_i δ`` (``φ_i`` the face's barycentric weight
of ``i``), so

``dV/dx_i = Σ_f (∫_{f ∩ other} φ_i dA) n_f``,

``n_f`` the face's unit outward normal. ``φ_i`` is linear, so per face the area ``A`` and the
first moment ``P = ∫ x dA`` of ``f ∩ other`` are enough. The kernel sums, per face of either
union (`ExactIntersector` with ``faces=True``), ``F = ∫ n dA = n A`` and
``M = ∫ x × n dA = P × n``, and ``P · n = d A`` (``d`` the face's plane offset), so
``P = n × M + n d A``. Each face of a union lies in one input face (manifold3d face ids,
`moments.face_sources`), whose pieces add up.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.intersector import ExactIntersector

__all__ = [
    "corner_integrals",
    "face_moments",
    "mesh_vertex_gradients",
    "scatter_corners",
    "side_gradients",
]


def face_moments(
    rows: np.ndarray,
    sources: np.ndarray,
    meshes: list[tuple[np.ndarray, np.ndarray]],
    poses: np.ndarray | None = None,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per input face that meets the other solid, the area and first moment of its part
    inside it: only the rows that are not zero are read.

    Parameters
    ----------
    rows : numpy.ndarray, shape (k, r, 6)
        Per pose and face of a union, ``(∫ n dA, ∫ x × n dA)`` in the frame of the fixed mesh
        (`ExactIntersector.volume_moments` with ``faces=True``, one side's rows).
    sources : numpy.ndarray, shape (r, 2) int
        The (mesh, face) each row's face lies in (`ExactIntersector.face_sources`).
    meshes : list of (V (n, 3), F (m, 3))
        The input meshes (length units), in their own frame.
    poses : numpy.ndarray, shape (k, 4, 4), optional
        Rigid motions that put the meshes into the rows' frame (the moving side); None: the
        meshes are in it already (the fixed side).

    Returns
    -------
    list of (pose (t,) int, face (t,) int, moments (t, 4))
        Per mesh, each (pose, face) met once: the area (squared length units), then the first
        moment ``∫ x dA`` (cubed length units) in the mesh's own frame.
    """
    # A face met has F = n A != 0 (three strided tests: cheaper than one over all six).
    pose, row = np.nonzero((rows[..., 0] != 0.0) | (rows[..., 1] != 0.0) | (rows[..., 2] != 0.0))
    F, M = rows[pose, row, :3], rows[pose, row, 3:]
    if poses is not None:
        R, t = poses[pose, :3, :3], poses[pose, :3, 3]
        # Into the mesh's frame: F_b = R^T F, M_b = R^T (M - t × F).
        M = np.einsum("tji,tj->ti", R, M - np.cross(t, F))
        F = np.einsum("tji,tj->ti", R, F)
    out = []
    for i, (V, Fc) in enumerate(meshes):
        own = np.flatnonzero(sources[row, 0] == i)
        face = sources[row[own], 1]
        a, b, c = V[Fc[face, 0]], V[Fc[face, 1]], V[Fc[face, 2]]
        N = np.cross(b - a, c - a)
        length = np.linalg.norm(N, axis=1)
        n = np.divide(N, length[:, None], out=np.zeros_like(N), where=length[:, None] > 0)
        area = np.einsum("ij,ij->i", F[own], n)
        first = np.cross(n, M[own]) + n * (np.einsum("ij,ij->i", n, a) * area)[:, None]
        keys, back = np.unique(pose[own] * len(Fc) + face, return_inverse=True)
        summed = np.zeros((len(keys), 4))
        np.add.at(summed, back.reshape(-1), np.column_stack([area, first]))
        out.append((keys // len(Fc), keys % len(Fc), summed))
    return out


def corner_integrals(V: np.ndarray, F: np.ndarray, moments: np.ndarray) -> np.ndarray:
    """Per face and corner ``j``, ``(∫ φ_j dA) n_f`` over the face's part inside the other
    solid, from its area and first moment.

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3)
        The mesh's vertices (length units).
    F : numpy.ndarray, shape (t, 3)
        The faces the moments are of (a face may come more than once, one per pose).
    moments : numpy.ndarray, shape (t, 4)
        `face_moments`' area and first moment per face (the mesh's frame).

    Returns
    -------
    numpy.ndarray, shape (t, 3, 3)
        Squared length units: the derivative of the volume by each corner's vertex, face by
        face (a face of no area gives 0).
    """
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    N = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", N, N)
    inv = np.divide(1.0, nn, out=np.zeros_like(nn), where=nn > 0)
    unit = N * np.sqrt(inv)[:, None]
    A, P = moments[:, :1], moments[:, 1:]
    out = np.empty((len(F), 3, 3))
    # φ_j(x) = ((z - y) × (x - y)) · N / |N|² for the corners (x_j, y, z) in turn.
    for j, (y, z) in enumerate(((b, c), (c, a), (a, b))):
        w = np.einsum("ij,ij->i", np.cross(z - y, P - A * y), N) * inv
        out[:, j] = w[:, None] * unit
    return out


def scatter_corners(
    pose: np.ndarray, targets: np.ndarray, corners: np.ndarray, out: np.ndarray
) -> None:
    """Add per-corner vectors (t, 3, 3) of poses ``pose`` (t,) to ``out`` (k, n, 3) at the
    vertices ``targets`` (t, 3) name."""
    k, n = out.shape[:2]
    index, back = np.unique((pose[:, None] * n + targets).reshape(-1), return_inverse=True)
    flat = corners.reshape(-1, 3)
    view = out.reshape(k * n, 3)
    for d in range(3):
        view[index, d] += np.bincount(back.reshape(-1), weights=flat[:, d], minlength=len(index))


def side_gradients(
    rows: np.ndarray,
    sources: np.ndarray,
    meshes: list[tuple[np.ndarray, np.ndarray]],
    poses: np.ndarray | None,
    targets: list[np.ndarray],
    n: int,
) -> np.ndarray:
    """The volume's derivative by every vertex of one side, (k, n, 3) in squared length units:
    `face_moments` of its meshes, their `corner_integrals`, added onto the vertex each corner
    goes to (``targets``: per mesh (m_i, 3) indices among the ``n``; a body's in its own
    frame)."""
    out = np.zeros((len(rows), n, 3))
    moments = face_moments(rows, sources, meshes, poses)
    for (V, F), (pose, face, m), target in zip(meshes, moments, targets, strict=True):
        scatter_corners(pose, target[face], corner_integrals(V, F[face], m), out)
    return out


def mesh_vertex_gradients(
    intersector: ExactIntersector,
    hand: list[tuple[np.ndarray, np.ndarray]],
    bodies: list[tuple[np.ndarray, np.ndarray]],
    poses: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Volumes and the volume's derivative by every vertex of the hand's links and of the
    object's bodies (each in its own frame), for poses (k, 4, 4).

    Parameters
    ----------
    intersector : ExactIntersector
        Built with ``faces=True`` from ``hand`` and ``bodies``.
    hand, bodies : list of (V (n, 3), F (m, 3))
        The meshes it was built from (length units).
    poses : numpy.ndarray, shape (k, 4, 4)
        Checked rigid motions of the bodies.

    Returns
    -------
    volumes : numpy.ndarray, shape (k,)
    hand_grads, body_grads : numpy.ndarray, shapes (k, Σ n_hand, 3) and (k, Σ n_body, 3)
        The meshes' vertices in order, squared length units (volume per length of vertex
        motion); a body's in its own frame (``R^T`` of the derivative by its moved vertex).
    """
    volumes, rows = intersector.volume_moments(poses)
    hand_src, body_src = intersector.face_sources
    mh = len(hand_src)
    out = []
    for meshes, src, part, moved in (
        (hand, hand_src, rows[:, :mh], None),
        (bodies, body_src, rows[:, mh:], poses),
    ):
        offsets = np.cumsum([0] + [len(V) for V, _ in meshes])
        targets = [F + o for (_, F), o in zip(meshes, offsets[:-1], strict=True)]
        out.append(side_gradients(part, src, meshes, moved, targets, int(offsets[-1])))
    return volumes, out[0], out[1]
