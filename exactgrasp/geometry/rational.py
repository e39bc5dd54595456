"""Exact rational points and predicates, in Python integers, for the cuts floats cannot decide.

Every float64 coordinate is a dyadic rational, so a mesh's vertices become integers once
scaled by one power of two (`Integers`); an intersection point of segments and planes through
such vertices is rational. A point is kept in homogeneous integer coordinates
``(X, Y, Z, W)`` with ``W > 0`` and no common factor, which makes one point one tuple however
it was constructed (`normalized`): the cut identifies points by value, not by how they were
found. The predicates here are exact signs of polynomials in those integers; the callers in
`exactgrasp.geometry.exact_cut` filter them with floating point first and come here only when
the float sign is within its error bound.

Rounding happens once, at the end (`Integers.to_float`: each coordinate correctly rounded to
the nearest float64). `ExactPoints`, `RoundedPoints` and `FaceTuples` hold a mesh's points and
faces for the cut, converted only where it looks.
"""

from __future__ import annotations

from math import gcd

import numpy as np

__all__ = [
    "ExactPoints",
    "FaceTuples",
    "Integers",
    "RoundedPoints",
    "centroid",
    "incircle",
    "normalized",
    "orient2d",
    "plane_of",
    "point_on",
    "side",
    "triple",
]


class Integers:
    """A mesh's float coordinates as exact integers, scaled by one power of two.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
        Finite coordinates.

    Attributes
    ----------
    exponent : int
        Coordinates in the mesh's units are the integers times ``2 ** exponent``.
    """

    def __init__(self, vertices: np.ndarray) -> None:
        V = np.asarray(vertices, dtype=np.float64)
        mantissa, power = np.frexp(V)
        # mantissa * 2**53 is an integer for every float (subnormals included).
        nonzero = mantissa != 0
        self.exponent = int((power[nonzero] - 53).min()) if nonzero.any() else 0
        self._shift = np.where(nonzero, power - 53 - self.exponent, 0)
        self._digits = (mantissa * 2.0**53).astype(np.int64)

    def __len__(self) -> int:
        return len(self._digits)

    def point(self, k: int) -> tuple:
        """Vertex k as ``(X, Y, Z, 1)``."""
        (a, b, c), (s, t, u) = self._digits[k].tolist(), self._shift[k].tolist()
        return (a << s, b << t, c << u, 1)

    def to_float(self, p: tuple) -> list[float]:
        """The point ``p`` in the mesh's units, each coordinate correctly rounded."""
        X, Y, Z, W = p
        if self.exponent >= 0:
            return [(c << self.exponent) / W for c in (X, Y, Z)]
        # Integer true division rounds correctly, and the value stays in float range.
        den = W << -self.exponent
        return [c / den for c in (X, Y, Z)]


class ExactPoints:
    """Homogeneous integer points: the input's vertices (converted when first used), then the
    cut's."""

    def __init__(self, ints: Integers) -> None:
        self.ints = ints
        self.given: dict[int, tuple] = {}
        self.n = len(ints)
        self.extra: list[tuple] = []

    def __getitem__(self, g: int) -> tuple:
        if g >= self.n:
            return self.extra[g - self.n]
        p = self.given.get(g)
        if p is None:
            p = self.given[g] = self.ints.point(g)
        return p

    def __len__(self) -> int:
        return self.n + len(self.extra)


class RoundedPoints:
    """Each point's coordinates rounded to float64: the input's (as lists, made when first
    used), then the cut's."""

    def __init__(self, V: np.ndarray) -> None:
        self.given = V
        self.made: dict[int, list[float]] = {}
        self.n = len(V)
        self.extra: list[list[float]] = []

    def __getitem__(self, g: int) -> list[float]:
        if g >= self.n:
            return self.extra[g - self.n]
        x = self.made.get(g)
        if x is None:
            x = self.made[g] = self.given[g].tolist()
        return x

    def array(self) -> np.ndarray:
        """All of them, (n, 3)."""
        if not self.extra:
            return self.given
        return np.concatenate([self.given, np.array(self.extra, dtype=np.float64)])


class FaceTuples:
    """Input triangles as tuples of point indices, made when first used."""

    def __init__(self, F: np.ndarray) -> None:
        self.array = F
        self.made: dict[int, tuple[int, int, int]] = {}

    def __getitem__(self, t: int) -> tuple[int, int, int]:
        face = self.made.get(t)
        if face is None:
            face = self.made[t] = tuple(self.array[t].tolist())
        return face


def normalized(X: int, Y: int, Z: int, W: int) -> tuple:
    """The canonical homogeneous tuple of a point: ``W > 0``, no common factor."""
    if W < 0:
        X, Y, Z, W = -X, -Y, -Z, -W
    g = gcd(X, Y, Z, W)
    if g > 1:
        return X // g, Y // g, Z // g, W // g
    return X, Y, Z, W


def point_on(P: tuple, Q: tuple, tn: int, td: int) -> tuple:
    """The point ``P + (tn / td) (Q - P)`` (``td != 0``), normalized."""
    wp, wq = P[3], Q[3]
    a = (td - tn) * wq
    b = tn * wp
    return normalized(a * P[0] + b * Q[0], a * P[1] + b * Q[1], a * P[2] + b * Q[2], td * wp * wq)


def centroid(A: tuple, B: tuple, C: tuple) -> tuple:
    """The centroid of three points, normalized."""
    wa, wb, wc = A[3], B[3], C[3]
    ka, kb, kc = wb * wc, wa * wc, wa * wb
    return normalized(
        ka * A[0] + kb * B[0] + kc * C[0],
        ka * A[1] + kb * B[1] + kc * C[1],
        ka * A[2] + kb * B[2] + kc * C[2],
        3 * wa * wb * wc,
    )


def plane_of(A: tuple, B: tuple, C: tuple) -> tuple:
    """The plane through three points as ``(a, b, c, d)``: a point x is on it where
    ``a x + b y + c z + d == 0``, and ``(a, b, c)`` is the normal ``(B - A) x (C - A)`` up to a
    positive factor. All zero when the points are collinear."""
    (x0, y0, z0, w0), (x1, y1, z1, w1), (x2, y2, z2, w2) = A, B, C
    # Differences scaled by the W's (positive): (B - A) w0 w1 and (C - A) w0 w2.
    ux, uy, uz = x1 * w0 - x0 * w1, y1 * w0 - y0 * w1, z1 * w0 - z0 * w1
    vx, vy, vz = x2 * w0 - x0 * w2, y2 * w0 - y0 * w2, z2 * w0 - z0 * w2
    a = uy * vz - uz * vy
    b = uz * vx - ux * vz
    c = ux * vy - uy * vx
    d = -(a * x0 + b * y0 + c * z0)
    # The normal is scaled by w0^2 w1 w2 > 0 and d by one more w0: divide d out evenly.
    return a * w0, b * w0, c * w0, d


def side(plane: tuple, P: tuple) -> int:
    """``a X + b Y + c Z + d W`` for the point P: its sign is the side of the plane P lies on
    (positive: in front of the normal)."""
    return plane[0] * P[0] + plane[1] * P[1] + plane[2] * P[2] + plane[3] * P[3]


def orient2d(p: tuple, q: tuple, r: tuple, i: int, j: int) -> int:
    """A positive multiple of twice the signed area of (p, q, r) in the coordinates (i, j):
    positive when they turn counter-clockwise."""
    pi_, pj, pw = p[i], p[j], p[3]
    qi, qj, qw = q[i], q[j], q[3]
    ri, rj, rw = r[i], r[j], r[3]
    return pi_ * (qj * rw - qw * rj) - pj * (qi * rw - qw * ri) + pw * (qi * rj - qj * ri)


def incircle(a: tuple, b: tuple, c: tuple, d: tuple, i: int, j: int) -> int:
    """Positive when d lies strictly inside the circle through a, b, c (counter-clockwise in
    the coordinates (i, j)), negative outside, zero on it; scaled by a positive factor."""
    rows = []
    for p in (a, b, c, d):
        x, y, w = p[i], p[j], p[3]
        rows.append((x * w, y * w, x * x + y * y, w * w))
    return _det4(rows)


def triple(p, q, r):
    """``(p × q) · r`` of the first three coordinates (exact for integers and fractions)."""
    return (
        (p[1] * q[2] - p[2] * q[1]) * r[0]
        + (p[2] * q[0] - p[0] * q[2]) * r[1]
        + (p[0] * q[1] - p[1] * q[0]) * r[2]
    )


def _det4(m) -> int:
    """Determinant of a 4 x 4 integer matrix (rows), by 2 x 2 minors of the first two rows."""
    (a0, a1, a2, a3), (b0, b1, b2, b3), (c0, c1, c2, c3), (d0, d1, d2, d3) = m
    s0 = a0 * b1 - a1 * b0
    s1 = a0 * b2 - a2 * b0
    s2 = a0 * b3 - a3 * b0
    s3 = a1 * b2 - a2 * b1
    s4 = a1 * b3 - a3 * b1
    s5 = a2 * b3 - a3 * b2
    c5 = c2 * d3 - c3 * d2
    c4 = c1 * d3 - c3 * d1
    c3_ = c1 * d2 - c2 * d1
    c2_ = c0 * d3 - c3 * d0
    c1_ = c0 * d2 - c2 * d0
    c0_ = c0 * d1 - c1 * d0
    return s0 * c5 - s1 * c4 + s2 * c3_ + s3 * c2_ - s4 * c1_ + s5 * c0_
