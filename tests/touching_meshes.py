"""Solids whose surfaces touch themselves, grown from a real finger link: cavities touching the
outer shell along an edge or at a vertex, an island in such a cavity on the same edge, wedges
around one edge (edges of four and six faces) and shells touching along a face. Every
coordinate is a dyadic rational, so each solid's volume is known exactly (`VOLUMES`); each
builder returns ``(vertices (n, 3), faces (m, 3))``, welded, outward shells counter-clockwise
seen from outside and cavities the other way."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from tests.conftest import box_arrays
from tests.messy_meshes import joined

# The unit box's top (z = 1) with two inner points A and B, so that the edge A-B is one of its
# edges: two triangles of the top meet there.
A, B = (3 / 8, 1 / 2, 1.0), (5 / 8, 1 / 2, 1.0)
CORNERS = [(0, 0, 1.0), (1, 0, 1.0), (1, 1, 1.0), (0, 1, 1.0)]
# Below the edge: the cavity's other corners, and the island's inside the cavity.
C, D = (1 / 2, 1 / 4, 3 / 4), (1 / 2, 3 / 4, 3 / 4)
E, G = (1 / 2, 7 / 16, 7 / 8), (1 / 2, 9 / 16, 7 / 8)


def _mesh(triangles) -> tuple[np.ndarray, np.ndarray]:
    """Triangles given as corner triples, welded into arrays."""
    points = np.array([p for t in triangles for p in t], float)
    return joined((points, np.arange(len(points)).reshape(-1, 3)))


def _tetrahedron(p, q, r, s, outward: bool = True):
    """Triangles of the tetrahedron pqrs, outward (or inward) oriented."""
    faces = [(p, r, q), (p, q, s), (p, s, r), (q, r, s)]
    sign = np.linalg.det(np.array([np.subtract(q, p), np.subtract(r, p), np.subtract(s, p)]))
    if (sign < 0) == outward:
        faces = [f[::-1] for f in faces]
    return faces


def _box_below_top():
    """The unit box's bottom and sides as triangles (its top left out)."""
    V, F = box_arrays([0, 0, 0], [1, 1, 1])
    top = np.all(np.isclose(V[F][:, :, 2], 1.0), axis=1)
    return [tuple(map(tuple, V[f])) for f in F[~top]]


def _top_with_edge():
    """The top as six triangles, two of them on the edge A-B."""
    p0, p1, p2, p3 = CORNERS
    return [(p0, p1, B), (p0, B, A), (p1, p2, B), (p2, p3, A), (p2, A, B), (p3, p0, A)]


def cavity_touching_at_an_edge():
    """The unit box less the tetrahedron ABCD, whose edge A-B lies in the box's top: four
    faces on A-B (two of the top, two of the cavity), and around A and B one fan each that
    passes the edge twice."""
    return _mesh(_box_below_top() + _top_with_edge() + _tetrahedron(A, B, C, D, False))


def island_in_a_cavity_on_its_edge():
    """`cavity_touching_at_an_edge` with the tetrahedron ABEG inside the cavity, solid again:
    six faces on A-B, of the top, the cavity and the island, nested."""
    V, F = cavity_touching_at_an_edge()
    return joined((V, F), _mesh(_tetrahedron(A, B, E, G)))


def cavity_touching_at_a_vertex():
    """The unit box less a tetrahedron whose corner M is a corner of the top's triangles."""
    m = (1 / 2, 1 / 2, 1.0)
    p0, p1, p2, p3 = CORNERS
    top = [(p0, p1, m), (p1, p2, m), (p2, p3, m), (p3, p0, m)]
    cavity = _tetrahedron(m, C, D, (3 / 4, 1 / 2, 3 / 4), False)
    return _mesh(_box_below_top() + top + cavity)


def wedges_around_an_edge(k: int = 3):
    """``k`` (2 or 3) triangular prisms around the edge x = y = 0, 0 <= z <= 1, apart but for
    that edge: an edge of ``2 k`` faces."""
    rays = [((1, 0), (1, 1)), ((0, 1), (-1, 0)), ((-1, -1), (1, -2))][:k]
    triangles = []
    for r, s in rays:
        o0, o1 = (0, 0, 0.0), (0, 0, 1.0)
        r0, r1, s0, s1 = (*r, 0.0), (*r, 1.0), (*s, 0.0), (*s, 1.0)
        triangles += [(o0, s0, r0), (o1, r1, s1)]  # bottom, top
        triangles += [(o0, r0, r1), (o0, r1, o1)]  # side on r
        triangles += [(o0, o1, s1), (o0, s1, s0)]  # side on s
        triangles += [(r0, s0, s1), (r0, s1, r1)]  # outer side
    return _mesh(triangles)


def boxes_touching_along_a_face():
    """The unit box and a smaller box on its face x = 1, touching along a square of it."""
    return joined(box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([1, 0.25, 0.25], [2, 0.75, 0.75]))


FAMILY = {
    "cavity touching at an edge": cavity_touching_at_an_edge,
    "island in a cavity on its edge": island_in_a_cavity_on_its_edge,
    "cavity touching at a vertex": cavity_touching_at_a_vertex,
    "four faces on an edge": lambda: wedges_around_an_edge(2),
    "six faces on an edge": lambda: wedges_around_an_edge(3),
    "boxes touching along a face": boxes_touching_along_a_face,
}

_CAVITY = Fraction(1, 192)
#: Each solid's volume, exactly.
VOLUMES = {
    "cavity touching at an edge": 1 - _CAVITY,
    "island in a cavity on its edge": 1 - _CAVITY + Fraction(1, 1536),
    "cavity touching at a vertex": 1 - Fraction(1, 192),
    "four faces on an edge": Fraction(1, 2) + Fraction(1, 2),
    "six faces on an edge": Fraction(1, 2) + Fraction(1, 2) + Fraction(3, 2),
    "boxes touching along a face": 1 + Fraction(1, 4),
}


# -- scenes: each solid against objects touching its special places, in many frames ---------

#: Per solid, a line through its special edge or vertex: (point, unit direction); an object's
#: face is placed through it, and moved along it.
SPECIAL_LINES = {
    "cavity touching at an edge": ((1 / 2, 1 / 2, 1.0), (1.0, 0, 0)),
    "island in a cavity on its edge": ((1 / 2, 1 / 2, 1.0), (1.0, 0, 0)),
    "cavity touching at a vertex": ((1 / 2, 1 / 2, 1.0), (1.0, 0, 0)),
    "four faces on an edge": ((0, 0, 1 / 2), (0, 0, 1.0)),
    "six faces on an edge": ((0, 0, 1 / 2), (0, 0, 1.0)),
    "boxes touching along a face": ((1, 1 / 2, 1 / 2), (0, 1.0, 0)),
}


def _box(p, q):
    return box_arrays(np.minimum(p, q), np.maximum(p, q))


def touching_objects(name: str):
    """Boxes whose face holds the solid's special line (through the edge, or along it), and
    a box whose edge lies on it, each as (vertices, faces)."""
    p, d = (np.array(x, float) for x in SPECIAL_LINES[name])
    normal = np.roll(d, 1)  # a coordinate axis across the line
    side = np.roll(d, 2)
    half = 0.25 * (np.abs(normal) + np.abs(side) + np.abs(d))
    through = (p - half * (1 - np.abs(normal)), p + half * (1 - np.abs(normal)) + half * normal)
    along = (p - half * np.abs(d), p + half * (np.abs(d) + np.abs(normal) + np.abs(side)))
    across = (p - half * (np.abs(d) + np.abs(normal) + np.abs(side)), p + half * np.abs(d))
    return [_box(*through), _box(*along), _box(*across)], d


def frames(rng: np.random.Generator):
    """Similarities (scale, rotation (3, 3), shift (3,)) the scenes are moved by: the solid as
    built, a signed permutation (exact), scaled by 1e-3 and by 1e3, and far from the origin."""
    perm = np.eye(3)[rng.permutation(3)] * rng.choice([-1.0, 1.0], 3)
    if np.linalg.det(perm) < 0:
        perm[0] *= -1
    q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    q *= np.sign(np.linalg.det(q))
    yield "as built", 1.0, np.eye(3), np.zeros(3)
    yield "permuted", 1.0, perm, np.array([0.5, -0.25, 2.0])
    yield "scaled by 1e-3", 1e-3, q, rng.uniform(-1, 1, 3) * 1e-3
    yield "scaled by 1e3", 1e3, q, rng.uniform(-1, 1, 3) * 1e3
    yield "far from the origin", 1.0, q, rng.uniform(500, 1000, 3) * rng.choice([-1.0, 1.0], 3)


def random_poses(rng: np.random.Generator, n: int, centre, spread: float) -> np.ndarray:
    """``n`` rigid motions (n, 4, 4) that put an object at the origin near ``centre``."""
    q = np.linalg.qr(rng.normal(size=(n, 3, 3)))[0]
    q *= np.sign(np.linalg.det(q))[:, None, None]
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, :3] = q
    poses[:, :3, 3] = np.asarray(centre) + rng.uniform(-spread, spread, (n, 3))
    return poses


def scenes(rng: np.random.Generator, ball, n_ball: int = 12):
    """The fuzz family: for every solid and frame, objects touching its special line (moved
    along it by dyadic steps: exact contact in exact frames) and ``ball`` (vertices, faces,
    centred at the origin) at ``n_ball`` random poses around the line. Yields (label, solid (V, F),
    object (V, F), poses (k, 4, 4) or None, the solid's volume), all in the frame. A touching
    object comes already moved (poses None): a pose applied in floating point would round
    the contact away differently in the library and in a reference."""
    for name, build in FAMILY.items():
        V, F = build()
        p, _ = SPECIAL_LINES[name]
        objects, direction = touching_objects(name)
        ball_poses = random_poses(rng, n_ball, p, 0.35)
        for frame, s, R, c in frames(rng):
            S = np.eye(4)
            S[:3, :3], S[:3, 3] = s * R, c

            def moved(mesh, shift=0.0, S=S):
                return (mesh[0] + shift) @ S[:3, :3].T + S[:3, 3], mesh[1]

            volume = float(VOLUMES[name]) * s**3
            label = f"{name}, {frame}"
            for i, obj in enumerate(objects):
                for step in (0, 1 / 16, -1 / 8, 3 / 32):
                    shifted = moved(obj, step * direction)
                    yield f"{label}, box {i} + {step}", moved((V, F)), shifted, None, volume
            poses = S @ ball_poses @ np.linalg.inv(S)
            yield f"{label}, ball", moved((V, F)), moved(ball), poses, volume
