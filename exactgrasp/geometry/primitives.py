"""Closed triangle meshes of primitive shapes (box, sphere, capsule, cylinder, ellipsoid).

Every builder returns ``(V, F)``: vertices ``(n, 3)`` float64 and faces ``(m, 3)`` int64,
a single closed shell without duplicate vertices whose faces are ordered counter-clockwise
seen from outside (outward normals, positive signed volume). Shapes are centred on the
origin with their axis of symmetry along +z, the conventions of MuJoCo's geoms.

Curved shapes are *inscribed*: every vertex lies on the true surface, so the mesh lies inside
the true solid and its volume is slightly smaller, converging quadratically as ``segments``
grows: at 32 segments by 0.6 % for a cylinder (``(2 pi / segments)^2 / 6``), 0.9 % for a
capsule and 1.6 % for a sphere or ellipsoid; 0.1 % .. 0.4 % at 64.
Inscribing keeps a contact that touches the true shape from turning into a penetration of
the mesh.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.errors import MeshError

__all__ = ["box", "capsule", "cylinder", "ellipsoid", "sphere"]


def _check_segments(segments: int) -> int:
    if isinstance(segments, bool) or int(segments) != segments or segments < 4:
        raise MeshError(f"segments must be an integer >= 4, got {segments!r}")
    return int(segments)


def _check_positive(name: str, value) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise MeshError(f"{name} must be finite and > 0, got {value!r}")
    return arr


def _lathe(radii: np.ndarray, heights: np.ndarray, top: float, bottom: float, segments: int):
    """Surface of revolution about z: a top pole, rings of ``segments`` vertices, a bottom pole.

    Parameters
    ----------
    radii, heights : ndarray, shape (k,)
        Ring radii and z values, ordered from the top ring to the bottom ring.
    top, bottom : float
        z of the two poles (the fans closing the shell).
    segments : int
        Vertices per ring.

    Returns
    -------
    V : ndarray, shape (k * segments + 2, 3), float64
    F : ndarray, shape (2 * k * segments, 3), int64
    """
    n = segments
    k = len(radii)
    angles = 2.0 * np.pi * np.arange(n) / n
    ring = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    rings = np.concatenate(
        [np.column_stack([r * ring, np.full(n, z)]) for r, z in zip(radii, heights, strict=True)]
    )
    V = np.vstack([[0.0, 0.0, top], rings, [0.0, 0.0, bottom]])
    top_id, bottom_id = 0, k * n + 1
    j = np.arange(n)
    j1 = (j + 1) % n
    faces = [np.column_stack([np.full(n, top_id), 1 + j, 1 + j1])]
    for i in range(k - 1):
        a, b = 1 + i * n + j, 1 + i * n + j1
        c, d = a + n, b + n
        faces.append(np.column_stack([a, c, d]))
        faces.append(np.column_stack([a, d, b]))
    last = 1 + (k - 1) * n
    faces.append(np.column_stack([np.full(n, bottom_id), last + j1, last + j]))
    return V, np.concatenate(faces).astype(np.int64)


def box(half_extents) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned box centred on the origin (MuJoCo's box ``size``).

    Parameters
    ----------
    half_extents : array_like, shape (3,)
        Half side lengths along x, y, z (metres, or any unit).

    Returns
    -------
    V : ndarray, shape (8, 3), float64
    F : ndarray, shape (12, 3), int64
    """
    h = _check_positive("half_extents", half_extents)
    if h.shape != (3,):
        raise MeshError(f"half_extents must have 3 values, got shape {h.shape}")
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    # corner index = 4*ix + 2*iy + iz; each quad listed counter-clockwise from outside.
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    F = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], dtype=np.int64)
    return corners * h, F


def sphere(radius: float, segments: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """UV sphere of ``radius`` centred on the origin: the `ellipsoid` of three equal radii
    (``segments`` as there); returns its V (n, 3) float64 and F (m, 3) int64."""
    return ellipsoid((radius, radius, radius), segments)


def ellipsoid(radii, segments: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Ellipsoid centred on the origin with semi-axes along x, y, z.

    Parameters
    ----------
    radii : array_like, shape (3,)
        Semi-axes (MuJoCo's ellipsoid ``size``).
    segments : int
        Vertices around the equator; ``segments // 2`` latitude bands pole to pole.

    Returns
    -------
    V : ndarray, shape (n, 3), float64
    F : ndarray, shape (m, 3), int64
    """
    r = _check_positive("radii", radii)
    if r.shape != (3,):
        raise MeshError(f"radii must have 3 values, got shape {r.shape}")
    n = _check_segments(segments)
    bands = max(n // 2, 2)
    polar = np.pi * np.arange(1, bands) / bands
    V, F = _lathe(np.sin(polar), np.cos(polar), 1.0, -1.0, n)
    return V * r, F


def cylinder(radius: float, half_height: float, segments: int = 32):
    """Closed cylinder centred on the origin, axis along z (MuJoCo's cylinder ``size``).

    Parameters
    ----------
    radius : float
        Cylinder radius.
    half_height : float
        Half the length along z.
    segments : int
        Vertices around each rim.

    Returns
    -------
    V : ndarray, shape (2 * segments + 2, 3), float64
    F : ndarray, shape (4 * segments, 3), int64
    """
    r = float(_check_positive("radius", radius))
    h = float(_check_positive("half_height", half_height))
    return _lathe(np.array([r, r]), np.array([h, -h]), h, -h, _check_segments(segments))


def capsule(radius: float, half_length: float, segments: int = 32):
    """Capsule centred on the origin: a cylinder along z capped by two hemispheres.

    Parameters
    ----------
    radius : float
        Radius of the cylinder and of the hemispherical caps.
    half_length : float
        Half the length of the cylindrical part (MuJoCo's capsule ``size[1]``); the capsule
        spans ``z = -(half_length + radius) .. half_length + radius``.
    segments : int
        Vertices around the equator; each cap has ``segments // 4`` latitude bands.

    Returns
    -------
    V : ndarray, shape (n, 3), float64
    F : ndarray, shape (m, 3), int64
    """
    r = float(_check_positive("radius", radius))
    h = float(_check_positive("half_length", half_length))
    n = _check_segments(segments)
    bands = max(n // 4, 1)
    polar = 0.5 * np.pi * np.arange(1, bands + 1) / bands  # ends on the equator
    radii = np.concatenate([r * np.sin(polar), r * np.sin(polar[::-1])])
    heights = np.concatenate([h + r * np.cos(polar), -h - r * np.cos(polar[::-1])])
    return _lathe(radii, heights, h + r, -h - r, n)
