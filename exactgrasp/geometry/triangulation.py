"""Exact constrained Delaunay triangulation of points and segments inside one triangle.

`constrained_delaunay` tiles a triangle, given with the points that lie in it and the segments
between them that must be edges, without adding a point. Points are inserted one by one
(split the triangle or the edge they fall in), each segment is recovered by flipping the edges
that cross it (Sloan's method), and the edges that are not segments are flipped until every
one is locally Delaunay. Signs come from float64 with a static error bound, else from exact
integers (`exactgrasp.geometry.rational`).

The result does not depend on what lies outside a region enclosed by segments: the
constrained Delaunay triangulation is unique once ties (four points on one circle, common in
the rectangles where boxes overlap) are broken by a symbolic perturbation of the lifted points
ordered by their global rank. So two coplanar triangles of a mesh that overlap tile their
common part with the same triangles, which the cut needs to match them face for face.
"""

from __future__ import annotations

from collections import deque

from exactgrasp.geometry.rational import incircle, orient2d

__all__ = ["constrained_delaunay"]

# Float error bounds for points given to about half an ulp per coordinate, relative to the
# largest coordinate magnitude M: orient2d within 4.8e-15 M^2, incircle within 3e-13 M^4.
_ORIENT_BOUND = 1e-14
_INCIRCLE_BOUND = 1e-11
_TINY = 1e-150


class _Tiling:
    """Triangles (counter-clockwise in the coordinates (i, j)) with directed-edge lookup."""

    def __init__(self, points, approx, rank, i, j) -> None:
        self.points = points
        self.approx = approx
        self.rank = rank
        self.i, self.j = i, j
        self.tris: dict[int, tuple[int, int, int]] = {}
        self.edge: dict[tuple[int, int], int] = {}
        self.fixed: set[tuple[int, int]] = set()
        self.next = 0

    # -- predicates ----------------------------------------------------------------------

    def orient(self, p: int, q: int, r: int) -> int:
        """Sign of the turn p -> q -> r (+1 counter-clockwise)."""
        (px, py), (qx, qy), (rx, ry) = self.approx[p], self.approx[q], self.approx[r]
        m = max(abs(px), abs(py), abs(qx), abs(qy), abs(rx), abs(ry))
        det = (qx - px) * (ry - py) - (qy - py) * (rx - px)
        if m > _TINY and abs(det) > _ORIENT_BOUND * m * m:
            return 1 if det > 0 else -1
        P = self.points
        value = orient2d(P[p], P[q], P[r], self.i, self.j)
        return (value > 0) - (value < 0)

    def inside_circle(self, a: int, b: int, c: int, d: int) -> bool:
        """Whether d lies inside the circle through the counter-clockwise a, b, c, ties broken
        by lifting each point by a perturbation that shrinks with its rank."""
        quad = (a, b, c, d)
        (dx, dy) = self.approx[d]
        rows = []
        m = 0.0
        for p in quad[:3]:
            x, y = self.approx[p][0] - dx, self.approx[p][1] - dy
            rows.append((x, y, x * x + y * y))
            m = max(m, abs(self.approx[p][0]), abs(self.approx[p][1]))
        m = max(m, abs(dx), abs(dy))
        (ax, ay, al), (bx, by, bl), (cx, cy, cl) = rows
        det = al * (bx * cy - by * cx) - bl * (ax * cy - ay * cx) + cl * (ax * by - ay * bx)
        if m > _TINY and abs(det) > _INCIRCLE_BOUND * m**4:
            return det > 0
        P = self.points
        value = incircle(P[a], P[b], P[c], P[d], self.i, self.j)
        if value:
            return value > 0
        # Four points on one circle: the lowest-ranked point's lift decides.
        k = min(range(4), key=lambda n: self.rank[quad[n]])
        others = [quad[n] for n in range(4) if n != k]
        turn = self.orient(*others)
        return (turn if k % 2 == 0 else -turn) > 0

    # -- editing -------------------------------------------------------------------------

    def add(self, a: int, b: int, c: int) -> None:
        t = self.next
        self.next += 1
        self.tris[t] = (a, b, c)
        self.edge[(a, b)] = t
        self.edge[(b, c)] = t
        self.edge[(c, a)] = t

    def remove(self, t: int) -> tuple[int, int, int]:
        a, b, c = self.tris.pop(t)
        for e in ((a, b), (b, c), (c, a)):
            if self.edge.get(e) == t:
                del self.edge[e]
        return a, b, c

    def apex(self, u: int, v: int) -> int:
        """The corner opposite the directed edge u -> v."""
        a, b, c = self.tris[self.edge[(u, v)]]
        return c if (a, b) == (u, v) else (a if (b, c) == (u, v) else b)

    def flip(self, u: int, v: int) -> tuple[int, int]:
        """Replace the edge u-v by the other diagonal of its two triangles; returns it."""
        x, y = self.apex(u, v), self.apex(v, u)
        self.remove(self.edge[(u, v)])
        self.remove(self.edge[(v, u)])
        self.add(x, u, y)
        self.add(y, v, x)
        return x, y

    def insert(self, p: int) -> None:
        """Split the triangle (or the edge) that point p falls in."""
        for t, (a, b, c) in self.tris.items():
            sides = (self.orient(a, b, p), self.orient(b, c, p), self.orient(c, a, p))
            if min(sides) < 0:
                continue
            if 0 not in sides:
                self.remove(t)
                self.add(a, b, p)
                self.add(b, c, p)
                self.add(c, a, p)
                return
            k = sides.index(0)
            u, v = ((a, b), (b, c), (c, a))[k]
            self._split_edge(u, v, p)
            return
        raise ValueError("a point lies outside the triangle it was given with")

    def _split_edge(self, u: int, v: int, p: int) -> None:
        w = self.apex(u, v)
        other = self.edge.get((v, u))
        self.remove(self.edge[(u, v)])
        self.add(u, p, w)
        self.add(p, v, w)
        if other is not None:
            z = self.apex(v, u)
            self.remove(other)
            self.add(v, p, z)
            self.add(p, u, z)

    # -- segments and Delaunay flips -----------------------------------------------------

    def crosses(self, a: int, b: int, x: int, y: int) -> bool:
        """Whether segments a-b and x-y cross at a point inside both."""
        if len({a, b, x, y}) < 4:
            return False
        return (
            self.orient(a, b, x) * self.orient(a, b, y) < 0
            and self.orient(x, y, a) * self.orient(x, y, b) < 0
        )

    def recover(self, a: int, b: int) -> None:
        """Make a-b an edge by flipping the edges that cross it, and keep it."""
        self.fixed |= {(a, b), (b, a)}
        if (a, b) in self.edge or (b, a) in self.edge:
            return
        crossing = deque()
        for t in list(self.tris):
            tri = self.tris[t]
            if a not in tri:
                continue
            k = tri.index(a)
            u, v = tri[(k + 1) % 3], tri[(k + 2) % 3]
            if self.orient(a, u, b) > 0 and self.orient(a, v, b) < 0:
                break
        else:
            raise ValueError("a segment leaves the triangle it was given with")
        while True:  # walk along a -> b; u stays on its right, v on its left
            crossing.append((u, v))
            w = self.apex(v, u)
            if w == b:
                break
            if self.orient(a, b, w) < 0:
                u = w
            else:
                v = w
        while crossing:
            u, v = crossing.popleft()
            x, y = self.apex(u, v), self.apex(v, u)
            if self.orient(x, y, u) * self.orient(x, y, v) < 0:
                x, y = self.flip(u, v)
                if self.crosses(a, b, x, y):
                    crossing.append((x, y))
            else:
                crossing.append((u, v))

    def make_delaunay(self) -> None:
        """Flip every edge that is not kept and not locally Delaunay (Lawson)."""
        stack = [e for e in self.edge if e[0] < e[1]]
        while stack:
            u, v = stack.pop()
            if (u, v) in self.fixed or (u, v) not in self.edge or (v, u) not in self.edge:
                continue
            x, y = self.apex(u, v), self.apex(v, u)
            if self.inside_circle(u, v, x, y):
                self.flip(u, v)
                stack += [(x, u), (u, y), (y, v), (v, x)]


def constrained_delaunay(points, approx, rank, segments, i: int, j: int):
    """Triangles tiling a triangle, with the given points as corners and segments as edges.

    Parameters
    ----------
    points : list of tuple
        Homogeneous integer points (`exactgrasp.geometry.rational`), all in one plane; the
        first three are the triangle's corners, counter-clockwise in the coordinates (i, j),
        and every other lies in it (closed).
    approx : list of (float, float)
        Each point's coordinates (i, j), rounded, for the float filter.
    rank : list of int
        Distinct ranks that break ties alike wherever the same points meet.
    segments : iterable of (int, int)
        Pairs of indices into ``points`` that must be edges: they cross no other segment and
        hold no other point.
    i, j : int
        The two coordinates (0, 1 or 2) the triangle is seen in.

    Returns
    -------
    list of (int, int, int)
        Counter-clockwise triangles, as indices into ``points``.
    """
    tiling = _Tiling(points, approx, rank, i, j)
    tiling.add(0, 1, 2)
    for p in range(3, len(points)):
        tiling.insert(p)
    for a, b in segments:
        tiling.recover(a, b)
    tiling.make_delaunay()
    return list(tiling.tris.values())
