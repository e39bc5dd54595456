"""Certified tests of one pair of triangles (numba), for `exactgrasp.geometry.crossings`.

Orientation signs come with Shewchuk's static error bound (`exactgrasp.geometry.predicates`):
a sign within the bound is 0, *uncertain*. `edge_triangle` asks whether a segment meets a
triangle; `meets_beyond_shared` asks whether two triangles that share one or two corners (by
identity: copies of one point count as one) meet anywhere else, which is what decides whether
neighbours in a flat region touch only along their common edge or corner. Each answer is
either certain or "maybe", never a wrong "no".
"""

from __future__ import annotations

from exactgrasp.compiling import inner
from exactgrasp.geometry.predicates import orient_bound, orient_det

__all__ = ["CROSS", "NO", "UNSURE", "certain_sign", "edge_triangle", "meets_beyond_shared"]

#: Result codes of a pair test: certainly apart, certainly crossing, or uncertain.
NO, CROSS, UNSURE = 0, 1, 2


@inner(nogil=True, error_model="numpy")
def certain_sign(det, bound):
    """+1 or -1 when ``det`` is beyond ``bound``, else 0 (uncertain)."""
    if det > bound:
        return 1
    if det < -bound:
        return -1
    return 0


@inner(nogil=True, error_model="numpy")
def spread(X, ax):
    """Extent of the six corners X (6, 3) along axis ``ax``."""
    lo = X[0, ax]
    hi = lo
    for k in range(1, 6):
        lo = min(lo, X[k, ax])
        hi = max(hi, X[k, ax])
    return hi - lo


@inner(nogil=True, error_model="numpy")
def edge_triangle(X, e0, e1, a, b, c, bound):
    """Does the closed segment from corner ``e0`` to ``e1`` meet the closed triangle of
    corners ``a, b, c``? Corners are rows of X (6, 3): scalar loads, no array views in the
    hot loop.

    Returns ``(code, lam)``: `NO` (certainly not), `CROSS` (certainly, through the
    triangle's interior, at ``X[e0] + lam (X[e1] - X[e0])``) or `UNSURE`.
    """
    px, py, pz = X[e0, 0], X[e0, 1], X[e0, 2]
    qx, qy, qz = X[e1, 0], X[e1, 1], X[e1, 2]
    ax, ay, az = X[a, 0], X[a, 1], X[a, 2]
    bx, by, bz = X[b, 0], X[b, 1], X[b, 2]
    cx, cy, cz = X[c, 0], X[c, 1], X[c, 2]
    dp = orient_det(ax, ay, az, bx, by, bz, cx, cy, cz, px, py, pz)
    dq = orient_det(ax, ay, az, bx, by, bz, cx, cy, cz, qx, qy, qz)
    sp = certain_sign(dp, bound)
    sq = certain_sign(dq, bound)
    if sp != 0 and sp == sq:
        return NO, 0.0
    s1 = certain_sign(orient_det(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz), bound)
    s2 = certain_sign(orient_det(px, py, pz, qx, qy, qz, bx, by, bz, cx, cy, cz), bound)
    s3 = certain_sign(orient_det(px, py, pz, qx, qy, qz, cx, cy, cz, ax, ay, az), bound)
    if (s1 > 0 or s2 > 0 or s3 > 0) and (s1 < 0 or s2 < 0 or s3 < 0):
        return NO, 0.0
    if sp == 0 or sq == 0 or s1 == 0 or s2 == 0 or s3 == 0:
        return UNSURE, 0.0
    return CROSS, dp / (dp - dq)


@inner(nogil=True, error_model="numpy")
def _turn(X, p, q, r, i, j, bound):
    """Certain sign of the turn p -> q -> r of rows of X in the coordinates (i, j)."""
    det = (X[q, i] - X[p, i]) * (X[r, j] - X[p, j]) - (X[q, j] - X[p, j]) * (X[r, i] - X[p, i])
    return certain_sign(det, bound)


@inner(nogil=True, error_model="numpy")
def _corner(mask, n, shared):
    """Index of the n-th corner (0, 1, 2) whose bit in ``mask`` is ``shared`` (1 or 0)."""
    seen = 0
    for k in range(3):
        if (mask >> k & 1) == shared:
            if seen == n:
                return k
            seen += 1
    return -1


@inner(nogil=True, error_model="numpy")
def _rays_outside(X, p, a, b, c, d, i, j, bound):
    """Are the rays from corner p through c and through d certainly outside the closed cone
    from p spanned by a and b (an angle of a flat triangle, so under half a turn)? A corner
    seen exactly at p (its triangle edge-on) adds no ray."""
    s = _turn(X, p, a, b, i, j, bound)
    for r in (c, d):
        if X[r, i] == X[p, i] and X[r, j] == X[p, j]:
            continue
        if _turn(X, p, a, r, i, j, bound) != -s and _turn(X, p, r, b, i, j, bound) != -s:
            return False
    return True


@inner(nogil=True, error_model="numpy")
def _apart_but_shared_2d(X, mask_t, mask_u, shared):
    """Are triangles X[0:3] and X[3:6], sharing the corners in the bit masks (one or two),
    certainly apart but for those corners in a projection onto a coordinate plane that keeps
    one of them flat (so that meeting only there in projection means only there in space)?
    Across a shared edge: the free corners on opposite sides of it. At a shared corner: the
    projections are cones from it, which meet beyond it only if a bounding ray of one lies in
    the other (a cone seen edge-on is its rays)."""
    p = _corner(mask_t, 0, 1)
    r0, r1 = _corner(mask_t, 0, 0), _corner(mask_t, 1, 0)
    v0, v1 = _corner(mask_u, 0, 0) + 3, _corner(mask_u, 1, 0) + 3
    for i, j in ((1, 2), (2, 0), (0, 1)):
        ext = max(spread(X, i), spread(X, j))
        # Rounding of a 2D orientation determinant is below 4 eps times its terms, 2 L^2.
        bound = 1e-14 * ext * ext
        flat_t = _turn(X, 0, 1, 2, i, j, bound) != 0
        flat_u = _turn(X, 3, 4, 5, i, j, bound) != 0
        if not flat_t and not flat_u:
            continue
        if shared == 2:
            q = _corner(mask_t, 1, 1)
            s1 = _turn(X, p, q, r0, i, j, bound)
            s2 = _turn(X, p, q, v0, i, j, bound)
            if s1 != 0 and s2 != 0 and s1 != s2:
                return True
            continue
        if flat_t and not _rays_outside(X, p, r0, r1, v0, v1, i, j, bound):
            continue
        if flat_u and not _rays_outside(X, p, v0, v1, r0, r1, i, j, bound):
            continue
        return True
    return False


@inner(nogil=True, error_model="numpy")
def meets_beyond_shared(V, F, ident, t, u, X):
    """Might triangles t and u of (V, F), which share corners by ``ident``, meet anywhere but
    at those corners (and the edge between two of them)? False only when certainly not.
    ``X`` (6, 3) is scratch space."""
    mask_t = 0
    mask_u = 0
    for a in range(3):
        for b in range(3):
            if ident[F[t, a]] == ident[F[u, b]]:
                mask_t |= 1 << a
                mask_u |= 1 << b
    shared = (mask_t & 1) + (mask_t >> 1 & 1) + (mask_t >> 2 & 1)
    shared_u = (mask_u & 1) + (mask_u >> 1 & 1) + (mask_u >> 2 & 1)
    if shared != shared_u or shared == 0 or shared == 3:
        return True  # a repeated corner, or the same three points: for exact arithmetic
    for k in range(3):
        for ax in range(3):
            X[k, ax] = V[F[t, k], ax]
            X[k + 3, ax] = V[F[u, k], ax]
    ext = max(spread(X, 0), spread(X, 1), spread(X, 2))
    bound = orient_bound(ext * (1.0 + 1e-12))
    off = True  # every unshared corner certainly off the other's plane
    for first in range(2):
        a, b = (0, 3) if first == 0 else (3, 0)
        mask = mask_u if first == 0 else mask_t
        side = 0
        split = False
        for k in range(3):
            if mask >> k & 1:
                continue
            s = certain_sign(
                orient_det(X[a, 0], X[a, 1], X[a, 2], X[a + 1, 0], X[a + 1, 1], X[a + 1, 2],
                           X[a + 2, 0], X[a + 2, 1], X[a + 2, 2],
                           X[b + k, 0], X[b + k, 1], X[b + k, 2]),
                bound,
            )  # fmt: skip
            if s == 0:
                off = False
                split = True
            elif side != 0 and s != side:
                split = True
            else:
                side = s
        if not split:
            return False  # the other's free corners certainly on one side of this plane
    if shared == 1 and off:
        # Then they meet beyond the corner only if an edge opposite it meets the other.
        e0, e1 = _corner(mask_t, 0, 0), _corner(mask_t, 1, 0)
        f0, f1 = _corner(mask_u, 0, 0) + 3, _corner(mask_u, 1, 0) + 3
        c1, _ = edge_triangle(X, e0, e1, 3, 4, 5, bound)
        c2, _ = edge_triangle(X, f0, f1, 0, 1, 2, bound)
        return c1 != NO or c2 != NO
    return not _apart_but_shared_2d(X, mask_t, mask_u, shared)
