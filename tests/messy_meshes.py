"""Closed surfaces as labs ship them: edges of four faces, shells touching at a corner,
surfaces folded or looped through themselves, repeated faces. Each builder returns
``(vertices (n, 3), faces (m, 3))``, welded (coincident corners share one index)."""

from __future__ import annotations

import numpy as np

from tests.conftest import box_arrays


def joined(*parts, weld: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Meshes side by side in one array pair; with ``weld``, equal corners merged."""
    vs, fs, offset = [], [], 0
    for v, f in parts:
        vs.append(np.asarray(v, float))
        fs.append(np.asarray(f) + offset)
        offset += len(v)
    V, F = np.concatenate(vs), np.concatenate(fs)
    if not weld:
        return V, F
    V, inverse = np.unique(V, axis=0, return_inverse=True)
    return V, inverse.reshape(-1)[F].reshape(-1, 3)


def cubes_sharing_an_edge() -> tuple[np.ndarray, np.ndarray]:
    """Unit cubes [0,1]^3 and [1,2]x[1,2]x[0,1]: the edge x = y = 1 has four faces. Volume 2."""
    return joined(box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([1, 1, 0], [2, 2, 1]))


def tetrahedra_sharing_a_vertex() -> tuple[np.ndarray, np.ndarray]:
    """Two corner tetrahedra of side 1 meeting at the origin. Volume 1/3."""
    a = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return joined((a, f), (-a, f[:, ::-1]))


# The well of `dented_box`: its cross-section and depth.
WELL = (0.3, 0.65, 0.25, 0.7)
WELL_BOTTOM = -0.5
#: The solid of `dented_box`: the unit box less a through-hole of the well's cross-section.
DENTED_VOLUME = 1.0 - (WELL[1] - WELL[0]) * (WELL[3] - WELL[2])


def dented_box() -> tuple[np.ndarray, np.ndarray]:
    """A unit box whose top, over the well's cross-section, is pushed down through the floor
    to z = -0.5: one shell crossing itself. Inside the well above the floor the winding number
    is 0, below the floor -1; the solid is the box with a square through-hole."""
    x0, x1, y0, y1 = WELL
    zb = WELL_BOTTOM
    index: dict[tuple, int] = {}
    faces: list[list[int]] = []

    def v(p):
        return index.setdefault(tuple(float(c) for c in p), len(index))

    def quad(a, b, c, d):  # counter-clockwise seen from outside
        faces.extend([[v(a), v(b), v(c)], [v(a), v(c), v(d)]])

    faces += [
        [v((0, 0, 0)), v((1, 1, 0)), v((1, 0, 0))],
        [v((0, 0, 0)), v((0, 1, 0)), v((1, 1, 0))],
    ]
    quad((0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1))
    quad((1, 0, 0), (1, 1, 0), (1, 1, 1), (1, 0, 1))
    quad((1, 1, 0), (0, 1, 0), (0, 1, 1), (1, 1, 1))
    quad((0, 1, 0), (0, 0, 0), (0, 0, 1), (0, 1, 1))
    quad((0, 0, 1), (1, 0, 1), (x1, y0, 1), (x0, y0, 1))
    quad((1, 0, 1), (1, 1, 1), (x1, y1, 1), (x1, y0, 1))
    quad((1, 1, 1), (0, 1, 1), (x0, y1, 1), (x1, y1, 1))
    quad((0, 1, 1), (0, 0, 1), (x0, y0, 1), (x0, y1, 1))
    quad((x0, y0, 1), (x1, y0, 1), (x1, y0, zb), (x0, y0, zb))
    quad((x1, y0, 1), (x1, y1, 1), (x1, y1, zb), (x1, y0, zb))
    quad((x1, y1, 1), (x0, y1, 1), (x0, y1, zb), (x1, y1, zb))
    quad((x0, y1, 1), (x0, y0, 1), (x0, y0, zb), (x0, y1, zb))
    quad((x0, y0, zb), (x1, y0, zb), (x1, y1, zb), (x0, y1, zb))
    return np.array(list(index)), np.array(faces)


def folded_box(corner=(-0.5, 0.55, 0.45)) -> tuple[np.ndarray, np.ndarray]:
    """A unit box whose corner (1, 1, 1) is pushed to ``corner``, through the face x = 0."""
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    v[7] = corner
    return v, f


def figure_eight_tube(n: int = 120, k: int = 16, r: float = 0.12):
    """A closed tube of radius r along a figure-eight curve that passes through itself near
    the origin (a torus of one shell; winding number 2 where the two branches overlap)."""
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    c = np.stack(
        [np.sin(s), np.sin(s) * np.cos(s) + 0.013 * np.cos(3 * s), 0.05 * np.sin(s + 0.3)], 1
    )
    dc = np.stack([np.cos(s), np.cos(2 * s) - 0.039 * np.sin(3 * s), 0.05 * np.cos(s + 0.3)], 1)
    t = dc / np.linalg.norm(dc, axis=1)[:, None]
    normal = np.cross([0, 0, 1.0], t)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    binormal = np.cross(t, normal)
    a = np.linspace(0, 2 * np.pi, k, endpoint=False) + 0.1
    ring = (
        np.cos(a)[None, :, None] * normal[:, None] + np.sin(a)[None, :, None] * binormal[:, None]
    )
    V = (c[:, None, :] + r * ring).reshape(-1, 3)
    faces = []
    for i in range(n):
        for j in range(k):
            p, q = i * k + j, i * k + (j + 1) % k
            p2, q2 = ((i + 1) % n) * k + j, ((i + 1) % n) * k + (j + 1) % k
            faces += [[p, p2, q2], [p, q2, q]]
    F = np.array(faces)
    a0, b0, c0 = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    if np.einsum("ij,ij->", a0, np.cross(b0, c0)) < 0:
        F = F[:, ::-1].copy()
    return V, F


# Volumes of the solids (points of winding number >= 1) of `folded_box()` and
# `figure_eight_tube()`, from libigl's CGAL boolean (exact arithmetic):
# igl.copyleft.cgal.mesh_boolean(V, F, empty, empty, "union"), libigl 2.6.3.
FOLDED_VOLUME_CGAL = 0.25925925925925924
FIGURE_EIGHT_VOLUME_CGAL = 0.26045444446368526
