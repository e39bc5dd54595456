"""Certified and filtered geometric tests of the exact kernel (numba): segment against
triangle with certified orientation signs, triangle against box (separating axes).

The orientation determinant and its error bound are `exactgrasp.geometry.predicates`'s.
"""

from __future__ import annotations

from exactgrasp.backends.exact.tables import DEGENERATE
from exactgrasp.compiling import inner
from exactgrasp.geometry.predicates import orient

#: Outcomes of `edge_triangle` (and of a face pair, see `pairs.pair`): no crossing, a crossing,
#: and `DEGENERATE` (a sign that no certified bound decides), the pose code of that name, so
#: that a pair's outcome passes up unchanged.
NO, CROSS = 0, 1


@inner(nogil=True, error_model="numpy")
def sign(x):
    """+1 for a positive x, else -1 (for distances already known to be non-zero)."""
    return 1 if x > 0 else -1


@inner(nogil=True, error_model="numpy")
def edge_triangle(
    px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, cx, cy, cz, sp, s1, sq, s2, bound
):
    """Does segment pq cross triangle abc? Returns (code, lambda) with p + lambda (q - p).

    ``sp, s1`` and ``sq, s2`` are the certain sign (or 0) and the determinant of `orient`
    (a, b, c, p) and (a, b, c, q); code is `NO`, `CROSS` or `DEGENERATE`.
    """
    if sp != 0 and sq != 0 and sp == sq:
        return NO, 0.0
    o1, k1 = orient(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, bound)
    o2, k2 = orient(px, py, pz, qx, qy, qz, bx, by, bz, cx, cy, cz, bound)
    o3, k3 = orient(px, py, pz, qx, qy, qz, cx, cy, cz, ax, ay, az, bound)
    pos = (k1 and o1 > 0) or (k2 and o2 > 0) or (k3 and o3 > 0)
    neg = (k1 and o1 < 0) or (k2 and o2 < 0) or (k3 and o3 < 0)
    if pos and neg:
        return NO, 0.0
    if sp == 0 or sq == 0 or not (k1 and k2 and k3):
        return DEGENERATE, 0.0
    return CROSS, s1 / (s1 - s2)


@inner(nogil=True, error_model="numpy")
def _sep(ax, ay, az, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz):
    """Is axis (ax, ay, az) separating a triangle and the box [-h*, h*] (half sizes h*)?"""
    p0 = ax * x0 + ay * y0 + az * z0
    p1 = ax * x1 + ay * y1 + az * z1
    p2 = ax * x2 + ay * y2 + az * z2
    r = hx * abs(ax) + hy * abs(ay) + hz * abs(az)
    return (min(p0, p1, p2) > r) | (max(p0, p1, p2) < -r)


@inner(nogil=True, error_model="numpy")
def _sep2(a, b, p, q, r, s, ha, hb):
    """Is the axis with components (a, b) in two coordinates (0 in the third) separating a
    triangle whose corners project to a p + b q and a r + b s, and a box of half sizes
    ha, hb in those coordinates?"""
    p0 = a * p + b * q
    p1 = a * r + b * s
    rad = ha * abs(a) + hb * abs(b)
    return (min(p0, p1) > rad) | (max(p0, p1) < -rad)


@inner(nogil=True, error_model="numpy")
def tri_box(cx, cy, cz, hh, a, b, c):
    """Separating-axis test: does triangle abc touch the cube of half-size hh at (cx, cy, cz)?"""
    return tri_box_xyz(
        cx, cy, cz, hh, hh, hh, a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]
    )


@inner(nogil=True, error_model="numpy")
def tri_box_xyz(cx, cy, cz, hx, hy, hz, ax, ay, az, bx, by, bz, qx, qy, qz):
    """Does the triangle with corners (ax, ay, az), (bx, by, bz), (qx, qy, qz) touch the box of
    centre (cx, cy, cz) and half sizes hx, hy, hz? Scalars only (no array views in hot loops).
    The cross-product axes and the normal are tested together, with one branch: alone, their
    outcomes are hard to predict."""
    x0, y0, z0 = ax - cx, ay - cy, az - cz
    x1, y1, z1 = bx - cx, by - cy, bz - cz
    x2, y2, z2 = qx - cx, qy - cy, qz - cz
    if min(x0, x1, x2) > hx or max(x0, x1, x2) < -hx:
        return False
    if min(y0, y1, y2) > hy or max(y0, y1, y2) < -hy:
        return False
    if min(z0, z1, z2) > hz or max(z0, z1, z2) < -hz:
        return False
    e0x, e0y, e0z = x1 - x0, y1 - y0, z1 - z0
    e1x, e1y, e1z = x2 - x1, y2 - y1, z2 - z1
    e2x, e2y, e2z = x0 - x2, y0 - y2, z0 - z2
    # Edge k × a coordinate axis: edge k's two ends project to one value, so its start
    # and the opposite corner suffice.
    out = _sep2(-e0z, e0y, y0, z0, y2, z2, hy, hz) | _sep2(e0z, -e0x, x0, z0, x2, z2, hx, hz)
    out |= _sep2(-e0y, e0x, x0, y0, x2, y2, hx, hy) | _sep2(-e1z, e1y, y1, z1, y0, z0, hy, hz)
    out |= _sep2(e1z, -e1x, x1, z1, x0, z0, hx, hz) | _sep2(-e1y, e1x, x1, y1, x0, y0, hx, hy)
    out |= _sep2(-e2z, e2y, y2, z2, y1, z1, hy, hz) | _sep2(e2z, -e2x, x2, z2, x1, z1, hx, hz)
    out |= _sep2(-e2y, e2x, x2, y2, x1, y1, hx, hy)
    nx = e0y * e1z - e0z * e1y
    ny = e0z * e1x - e0x * e1z
    nz = e0x * e1y - e0y * e1x
    return not (out | _sep(nx, ny, nz, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz))
