"""Triangle pairs of a closed mesh that cross or may touch: a grid and certified signs.

Used by `exactgrasp.geometry.shells` to decide how shells relate. Triangle bounding boxes are
binned on a uniform grid of about a triangle's size; each candidate pair gets an edge-triangle
test whose orientation signs are certified by a static error bound (Shewchuk's, see
`exactgrasp.geometry.predicates`): a sign inside the bound is *uncertain*. Within one shell
only certain crossings are reported, and pairs sharing an edge are skipped; between shells an
uncertain contact is reported too.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.compiling import inner, kernel
from exactgrasp.geometry.predicates import orient_bound, orient_det

__all__ = ["CROSS", "NO", "UNSURE", "find_crossings"]

#: Result codes of a pair test: certainly apart, certainly crossing, or uncertain.
NO, CROSS, UNSURE = 0, 1, 2

# -- numba kernels ----------------------------------------------------------------------------


@inner(nogil=True, error_model="numpy")
def _sign(det, bound):
    if det > bound:
        return 1
    if det < -bound:
        return -1
    return 0


@inner(nogil=True, error_model="numpy")
def _edge_tri(X, e0, e1, a, b, c, bound):
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
    sp = _sign(dp, bound)
    sq = _sign(dq, bound)
    if sp != 0 and sp == sq:
        return NO, 0.0
    s1 = _sign(orient_det(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz), bound)
    s2 = _sign(orient_det(px, py, pz, qx, qy, qz, bx, by, bz, cx, cy, cz), bound)
    s3 = _sign(orient_det(px, py, pz, qx, qy, qz, cx, cy, cz, ax, ay, az), bound)
    if (s1 > 0 or s2 > 0 or s3 > 0) and (s1 < 0 or s2 < 0 or s3 < 0):
        return NO, 0.0
    if sp == 0 or sq == 0 or s1 == 0 or s2 == 0 or s3 == 0:
        return UNSURE, 0.0
    return CROSS, dp / (dp - dq)


@inner(nogil=True, error_model="numpy")
def _tri_tri(V, F, ident, t, u, skip_shared, flat_check, X, out):
    """Do triangles t and u of (V, F) meet? `NO`, `CROSS` (a certain crossing, its point
    written to ``out`` (3,)) or `UNSURE`. With ``skip_shared`` (triangles of one shell
    sharing one corner, by ``ident``), meeting only at that corner counts as `NO`. With
    ``flat_check``, an uncertain pair that is apart in projection (`_apart_in_projection`)
    counts as `NO`. ``X`` (6, 3) is scratch space.

    Two closed triangles meet iff an edge of one meets the other, so six edge tests decide.
    """
    for k in range(3):
        for ax in range(3):
            X[k, ax] = V[F[t, k], ax]
            X[k + 3, ax] = V[F[u, k], ax]
    ext = max(_spread(X, 0), _spread(X, 1), _spread(X, 2))
    bound = orient_bound(ext * (1.0 + 1e-12))
    # Cheap rejection: one triangle certainly on one side of the other's plane. With
    # ``skip_shared``, a corner shared by both is left out: the pair then meets only there.
    for first in range(2):
        a, b = (0, 3) if first == 0 else (3, 0)
        ta, tb = (t, u) if first == 0 else (u, t)
        side = 0
        split = False
        for k in range(3):
            vk = ident[F[tb, k]]
            if skip_shared and (
                vk == ident[F[ta, 0]] or vk == ident[F[ta, 1]] or vk == ident[F[ta, 2]]
            ):
                continue
            s = _sign(
                orient_det(X[a, 0], X[a, 1], X[a, 2], X[a + 1, 0], X[a + 1, 1], X[a + 1, 2],
                        X[a + 2, 0], X[a + 2, 1], X[a + 2, 2],
                        X[b + k, 0], X[b + k, 1], X[b + k, 2]),
                bound,
            )  # fmt: skip
            if s == 0 or (side != 0 and s != side):
                split = True
                break
            side = s
        if not split:
            return NO
    result = NO
    for first in range(2):
        a, b = (0, 3) if first == 0 else (3, 0)
        for k in range(3):
            e0 = a + k
            e1 = a + (k + 1) % 3
            code, lam = _edge_tri(X, e0, e1, b, b + 1, b + 2, bound)
            if code == CROSS:
                for ax in range(3):
                    out[ax] = X[e0, ax] + lam * (X[e1, ax] - X[e0, ax])
                return CROSS
            if code == UNSURE:
                result = UNSURE
    if result == UNSURE and flat_check and _apart_in_projection(X):
        return NO
    return result


@inner(nogil=True, error_model="numpy")
def _spread(X, ax):
    """Extent of the six corners X (6, 3) along axis ``ax``."""
    lo = X[0, ax]
    hi = lo
    for k in range(1, 6):
        lo = min(lo, X[k, ax])
        hi = max(hi, X[k, ax])
    return hi - lo


@inner(nogil=True, error_model="numpy")
def _apart_in_projection(X):
    """Are triangles X[0:3] and X[3:6] certainly apart in their projection onto one of the
    coordinate planes? Apart there means apart in space (the projection of a common point is
    common to both). Decides the coplanar and perpendicular neighbours that the orientation
    signs in space leave uncertain (triangles of one flat region, or of two flat regions
    meeting at a crease)."""
    for i, j in ((1, 2), (2, 0), (0, 1)):
        if _apart_2d(X, i, j):
            return True
    return False


@inner(nogil=True, error_model="numpy")
def _apart_2d(X, i, j):
    """Separating-axis test of the two triangles' projections onto axes (i, j), with an edge
    of either triangle as the axis; every sign certified."""
    ext = max(_spread(X, i), _spread(X, j))
    # Rounding of a 2D orientation determinant is below 4 eps times its terms, at most 2 L^2.
    bound = 1e-14 * ext * ext
    for first in range(2):
        a, b = (0, 3) if first == 0 else (3, 0)
        area = (X[a + 1, i] - X[a, i]) * (X[a + 2, j] - X[a, j]) - (X[a + 1, j] - X[a, j]) * (
            X[a + 2, i] - X[a, i]
        )
        if abs(area) <= bound:
            continue
        turn = 1.0 if area > 0 else -1.0
        for k in range(3):
            p, q = a + k, a + (k + 1) % 3
            outside = True
            for r in range(3):
                c = b + r
                d = (X[q, i] - X[p, i]) * (X[c, j] - X[p, j]) - (X[q, j] - X[p, j]) * (
                    X[c, i] - X[p, i]
                )
                if turn * d >= -bound:
                    outside = False
                    break
            if outside:
                return True
    return False


@kernel(nogil=True, error_model="numpy")
def _fill_cells(i0, i1, n, offsets, keys, tris):
    """Write the (flat cell, triangle) entries of every triangle's bounding-box cell range."""
    for f in range(i0.shape[0]):
        q = offsets[f]
        for i in range(i0[f, 0], i1[f, 0] + 1):
            for j in range(i0[f, 1], i1[f, 1] + 1):
                for k in range(i0[f, 2], i1[f, 2] + 1):
                    keys[q] = (i * n[1] + j) * n[2] + k
                    tris[q] = f
                    q += 1


@kernel(nogil=True, error_model="numpy")
def _pair_scan(V, F, ident, shell, self_contacts, lo, hi, i0, n, keys, tris):
    """Test every pair of triangles sharing a grid cell, once (in the first cell they share).

    Returns arrays ``t, u, code, point (k, 3)`` of the pairs that matter: certain crossings
    within one shell, certain or uncertain contacts between two shells, and with
    ``self_contacts`` uncertain contacts within one shell too.
    """
    ts = [np.int64(0) for _ in range(0)]
    us = [np.int64(0) for _ in range(0)]
    codes = [np.int64(0) for _ in range(0)]
    pts = [0.0 for _ in range(0)]
    out = np.zeros(3)
    X = np.empty((6, 3))
    start = 0
    total = keys.shape[0]
    while start < total:
        end = start + 1
        while end < total and keys[end] == keys[start]:
            end += 1
        cell = keys[start]
        # Sweep along x: sorted by lower x, a cell's later triangles start past t's end.
        run = tris[start:end]
        for p in range(run.shape[0]):
            t = run[p]
            for q in range(p + 1, run.shape[0]):
                u = run[q]
                if lo[u, 0] > hi[t, 0]:
                    break
                if (
                    lo[t, 1] > hi[u, 1]
                    or lo[u, 1] > hi[t, 1]
                    or lo[t, 2] > hi[u, 2]
                    or lo[u, 2] > hi[t, 2]
                ):
                    continue
                first = (max(i0[t, 0], i0[u, 0]) * n[1] + max(i0[t, 1], i0[u, 1])) * n[2]
                if first + max(i0[t, 2], i0[u, 2]) != cell:
                    continue
                shared = 0
                for a in range(3):
                    for b in range(3):
                        if ident[F[t, a]] == ident[F[u, b]]:
                            shared += 1
                if shared >= 2:
                    continue
                same = shell[t] == shell[u]
                code = _tri_tri(V, F, ident, t, u, shared == 1 and same, same, X, out)
                if code == NO or (code == UNSURE and same and (shared or not self_contacts)):
                    continue
                ts.append(t)
                us.append(u)
                codes.append(code)
                pts.append(out[0] if code == CROSS else np.nan)
                pts.append(out[1] if code == CROSS else np.nan)
                pts.append(out[2] if code == CROSS else np.nan)
        start = end
    return (
        np.array(ts, np.int64),
        np.array(us, np.int64),
        np.array(codes, np.int64),
        np.array(pts, np.float64).reshape(-1, 3),
    )


def find_crossings(
    vertices: np.ndarray,
    faces: np.ndarray,
    label: np.ndarray,
    *,
    identity: np.ndarray | None = None,
    self_contacts: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pairs of triangles that cross (within a shell) or may touch (between shells).

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
    label : numpy.ndarray, shape (m,), int64
        Shell of every face (`split_shells`).
    identity : numpy.ndarray, shape (n,), int64, optional
        Vertices with equal identity are one point (copies made by
        `exactgrasp.geometry.topology.split_nonmanifold`): triangles meeting only there share
        a corner. Default: every vertex its own.
    self_contacts : bool
        Also report uncertain contacts within one shell between triangles that share no
        corner (a surface touching itself, or crossing itself exactly through an edge or a
        corner).

    Returns
    -------
    t, u : numpy.ndarray, shape (k,), int64
        Face indices of each pair found.
    code : numpy.ndarray, shape (k,), int64
        1: a certain crossing; 2: uncertain contact (between different shells, or within one
        with ``self_contacts``).
    point : numpy.ndarray, shape (k, 3), float64
        A point of a certain crossing (NaN for uncertain contacts), in vertex units.
    """
    V = np.ascontiguousarray(vertices, dtype=np.float64)
    F = np.ascontiguousarray(faces, dtype=np.int64)
    corners = V[F]
    lo = np.ascontiguousarray(corners.min(1))
    hi = np.ascontiguousarray(corners.max(1))
    origin = lo.min(0)
    span = float((hi.max(0) - origin).max())
    size = float((hi - lo).max(1).mean())
    h = max(size, span * 1e-6, 1e-300)
    while True:
        # Cells of about a triangle's size: few pairs per cell; coarser while long triangles
        # would fill too many cells.
        n = np.minimum(np.floor((hi.max(0) - origin) / h).astype(np.int64) + 1, 2**20)
        i0 = np.minimum(np.floor((lo - origin) / h).astype(np.int64), n - 1)
        i1 = np.minimum(np.floor((hi - origin) / h).astype(np.int64), n - 1)
        counts = np.prod(i1 - i0 + 1, axis=1)
        if counts.sum() <= 16 * len(F) + 1024 or h >= span:
            break
        h *= 2.0
    offsets = np.zeros(len(F) + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    keys = np.empty(offsets[-1], np.int64)
    tris = np.empty(offsets[-1], np.int64)
    _fill_cells(i0, i1, n, offsets, keys, tris)
    # By cell, then lower x (the sweep's order), then triangle: sorted here, not in the kernel.
    order = np.lexsort((tris, lo[tris, 0], keys))
    label = np.ascontiguousarray(label, dtype=np.int64)
    ident = (
        np.arange(len(V), dtype=np.int64)
        if identity is None
        else np.ascontiguousarray(identity, dtype=np.int64)
    )
    return _pair_scan(
        V, F, ident, label, bool(self_contacts), lo, hi, i0, n, keys[order], tris[order]
    )
