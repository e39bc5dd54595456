"""Filtered orientation predicates (numba), for the exact backend's kernels.

`orient` is the determinant of Shewchuk's orientation test evaluated in one fixed order, with
the static error bound `orient_bound`: a sign whose magnitude exceeds the bound is certain.
The compiled (Cython) kernels have their own inline twin with the same arithmetic,
``_predicates.pxd``; this module goes when the exact backend's kernels are compiled too.
"""

from __future__ import annotations

from exactgrasp.compiling import inner, kernel

# Shewchuk's bound on the rounding error of this evaluation order of the determinant is
# (7 + 56 eps) eps ~ 7.8e-16 times its permanent, and the permanent is at most 6 L^3 when every
# coordinate difference is at most L: 4.7e-15 L^3, taken with a margin of two.
ORIENT_ERR = 1e-14


@kernel(nogil=True, error_model="numpy")
def orient_bound(extent):
    """Error bound of `orient` for points whose coordinates span at most `extent`."""
    return ORIENT_ERR * extent * extent * extent


@inner(nogil=True, error_model="numpy")
def orient_det(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz):
    """Six times the signed volume of tetrahedron abcd (sign > 0: d below abc's plane).

    `orient` evaluates it too.
    """
    adx = ax - dx
    ady = ay - dy
    adz = az - dz
    bdx = bx - dx
    bdy = by - dy
    bdz = bz - dz
    cdx = cx - dx
    cdy = cy - dy
    cdz = cz - dz
    det = adz * (bdx * cdy - cdx * bdy) + bdz * (cdx * ady - adx * cdy)
    det += cdz * (adx * bdy - bdx * ady)
    return det


@kernel(nogil=True, error_model="numpy")
def orient(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, bound):
    """Six times the signed volume of tetrahedron abcd, and whether its sign is certain.

    ``bound`` must bound the rounding error: `orient_bound` of the points' extent.
    """
    det = orient_det(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz)
    return det, abs(det) > bound
