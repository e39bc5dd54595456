"""Palms made of several closed shells that meet where floating-point signs cannot decide how:
faces in one plane that overlap, shells touching along an edge or sharing a corner, an edge
passing exactly through another edge, convex pieces of a decomposition sharing their cut
faces, and a piece folded through itself. Coordinates are small dyadic rationals, so these
contacts are exact as built. Each builder returns ``(vertices (n, 3), faces (m, 3))``, outward
shells counter-clockwise seen from outside, not welded unless it says so; `frames` moves a
palm to the scales and places the tests use, and `union_of_boxes` is the exact volume of a
union of axis-aligned boxes (an independent rational reference)."""

from __future__ import annotations

from fractions import Fraction
from itertools import product

import numpy as np
from scipy.spatial import ConvexHull

from tests.messy_meshes import joined

Mesh = tuple[np.ndarray, np.ndarray]


def box(lo, hi, n: int = 1) -> Mesh:
    """The box [lo, hi], outward, every face split into n x n squares of two triangles."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    index: dict[tuple[int, int, int], int] = {}
    faces = []

    def vertex(key) -> int:
        return index.setdefault(tuple(key), len(index))

    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side, flip in ((0, True), (n, False)):
            for a, b in product(range(n), range(n)):
                quad = []
                for da, db in ((0, 0), (1, 0), (1, 1), (0, 1)):
                    key = [0, 0, 0]
                    key[axis], key[u], key[v] = side, a + da, b + db
                    quad.append(vertex(key))
                if flip:
                    quad = quad[::-1]
                faces += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    steps = np.array(list(index), float) / n
    return lo + steps * (hi - lo), np.array(faces, np.int64)


def convex(points) -> Mesh:
    """The convex hull of ``points`` (in general position on its faces), outward."""
    P = np.asarray(points, float)
    hull = ConvexHull(P)
    F = hull.simplices.copy()
    centre = P[hull.vertices].mean(0)
    for k, f in enumerate(F):
        a, b, c = P[f]
        if np.dot(np.cross(b - a, c - a), a - centre) < 0:
            F[k] = f[::-1]
    used, inverse = np.unique(F, return_inverse=True)
    return P[used], inverse.reshape(-1, 3)


def prism(base, z0: float, z1: float) -> Mesh:
    """The prism over the triangle ``base`` ((3, 2) points in the xy plane) from z0 to z1."""
    base = np.asarray(base, float)
    return convex(np.concatenate([np.c_[base, np.full(3, z0)], np.c_[base, np.full(3, z1)]]))


def reversed_mesh(mesh: Mesh) -> Mesh:
    """The same shell facing inward (a cavity)."""
    return mesh[0], mesh[1][:, ::-1].copy()


def folded(lo, hi) -> Mesh:
    """The box [lo, hi] with its corner at hi pushed through the opposite face x = lo[0], to
    the centre of that face's diagonal line out beyond it: a shell crossing itself exactly
    through edges."""
    V, F = box(lo, hi)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    corner = np.flatnonzero(np.all(V == hi, axis=1))[0]
    V = V.copy()
    V[corner] = [lo[0] - (hi[0] - lo[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2]
    return V, F


# -- the palms ---------------------------------------------------------------------------------


#: Boxes ``(lo, hi, n)`` of the palms made of boxes only.
BOXES = {
    # Three plates of one thickness overlapping in pairs: their top and bottom faces lie in the
    # planes z = 0 and z = 1/4 and overlap in patches (side faces shared in part).
    "coplanar plates": [
        ([0, 0, 0], [1, 3 / 4, 1 / 4], 2),
        ([1 / 2, 1 / 4, 0], [3 / 2, 1, 1 / 4], 1),
        ([1, 0, 0], [7 / 4, 1 / 2, 1 / 4], 2),
    ],
    # A palm plate, a finger base on its edge (touching along a whole edge) and a knuckle
    # touching the finger base along part of an edge.
    "touching at edges": [
        ([0, 0, 0], [1, 1, 1 / 4], 1),
        ([1, 0, 1 / 4], [3 / 2, 1, 1 / 2], 1),
        ([3 / 2, 1 / 4, 1 / 2], [2, 3 / 4, 3 / 4], 1),
    ],
    # Two plates sharing a whole face (coincident triangles) and a third crossing both.
    "stacked plates": [
        ([0, 0, 0], [1, 1, 1 / 4], 1),
        ([0, 0, 1 / 4], [1, 1, 1 / 2], 1),
        ([1 / 4, 1 / 4, 1 / 8], [3 / 4, 3 / 2, 3 / 8], 1),
    ],
}


def boxes(name: str, weld: bool = False) -> Mesh:
    """The palm ``name`` of `BOXES`, its shells welded (equal corners merged, as a mesh file
    stores them) or not."""
    return joined(*(box(lo, hi, n) for lo, hi, n in BOXES[name]), weld=weld)


def sharing_corners() -> Mesh:
    """Pieces meeting at a corner (welded), a corner on a face and a wedge whose edge lies in a
    face: shells that share vertices or touch at one point."""
    return joined(
        box([0, 0, 0], [1, 1, 1 / 2]),
        box([1, 1, 1 / 2], [3 / 2, 3 / 2, 1]),
        convex([[1 / 4, 1 / 4, 1 / 2], [3 / 4, 1 / 4, 1], [1 / 4, 3 / 4, 1], [3 / 4, 3 / 4, 1]]),
        prism([[1 / 4, -1 / 2], [3 / 4, -1 / 2], [1 / 2, 0]], 1 / 8, 3 / 8),
    )


def edge_through_edge() -> Mesh:
    """A palm box, a tetrahedron whose edge crosses the box's top edge exactly at its midpoint
    (the two overlap beyond it), and one whose edge passes exactly through the box's corner,
    touching it there only."""
    a = box([0, 0, 0], [1, 1, 1])
    p, q = [1 / 2, 1 / 2, 3 / 2], [3 / 2, 1 / 2, 1 / 2]
    overlapping = convex([p, q, [3 / 4, 3 / 2, 3 / 4], [3 / 4, -1 / 2, 3 / 4]])
    touching = convex(
        [[1 / 2, 1, 3 / 2], [3 / 2, 1, 1 / 2], [7 / 4, 3 / 2, 7 / 4], [7 / 4, 2, 5 / 4]]
    )
    return joined(a, overlapping, touching, weld=False)


def convex_pieces() -> Mesh:
    """A convex decomposition of a palm (welded): a slab cut by the plane x + y = 3/2 into two
    prisms that share part of the cut face, a thumb piece overlapping both with faces in the
    slab's planes and a corner on the cut, and a finger pad standing on the slab's top."""
    slab0 = prism([[0, 0], [3 / 2, 0], [0, 3 / 2]], 0, 1 / 4)
    slab1 = convex(
        [[x, y, z] for x, y in ((3 / 2, 0), (2, 0), (2, 1), (1 / 2, 1)) for z in (0, 1 / 4)]
    )
    thumb = convex(
        [[x, y, z] for x, y in ((1 / 4, 1 / 4), (1, 1 / 2), (1 / 2, 5 / 4)) for z in (0, 1 / 4)]
    )
    pad = box([1, 1 / 2, 1 / 4], [3 / 2, 1, 1 / 2])
    return joined(slab0, slab1, thumb, pad)


def folded_and_plate() -> Mesh:
    """A plate, and a piece folded through itself that overlaps the plate in the plane of
    its face: shells that cross one another and themselves, with a patch of one on the
    other."""
    return joined(box([0, 0, 0], [1, 1, 1]), folded([0, 0, 0], [1, 1, 1 / 2]), weld=False)


def plate_with_pocket() -> Mesh:
    """A plate with a reversed box (a pocket) sharing its top face's plane and a side face's
    plane, and an outward box filling half of the pocket from above."""
    return joined(
        box([0, 0, 0], [2, 1, 1 / 2]),
        reversed_mesh(box([1 / 4, 0, 1 / 4], [1, 1 / 2, 1 / 2])),
        box([1 / 2, 0, 1 / 4], [1, 1 / 2, 3 / 4]),
        weld=False,
    )


PALMS = {
    "coplanar plates": lambda: boxes("coplanar plates"),
    "coplanar plates, welded": lambda: boxes("coplanar plates", weld=True),
    "touching at edges": lambda: boxes("touching at edges"),
    "touching at edges, welded": lambda: boxes("touching at edges", weld=True),
    "stacked plates, welded": lambda: boxes("stacked plates", weld=True),
    "sharing corners": sharing_corners,
    "edge through edge": edge_through_edge,
    "convex pieces": convex_pieces,
    "folded and plate": folded_and_plate,
    "plate with a pocket": plate_with_pocket,
}


def union_of_boxes(boxes) -> Fraction:
    """The exact volume of a union of axis-aligned boxes ``[(lo, hi), ...]`` with float
    (dyadic) corners, by coordinate compression."""
    cuts = [sorted({Fraction(b[k][a]) for b in boxes for k in (0, 1)}) for a in range(3)]
    total = Fraction(0)
    for i, j, k in product(*(range(len(c) - 1) for c in cuts)):
        lo = (cuts[0][i], cuts[1][j], cuts[2][k])
        hi = (cuts[0][i + 1], cuts[1][j + 1], cuts[2][k + 1])
        mid = [(a + b) / 2 for a, b in zip(lo, hi, strict=True)]
        if any(
            all(Fraction(b[0][a]) <= mid[a] <= Fraction(b[1][a]) for a in range(3)) for b in boxes
        ):
            total += (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2])
    return total


def frames():
    """Similarities the palms are moved by: ``(label, scale, rotation (3, 3), shift (3,),
    tolerance)``: as built (exact contacts), scaled by 1e-3 and by 1e3, and far from the
    origin (coordinates rounded by the move)."""
    yield "as built", 1.0, np.eye(3), np.zeros(3), 1e-12
    yield "scaled by 1e-3", 1e-3, np.eye(3), np.array([0.25, -0.5, 0.125]) * 1e-3, 1e-9
    yield "scaled by 1e3", 1e3, np.eye(3), np.array([-250.0, 500.0, 125.0]), 1e-9
    yield "far from the origin", 1.0, np.eye(3), np.array([700.3, -650.7, 811.1]), 1e-9
