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
import scipy.sparse

from exactgrasp.backends.exact.intersector import ExactIntersector

__all__ = ["corner_integrals", "face_moments", "mesh_vertex_gradients", "scatter_corners"]


def face_moments(
    rows: np.ndarray,
    sources: np.ndarray,
    meshes: list[tuple[np.ndarray, np.ndarray]],
    poses: np.ndarray | None = None,
) -> list[np.ndarray]:
    """Per input face, the area and first moment of its part inside the other solid.

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
    list of numpy.ndarray, shape (k, m, 4)
        Per mesh, per pose and face: the area (squared length units), then the first moment
        ``∫ x dA`` (cubed length units) in the mesh's own frame.
    """
    rows = np.asarray(rows, dtype=np.float64)
    F, M = rows[..., :3], rows[..., 3:]
    if poses is not None:
        R, t = poses[:, None, :3, :3], poses[:, None, :3, 3]
        # Into the mesh's frame: F_b = R^T F, M_b = R^T (M - t × F).
        F = np.einsum("kcji,kcj->kci", np.broadcast_to(R, (*F.shape[:2], 3, 3)), F)
        M = np.einsum(
            "kcji,kcj->kci",
            np.broadcast_to(R, (*M.shape[:2], 3, 3)),
            M - np.cross(t, rows[..., :3]),
        )
    out = []
    for i, (V, Fc) in enumerate(meshes):
        own = np.flatnonzero(sources[:, 0] == i)
        face = sources[own, 1]
        a, b, c = V[Fc[face, 0]], V[Fc[face, 1]], V[Fc[face, 2]]
        N = np.cross(b - a, c - a)
        length = np.linalg.norm(N, axis=1)
        n = np.divide(N, length[:, None], out=np.zeros_like(N), where=length[:, None] > 0)
        d = np.einsum("ij,ij->i", n, a)
        area = np.einsum("kij,ij->ki", F[:, own], n)
        first = np.cross(n, M[:, own]) + n * (d * area)[..., None]
        values = np.concatenate([area[..., None], first], axis=-1)  # (k, r_i, 4)
        gather = scipy.sparse.csr_matrix(
            (np.ones(len(own)), (face, np.arange(len(own)))), shape=(len(Fc), len(own))
        )
        k = len(rows)
        flat = values.transpose(1, 0, 2).reshape(len(own), k * 4)
        summed = np.asarray(gather @ flat).reshape(len(Fc), k, 4)
        out.append(summed.transpose(1, 0, 2))
    return out


def corner_integrals(V: np.ndarray, F: np.ndarray, moments: np.ndarray) -> np.ndarray:
    """Per face and corner ``j``, ``(∫ φ_j dA) n_f`` over the face's part inside the other
    solid, from its area and first moment.

    Parameters
    ----------
    V, F : numpy.ndarray, shapes (n, 3) and (m, 3)
        The mesh (length units).
    moments : numpy.ndarray, shape (k, m, 4)
        `face_moments`' area and first moment per face (the mesh's frame).

    Returns
    -------
    numpy.ndarray, shape (k, m, 3, 3)
        Squared length units: the derivative of the volume by each corner's vertex, face by
        face (a face of no area gives 0).
    """
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    N = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", N, N)
    inv = np.divide(1.0, nn, out=np.zeros_like(nn), where=nn > 0)
    unit = N * np.sqrt(inv)[:, None]
    A, P = moments[..., :1], moments[..., 1:]
    out = np.empty((*moments.shape[:2], 3, 3))
    # φ_j(x) = ((z - y) × (x - y)) · N / |N|² for the corners (x_j, y, z) in turn.
    for j, (y, z) in enumerate(((b, c), (c, a), (a, b))):
        w = np.einsum("kij,ij->ki", np.cross(z - y, P - A * y), N) * inv
        out[:, :, j] = w[..., None] * unit
    return out


def scatter_corners(F: np.ndarray, corners: np.ndarray, n: int) -> np.ndarray:
    """Per-corner vectors (k, m, 3, 3) summed onto the vertices ``F`` names: (k, n, 3)."""
    k = corners.shape[0]
    index = (np.arange(k)[:, None] * n + F.reshape(-1)[None, :]).reshape(-1)
    flat = corners.reshape(-1, 3)
    out = np.empty((k * n, 3))
    for d in range(3):
        out[:, d] = np.bincount(index, weights=flat[:, d], minlength=k * n)
    return out.reshape(k, n, 3)


def mesh_vertex_gradients(
    intersector: ExactIntersector,
    hand: list[tuple[np.ndarray, np.ndarray]],
    bodies: list[tuple[np.ndarray, np.ndarray]],
    poses: np.ndarray,
) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
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
    hand_grads, body_grads : list of numpy.ndarray, shape (k, n_i, 3)
        Per mesh, squared length units (volume per length of vertex motion); a body's in its
        own frame (``R^T`` of the derivative by its moved vertex).
    """
    volumes, rows = intersector.volume_moments(poses)
    hand_src, body_src = intersector.face_sources
    mh = len(hand_src)
    out = []
    for meshes, src, part, moved in (
        (hand, hand_src, rows[:, :mh], None),
        (bodies, body_src, rows[:, mh:], poses),
    ):
        moments = face_moments(part, src, meshes, moved)
        out.append(
            [
                scatter_corners(F, corner_integrals(V, F, m), len(V))
                for (V, F), m in zip(meshes, moments, strict=True)
            ]
        )
    return volumes, out[0], out[1]
