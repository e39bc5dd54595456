"""Triangle pairs of a closed mesh that cross or may touch: a grid and certified signs.

Used by `exactgrasp.geometry.shells` to decide how shells relate. Triangle bounding boxes are
binned on a uniform grid of about a triangle's size; each candidate pair gets an edge-triangle
test whose orientation signs are certified by a static error bound (Shewchuk's, see
`exactgrasp.geometry.predicates`): a sign inside the bound is *uncertain*. Within one shell
certain crossings are reported (and, on request, uncertain contacts, neighbours that may fold
onto each other included); between shells an uncertain contact is reported too.
`find_contacts` reports every pair that may meet beyond its shared corners, for the exact cut.
The single-pair tests live in `exactgrasp.geometry.pair_tests`.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.compiling import inner, kernel
from exactgrasp.geometry.pair_tests import CROSS, NO, UNSURE, meets_beyond_shared
from exactgrasp.geometry.pair_tests import certain_sign as _sign
from exactgrasp.geometry.pair_tests import edge_triangle as _edge_tri
from exactgrasp.geometry.pair_tests import spread as _spread
from exactgrasp.geometry.predicates import orient_bound, orient_det

__all__ = ["CROSS", "NO", "UNSURE", "find_contacts", "find_crossings"]

# -- numba kernels ----------------------------------------------------------------------------


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


@inner(nogil=True, error_model="numpy")
def _pair_code(V, F, ident, t, u, same, self_contacts, everything, X, out):
    """The code of one candidate pair, or -1 when it is not reported (see `_pair_scan`)."""
    shared = 0
    for a in range(3):
        for b in range(3):
            if ident[F[t, a]] == ident[F[u, b]]:
                shared += 1
    if everything:
        if shared == 0:
            code = _tri_tri(V, F, ident, t, u, False, True, X, out)
            return -1 if code == NO else code
        return UNSURE if meets_beyond_shared(V, F, ident, t, u, X) else -1
    if shared >= 2:
        # Triangles on one edge meet elsewhere only where they fold onto each other.
        if same and not self_contacts:
            return -1
        return UNSURE if meets_beyond_shared(V, F, ident, t, u, X) else -1
    code = _tri_tri(V, F, ident, t, u, shared == 1 and same, same, X, out)
    if code == NO:
        return -1
    if code == UNSURE and same:
        if not self_contacts or (shared and not meets_beyond_shared(V, F, ident, t, u, X)):
            return -1
    return code


@kernel(nogil=True, error_model="numpy")
def _pair_scan(V, F, ident, shell, self_contacts, everything, lo, hi, i0, n, keys, tris):
    """Test every pair of triangles sharing a grid cell, once (in the first cell they share).

    Returns arrays ``t, u, code, point (k, 3)`` of the pairs that matter: certain crossings
    within one shell, certain or uncertain contacts between two shells, and with
    ``self_contacts`` uncertain contacts within one shell too (neighbours included where
    they may meet beyond their common corners). With ``everything``, every pair that may meet
    anywhere but at the corners (and edge) it shares.
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
                same = shell[t] == shell[u]
                code = _pair_code(V, F, ident, t, u, same, self_contacts, everything, X, out)
                if code < 0:
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


def _scan(V, F, label, ident, self_contacts: bool, everything: bool):
    """Bin the triangles' bounding boxes on a grid and run `_pair_scan`."""
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    if len(F) == 0:
        empty = np.empty(0, np.int64)
        return empty, empty, empty, np.empty((0, 3))
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
        if ident is None
        else np.ascontiguousarray(ident, dtype=np.int64)
    )
    return _pair_scan(
        V, F, ident, label, self_contacts, everything, lo, hi, i0, n, keys[order], tris[order]
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
        Also report uncertain contacts within one shell: between triangles that share no
        corner (a surface touching itself, or crossing itself exactly through an edge or a
        corner), and between neighbours that may meet beyond the corners they share (a fold
        onto itself).

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
    return _scan(vertices, faces, label, identity, bool(self_contacts), False)


def find_contacts(
    vertices: np.ndarray, faces: np.ndarray, identity: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of triangles that may meet anywhere but at the corners they share.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
    identity : numpy.ndarray, shape (n,), int64
        Vertices with equal identity are one point.

    Returns
    -------
    t, u : numpy.ndarray, shape (k,), int64
        Face indices of each pair: the pairs the exact cut
        (`exactgrasp.geometry.exact_cut`) must decide. Pairs left out certainly meet at most
        at their shared corners and along their shared edge.
    """
    label = np.zeros(len(faces), np.int64)
    t, u, _, _ = _scan(vertices, faces, label, identity, True, True)
    return t, u
