"""A closed surface cut along every contact with itself, in exact rational arithmetic.

`cut_exactly` subdivides the triangles of a mesh so that any two of the result meet only at
common corners or along common edges, or are the same three points: it computes the mesh's
arrangement, degenerate contacts included (coplanar triangles that overlap, an edge through an
edge or a corner, a corner on a face, triangles folded onto a neighbour), which floating-point
signs cannot decide.

1. **Pairs.** `exactgrasp.geometry.crossings.find_contacts` lists every pair of triangles that
   may meet beyond the corners they share (float signs with a static error bound: a pair left
   out certainly does not).
2. **Contacts, exactly.** Coordinates become integers (`exactgrasp.geometry.rational`). Two
   triangles in different planes meet in a segment, a point or nothing: where each one's edges
   pierce the other's plane, overlapped along the planes' common line. Two in one plane add
   each one's edges, clipped to the other, to the other. Every point is a normalized
   homogeneous integer tuple, so a point found twice is one vertex.
3. **Every point where it lies.** Segments crossing inside a triangle add their crossing
   point; each point is then added to every triangle and edge it lies on, so that a segment
   common to two triangles is split at the same points in both.
4. **Tiling.** Each triangle with points or segments is tiled by its constrained Delaunay
   triangulation (`exactgrasp.geometry.exact_tiles`), which two coplanar triangles share on
   their overlap. A zero-area triangle is fanned over the points on its edges.

The cut points stay exact throughout; `exactgrasp.geometry.exact_solid` rounds them once, at
the end.
"""

from __future__ import annotations

from collections import defaultdict
from fractions import Fraction

import numpy as np

from exactgrasp.geometry.crossings import find_contacts
from exactgrasp.geometry.exact_tiles import tile_face
from exactgrasp.geometry.rational import (
    ExactPoints,
    FaceTuples,
    Integers,
    RoundedPoints,
    orient2d,
    plane_of,
    point_on,
    side,
)

__all__ = ["Arrangement", "cut_exactly"]

_AXES = ((1, 2), (2, 0), (0, 1))
# Float filters of exact signs: the points' float coordinates are within half an ulp.
_ORIENT_BOUND = 1e-14
_SIDE_BOUND = 1e-13
_TINY = 1e-150


class Arrangement:
    """The cut: exact points, and what each triangle holds.

    Attributes
    ----------
    ints : Integers
        The input's coordinates as integers.
    points : sequence of tuple
        Homogeneous integer points: the input's vertices first, then the cut's.
    approx : sequence of list of float
        Each point rounded to float64, in the input's units (a `RoundedPoints`).
    faces : sequence of (int, int, int)
        Input triangles (indices into ``points``).
    """

    def __init__(self, V: np.ndarray, F: np.ndarray, involved: np.ndarray) -> None:
        self.ints = Integers(V)
        self.points = ExactPoints(self.ints)
        self.approx = RoundedPoints(np.asarray(V, dtype=np.float64))
        # Every point the cut makes lies on a face in contact, so one equal to an input
        # vertex is a corner of such a face: those corners are enough to find it.
        self.index = {self.points[k]: k for k in involved.tolist()}
        self.faces = FaceTuples(np.asarray(F, dtype=np.int64))
        self.boxes: dict[int, tuple] = {}
        self.planes: dict[int, tuple] = {}
        self.views: dict[int, tuple[int, int, int]] = {}
        self.segments: dict[int, set] = defaultdict(set)
        self.found: dict[int, set] = defaultdict(set)
        self.partners: dict[int, set] = defaultdict(set)
        self.inside: dict[int, set] = defaultdict(set)
        self.on_edge: dict[tuple[int, int], set] = defaultdict(set)

    # -- points and signs -----------------------------------------------------------------

    def point(self, p: tuple) -> int:
        """The index of the (normalized) point p, added if new."""
        k = self.index.get(p)
        if k is None:
            k = len(self.points)
            self.points.extra.append(p)
            self.approx.extra.append(self.ints.to_float(p))
            self.index[p] = k
        return k

    def box(self, t: int) -> tuple[list[float], list[float]]:
        """Triangle t's bounding box, padded by the rounding of the points placed on it."""
        box = self.boxes.get(t)
        if box is None:
            corners = [self.approx[v] for v in self.faces[t]]
            lo = [min(c[k] for c in corners) for k in range(3)]
            hi = [max(c[k] for c in corners) for k in range(3)]
            pad = 4e-16 * max(map(abs, lo + hi))
            box = self.boxes[t] = ([v - pad for v in lo], [v + pad for v in hi])
        return box

    def plane(self, t: int) -> tuple:
        """Triangle t's plane (`exactgrasp.geometry.rational.plane_of`)."""
        pl = self.planes.get(t)
        if pl is None:
            a, b, c = self.faces[t]
            pl = self.planes[t] = plane_of(self.points[a], self.points[b], self.points[c])
        return pl

    def view(self, t: int) -> tuple[int, int, int]:
        """Coordinates (i, j) that keep triangle t flat, and +1 (-1) when it turns
        counter-clockwise (clockwise) in them."""
        seen = self.views.get(t)
        if seen is None:
            pl = self.plane(t)
            k = max(range(3), key=lambda a: abs(pl[a]))
            seen = self.views[t] = (*_AXES[k], 1 if pl[k] > 0 else -1)
        return seen

    def orient(self, p: int, q: int, r: int, i: int, j: int) -> int:
        """Exact sign of the turn p -> q -> r in the coordinates (i, j)."""
        A, B, C = self.approx[p], self.approx[q], self.approx[r]
        m = max(abs(A[i]), abs(A[j]), abs(B[i]), abs(B[j]), abs(C[i]), abs(C[j]))
        det = (B[i] - A[i]) * (C[j] - A[j]) - (B[j] - A[j]) * (C[i] - A[i])
        if m > _TINY and abs(det) > _ORIENT_BOUND * m * m:
            return 1 if det > 0 else -1
        value = orient2d(self.points[p], self.points[q], self.points[r], i, j)
        return (value > 0) - (value < 0)

    def side_of(self, t: int, g: int) -> int:
        """Exact sign of point g's side of triangle t's plane."""
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = (self.approx[v] for v in self.faces[t])
        x, y, z = self.approx[g]
        ux, uy, uz, vx, vy, vz = bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az
        value = (
            (uy * vz - uz * vy) * (x - ax)
            + (uz * vx - ux * vz) * (y - ay)
            + (ux * vy - uy * vx) * (z - az)
        )
        m = max(abs(ax), abs(ay), abs(az), abs(bx), abs(by), abs(bz))
        m = max(m, abs(cx), abs(cy), abs(cz), abs(x), abs(y), abs(z))
        if m > _TINY and abs(value) > _SIDE_BOUND * m**3:
            return 1 if value > 0 else -1
        s = side(self.plane(t), self.points[g])
        return (s > 0) - (s < 0)

    def along(self, a: int, b: int, axes=(0, 1, 2)) -> int:
        """An axis among ``axes`` along which points a and b differ: the one where their
        rounded coordinates differ most (rounding keeps order, so a difference there is a
        difference), else the one where they differ most exactly."""
        A, B = self.approx[a], self.approx[b]
        k = max(axes, key=lambda k: abs(B[k] - A[k]))
        if B[k] != A[k]:
            return k
        return max(axes, key=lambda k: abs(self.coordinate(b, k) - self.coordinate(a, k)))

    def sort_along(self, points, a: int, b: int, axes=(0, 1, 2)) -> list[int]:
        """``points`` (on the line through a and b) in order from a towards b, exactly:
        by their rounded coordinates, or exact ones where two round alike."""
        axis = self.along(a, b, axes)
        rising = self.approx[b][axis] > self.approx[a][axis] or (
            self.approx[b][axis] == self.approx[a][axis]
            and self.coordinate(b, axis) > self.coordinate(a, axis)
        )
        points = list(points)
        rounded = [self.approx[g][axis] for g in points]
        if len(set(rounded)) == len(rounded):
            return [g for _, g in sorted(zip(rounded, points, strict=True), reverse=not rising)]
        return sorted(points, key=lambda g: self.coordinate(g, axis), reverse=not rising)

    def coordinate(self, g: int, axis: int) -> Fraction:
        """Point g's coordinate ``axis``, exactly (in integer units)."""
        return Fraction(self.points[g][axis], self.points[g][3])

    def where(self, g: int, t: int):
        """Where point g lies on triangle t (closed): None (not on it), ``("in",)``,
        ``("edge", a, b)`` (on the edge a-b, a < b) or ``("corner",)``."""
        face = self.faces[t]
        if g in face:
            return ("corner",)
        x, (lo, hi) = self.approx[g], self.box(t)
        if any(x[k] < lo[k] or x[k] > hi[k] for k in range(3)):
            return None
        if not any(self.plane(t)[:3]) or self.side_of(t, g) != 0:
            return None
        i, j, turn = self.view(t)
        sides = [turn * self.orient(face[k], face[(k + 1) % 3], g, i, j) for k in range(3)]
        if min(sides) < 0:
            return None
        if 0 not in sides:
            return ("in",)
        k = sides.index(0)
        a, b = face[k], face[(k + 1) % 3]
        return ("edge", min(a, b), max(a, b))

    # -- step 2: pairs ----------------------------------------------------------------------

    def meet(self, t: int, u: int) -> None:
        """Record what triangles t and u have in common."""
        pt, pu = self.plane(t), self.plane(u)
        if not any(pt[:3]) or not any(pu[:3]):
            return  # zero area: it cuts nothing (its edges are its neighbours')
        self.partners[t].add(u)
        self.partners[u].add(t)
        P = self.points
        su = [side(pt, P[g]) for g in self.faces[u]]
        if not any(su):
            self._coplanar(t, u)
            self._coplanar(u, t)
            return
        st = [side(pu, P[g]) for g in self.faces[t]]
        on_u = self._plane_cut(self.faces[u], su)
        on_t = self._plane_cut(self.faces[t], st) if on_u else []
        if not on_t:
            return
        line = (
            pt[1] * pu[2] - pt[2] * pu[1],
            pt[2] * pu[0] - pt[0] * pu[2],
            pt[0] * pu[1] - pt[1] * pu[0],
        )
        axis = max(range(3), key=lambda a: abs(line[a]))

        def key(g: int) -> Fraction:
            return self.coordinate(g, axis)

        lo = max(min(on_u, key=key), min(on_t, key=key), key=key)
        hi = min(max(on_u, key=key), max(on_t, key=key), key=key)
        if key(lo) > key(hi):
            return
        self._add(t, lo, hi)
        self._add(u, lo, hi)

    def _add(self, t: int, a: int, b: int) -> None:
        self.found[t] |= {a, b}
        if a != b:
            self.segments[t].add((min(a, b), max(a, b)))

    def _plane_cut(self, face, sides) -> list[int]:
        """Where a triangle (corner indices, their sides of a plane) meets the plane."""
        P = self.points
        out = [g for g, s in zip(face, sides, strict=True) if s == 0]
        for k in range(3):
            sa, sb = sides[k], sides[(k + 1) % 3]
            if sa * sb < 0:
                A, B = P[face[k]], P[face[(k + 1) % 3]]
                out.append(self.point(point_on(A, B, sa, sa - sb)))
        return list(dict.fromkeys(out))

    def _coplanar(self, t: int, u: int) -> None:
        """Add u's edges, clipped to triangle t of the same plane, to t."""
        face = self.faces[t]
        i, j, turn = self.view(t)
        P = self.points
        for k in range(3):
            p, q = self.faces[u][k], self.faces[u][(k + 1) % 3]
            lo, hi = Fraction(0), Fraction(1)
            for e in range(3):
                c0, c1 = P[face[e]], P[face[(e + 1) % 3]]
                fp = turn * orient2d(c0, c1, P[p], i, j)
                fq = turn * orient2d(c0, c1, P[q], i, j)
                if fp < 0 and fq < 0:
                    break
                if fp < 0:
                    lo = max(lo, Fraction(fp, fp - fq))
                elif fq < 0:
                    hi = min(hi, Fraction(fp, fp - fq))
            else:
                if lo <= hi:
                    a = self._at(p, q, lo)
                    self._add(t, a, self._at(p, q, hi))

    def _at(self, p: int, q: int, lam: Fraction) -> int:
        if lam == 0:
            return p
        if lam == 1:
            return q
        return self.point(point_on(self.points[p], self.points[q], lam.numerator, lam.denominator))

    # -- step 3: crossings, and every point where it lies ----------------------------------

    def cross_segments(self, t: int) -> None:
        """Add the points where two of t's segments cross inside both."""
        segs = sorted(self.segments[t])
        if len(segs) < 2:
            return
        i, j, _ = self.view(t)
        A = self.approx
        ends = np.array([[[A[p][i], A[p][j]], [A[q][i], A[q][j]]] for p, q in segs])
        lo, hi = ends.min(1), ends.max(1)
        pad = 4e-16 * np.abs(ends).max() + 1e-300
        for a in range(len(segs)):
            p1, q1 = segs[a]
            near = np.flatnonzero(
                np.all(lo[a + 1 :] <= hi[a] + pad, axis=1)
                & np.all(hi[a + 1 :] >= lo[a] - pad, axis=1)
            )
            for b in near + a + 1:
                p2, q2 = segs[b]
                if len({p1, q1, p2, q2}) < 4:
                    continue
                if self.orient(p2, q2, p1, i, j) * self.orient(p2, q2, q1, i, j) >= 0:
                    continue
                if self.orient(p1, q1, p2, i, j) * self.orient(p1, q1, q2, i, j) >= 0:
                    continue
                P = self.points
                o1 = orient2d(P[p2], P[q2], P[p1], i, j) * P[q1][3]
                o2 = orient2d(P[p2], P[q2], P[q1], i, j) * P[p1][3]
                self.found[t].add(self.point(point_on(P[p1], P[q1], o1, o1 - o2)))

    def place(self, g: int, t: int) -> bool:
        """Add point g to triangle t (or the edge of t it lies on) if it lies on t."""
        spot = self.where(g, t)
        if spot is None:
            return False
        if spot[0] == "in":
            self.inside[t].add(g)
        elif spot[0] == "edge":
            self.on_edge[spot[1:]].add(g)
        return True


def cut_exactly(vertices: np.ndarray, faces: np.ndarray):
    """The arrangement of a closed surface: its triangles cut along every contact, exactly.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
        Distinct points (welded: equal coordinates are one vertex).
    faces : numpy.ndarray, shape (m, 3), int64
        A closed surface, or the part of one that is cut (`exact_window`).

    Returns
    -------
    arrangement : Arrangement
        The exact points (input vertices first).
    tiles : list of (int, int, int, int)
        ``(a, b, c, f)``: a triangle of the cut, as point indices oriented as input face f,
        for every face f in contact with another (which may be its own only tile).
    tiled : numpy.ndarray, shape (m,), bool
        The faces given as tiles; the others meet no other face but at corners and edges
        they share, and are kept as they are.
    n_cut : int
        Faces that were split.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    t, u = find_contacts(V, F, np.arange(len(V)))
    in_contact = np.unique(np.concatenate([t, u]))
    cut = Arrangement(V, F, np.unique(F[in_contact]))
    for a, b in zip(t.tolist(), u.tolist(), strict=True):
        cut.meet(a, b)
    for f in list(cut.segments):
        cut.cross_segments(f)
    for f in list(cut.found):
        for g in cut.found[f]:
            for h in (f, *cut.partners[f]):
                if g not in cut.faces[h]:
                    cut.place(g, h)
    # Faces to tile: those in contact, and those with a point on one of their edges.
    candidates = set(in_contact.tolist())
    if cut.on_edge:
        n = np.int64(len(V))
        lo, hi = np.minimum(F, np.roll(F, -1, 1)), np.maximum(F, np.roll(F, -1, 1))
        keys = np.array([a * n + b for a, b in cut.on_edge], np.int64)
        candidates |= set(np.flatnonzero(np.isin(lo * n + hi, keys).any(1)).tolist())
    tiles: list[tuple[int, int, int, int]] = []
    tiled = np.zeros(len(F), bool)
    n_cut = 0
    for f in sorted(candidates):
        split = tile_face(cut, f)
        if split is None:
            # Uncut, but it may coincide with a tile of a face it lies in: merged with it.
            split = [cut.faces[f]]
        tiled[f] = True
        n_cut += len(split) > 1
        tiles += [(*tri, f) for tri in split]
    return cut, tiles, tiled, n_cut
