"""The volume's derivatives as surface moments, and their boolean reference.

Moving the object rigidly with the spatial twist ``ξ = (v, ω)`` (a point ``x`` at velocity
``v + ω × x``) changes the volume of hand ∩ object at the rate

``dV/dε = ∫_{∂O ∩ H} (v + ω × x) · n_O dA = v · F_O + ω · M_O``,

``F_O = ∫ n_O dA`` and ``M_O = ∫ x × n_O dA`` over the object's boundary inside the hand
(``n_O`` its outward normal): the object gains volume where its surface advances into the
hand. The boundary of hand ∩ object is that surface plus the hand's boundary inside the object,
and a rigid velocity field has no divergence, so the two surfaces' fluxes cancel: with ``F_l``,
``M_l`` the same moments of the part of link ``l``'s boundary (the boundary of the union of the
links, face by face) inside the object, ``(F_O, M_O) = -Σ_l (F_l, M_l)``; and moving link ``l``
with the twist ``ξ_l`` changes the volume at ``ξ_l · (F_l, M_l)``.

`boolean_moments` computes these moments from one manifold3d boolean per pose, whose
triangles remember the solid they come from; it is the reference of the kernel's moments
(`_kernel.pose_volumes` with moments) and the fallback where the kernel hands a pose to the
boolean.
"""

from __future__ import annotations

import manifold3d
import numpy as np

from exactgrasp.backends.exact.tolerances import BOOLEAN_ROUNDING

__all__ = [
    "boolean_moments",
    "face_origins",
    "face_sources",
    "original_ids",
    "shift_moments",
    "triangle_moments",
]


def triangle_moments(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Per triangle, ``∫ n dA`` and ``∫ x × n dA`` (n the unit normal of the counter-clockwise
    orientation).

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3)
    F : numpy.ndarray, shape (m, 3) int

    Returns
    -------
    numpy.ndarray, shape (m, 6)
        Area units (3), then area times length units (3).
    """
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    half = 0.5 * np.cross(b - a, c - a)
    centre = (a + b + c) / 3.0
    return np.concatenate([half, np.cross(centre, half)], axis=1)


def shift_moments(moments: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """Moments ``(F, M)`` (..., 6) taken in coordinates ``x - origin``, re-taken in ``x``:
    ``M + origin × F``."""
    out = np.array(moments, dtype=np.float64)
    out[..., 3:] += np.cross(origin, out[..., :3])
    return out


def boolean_moments(
    hand_solid: manifold3d.Manifold,
    link_ids: list[int],
    object_solid: manifold3d.Manifold,
    pose: np.ndarray,
    areas: float,
) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume of hand ∩ moved object and its surface moments, from one manifold3d boolean.

    Parameters
    ----------
    hand_solid : manifold3d.Manifold
        The union of the links, each link built as its own manifold3d original.
    link_ids : list of int
        The links' manifold3d original ids, in link order (L).
    object_solid : manifold3d.Manifold
    pose : numpy.ndarray, shape (4, 4)
        The object's motion (same coordinates as both solids).
    areas : float
        Both surfaces' area: a volume below manifold3d's rounding over them reads 0
        (`tolerances.BOOLEAN_ROUNDING`, as the intersector's fallback).

    Returns
    -------
    volume : float
    links : numpy.ndarray, shape (L, 6)
        ``(F_l, M_l)`` of each link's boundary inside the object (0 where the volume reads 0).
    obj : numpy.ndarray, shape (6,)
        ``(F_O, M_O)`` of the object's boundary inside the hand.
    """
    moved = object_solid.transform(pose[:3, :])
    result = hand_solid ^ moved
    volume = float(result.volume())
    tolerance = max(hand_solid.get_tolerance(), moved.get_tolerance())
    links = np.zeros((len(link_ids), 6))
    obj = np.zeros(6)
    if volume <= BOOLEAN_ROUNDING * tolerance * areas:
        return 0.0, links, obj
    mesh = result.to_mesh64()
    V = np.asarray(mesh.vert_properties)[:, :3].astype(np.float64)
    F = np.asarray(mesh.tri_verts).astype(np.int64)
    moments = triangle_moments(V, F)
    starts = np.asarray(mesh.run_index, np.int64) // 3
    row = {oid: k for k, oid in enumerate(link_ids)}
    for r, oid in enumerate(np.asarray(mesh.run_original_id)):
        part = moments[starts[r] : starts[r + 1]].sum(0)
        if int(oid) in row:
            links[row[int(oid)]] += part
        else:
            obj += part
    return volume, links, obj


def face_origins(solid: manifold3d.Manifold, link_ids: list[int]) -> np.ndarray:
    """The link (index into ``link_ids``) of each triangle of ``solid.to_mesh64()``, from the
    mesh's runs of original ids (m,) int64."""
    mesh = solid.to_mesh64()
    starts = np.asarray(mesh.run_index, np.int64) // 3
    row = {oid: k for k, oid in enumerate(link_ids)}
    out = np.empty(len(np.asarray(mesh.tri_verts)), np.int64)
    for r, oid in enumerate(np.asarray(mesh.run_original_id)):
        out[starts[r] : starts[r + 1]] = row[int(oid)]
    return out


def face_sources(solid: manifold3d.Manifold, ids: list[int]) -> np.ndarray:
    """The (solid, face) each triangle of ``solid.to_mesh64()`` comes from: the index into
    ``ids`` of its run's original id, and its manifold3d face id (the input triangle's index
    where the solid was built with `geometry.manifold.to_manifold`'s ``face_ids``), shape
    (m, 2) int64."""
    mesh = solid.to_mesh64()
    out = np.empty((len(np.asarray(mesh.tri_verts)), 2), np.int64)
    out[:, 0] = face_origins(solid, ids)
    out[:, 1] = np.asarray(mesh.face_id, np.int64)
    return out


def original_ids(solids: list[manifold3d.Manifold]) -> list[int]:
    """Each solid's manifold3d original id: its own, or where it has none (a solid built from a
    mesh, not marked with ``as_original``) the one its triangles carry."""
    return [
        int(s.original_id())
        if s.original_id() >= 0
        else int(np.asarray(s.to_mesh64().run_original_id)[0])
        for s in solids
    ]
