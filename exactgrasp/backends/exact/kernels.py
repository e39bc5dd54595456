"""Numba kernels of the exact backend: filtered predicates and the per-pose surface integral.

The volume of ``A ∩ B`` for closed, outward-oriented triangle meshes is, by the divergence
theorem with the field ``x / 3``,

``V = 1/3 (Σ_{t∈∂A} d_t · area(t ∩ B) + Σ_{s∈∂B} d_s · area(s ∩ A))``, ``d_t = n_t · x_t``.

Writing each clipped area with Green's theorem (``area · n = 1/2 ∮ p × dp``) turns the sum into
three kinds of purely local terms (``D_t = d_t n_t``):

* every edge ``u → v`` (``u < v``) of A, owned by face ``t1`` and shared with ``t2``:
  ``W_e · f_e`` with ``W_e = (D_t1 − D_t2) · (u × v) / 6`` and ``f_e`` the fraction of the
  edge inside B (0 or 1 unless the edge crosses ∂B), and the same for the edges of B;
* every pair of faces ``(t, s)`` that cross, along their common segment ``p → q`` directed as
  ``n_t × n_s``: ``(D_t − D_s) · (p × q) / 6``.

Only the signs of orientation determinants decide which terms appear. They are evaluated in
double precision with a static error bound; a sign inside the bound makes the kernel report the
pose as *degenerate*, and the caller recomputes it with a manifold3d boolean. Every sign used
is therefore exact, so the result is the exact volume up to the rounding of the intersection
points (about 1e-15 relative).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# The shared predicates and winding number live in `exactgrasp.geometry`; re-exported here.
from exactgrasp.geometry.predicates import orient as orient
from exactgrasp.geometry.predicates import orient_bound as orient_bound
from exactgrasp.geometry.winding import winding_number as winding_number

#: Unit roundoff of double precision (round to nearest): every error bound below is a multiple.
U = 2.0**-53
#: A plane distance ``n·x - n·a`` with the unit normal of a face from its cross product errs by
#: at most ``U G (25 + 14.2 kappa)`` (``G`` bounds every coordinate, ``kappa`` the face's
#: conditioning `face_conditioning`; see docs/exact-backend.md): taken as ``32 (1 + kappa)``.
PLANE_ERR = 32.0
#: Conditioning beyond which the normal's direction error (7 U kappa, first order) is not
#: trusted: the face's plane tests then certify nothing and every decision takes the exact test.
KAPPA_MAX = 1e-2 / (7.0 * U)
#: Plane-distance error coefficient (times G) of a face beyond `KAPPA_MAX`: a distance that
#: large is impossible, so no side, box or walk decision is taken in floating point.
PLANE_ERR_NONE = 4.0
#: Error of a face's ``D = (n·a) n`` against the exact one, times its area / 3 (what the face's
#: terms can lose, see docs), in units of ``U G |b - a| |c - a|``: at most 6 when conditioned
#: (taken as 8), 236 beyond `KAPPA_MAX` (taken as 240).
FACE_D_ERR, FACE_D_ERR_NONE = 8.0, 240.0
#: Rounding of one product term ``g · (p × q) / 6`` (and of an edge weight), in units of
#: ``U (|D_1|_1 + |D_2|_1) |p|_inf |q|_inf``: 3 by a first-order count, taken as 4.
TERM_ERR = 4.0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def plane_err_coef(kappa):
    """Bound on the error of a plane distance with a face's unit normal, divided by the
    coordinate bound G (`PLANE_ERR`); `PLANE_ERR_NONE` beyond `KAPPA_MAX` (or no normal)."""
    if kappa <= KAPPA_MAX:
        return PLANE_ERR * U * (1.0 + kappa)
    return PLANE_ERR_NONE


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def face_d_coef(kappa, l1l2):
    """Bound (divided by G) on what a face's rounded ``D`` costs its terms: ``|dD| area / 3``
    (`FACE_D_ERR`), from the face's conditioning and ``|b - a| |c - a|``."""
    return (FACE_D_ERR if kappa <= KAPPA_MAX else FACE_D_ERR_NONE) * U * l1l2


_NO, _CROSS, _DEGENERATE = 0, 1, 2


@njit(cache=True, nogil=True, error_model="numpy")
def edge_triangle(
    px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, cx, cy, cz, sp, s1, sq, s2, bound
):
    """Does segment pq cross triangle abc? Returns (code, lambda) with p + lambda (q - p).

    ``sp, s1`` and ``sq, s2`` are the certain sign (or 0) and the determinant of `orient`
    (a, b, c, p) and (a, b, c, q).
    """
    if sp != 0 and sq != 0 and sp == sq:
        return _NO, 0.0
    o1, k1 = orient(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, bound)
    o2, k2 = orient(px, py, pz, qx, qy, qz, bx, by, bz, cx, cy, cz, bound)
    o3, k3 = orient(px, py, pz, qx, qy, qz, cx, cy, cz, ax, ay, az, bound)
    pos = (k1 and o1 > 0) or (k2 and o2 > 0) or (k3 and o3 > 0)
    neg = (k1 and o1 < 0) or (k2 and o2 < 0) or (k3 and o3 < 0)
    if pos and neg:
        return _NO, 0.0
    if sp == 0 or sq == 0 or not (k1 and k2 and k3):
        return _DEGENERATE, 0.0
    return _CROSS, s1 / (s1 - s2)


@njit(cache=True, nogil=True, error_model="numpy")
def face_terms(V, F, tiny, D, N):
    """Fill per face normal ``N`` (unnormalised) and ``D = (N·a) N / |N|²``, shapes (m, 3).

    ``D`` is set to zero where ``|N|² <= tiny``: such a face adds at most ``|a| sqrt(tiny) / 2``
    to the volume, and skipping it avoids dividing by zero.
    """
    # Scalar loads only: an array view per vertex costs two atomic reference-count updates,
    # which two threads sharing the mesh turn into cache-line contention.
    m = F.shape[0]
    for f in range(m):
        i, j, k = F[f, 0], F[f, 1], F[f, 2]
        a0, a1, a2 = V[i, 0], V[i, 1], V[i, 2]
        b0, b1, b2 = V[j, 0] - a0, V[j, 1] - a1, V[j, 2] - a2
        c0, c1, c2 = V[k, 0] - a0, V[k, 1] - a1, V[k, 2] - a2
        n0 = b1 * c2 - b2 * c1
        n1 = b2 * c0 - b0 * c2
        n2 = b0 * c1 - b1 * c0
        N[f, 0] = n0
        N[f, 1] = n1
        N[f, 2] = n2
        nn = n0 * n0 + n1 * n1 + n2 * n2
        D[f, 0] = D[f, 1] = D[f, 2] = 0.0
        if nn > tiny:
            s = (n0 * a0 + n1 * a1 + n2 * a2) / nn
            D[f, 0] = s * n0
            D[f, 1] = s * n1
            D[f, 2] = s * n2


@njit(cache=True, nogil=True, error_model="numpy")
def edge_weight_err(V, D, E, ET, e, Dcoef, g):
    """``W_e`` (see `edge_weight`) and a bound on its error: its rounding (`TERM_ERR`) and
    a third of what each face's rounded ``D`` costs (``Dcoef[t] * g``, see `face_d_coef`)."""
    i, j = E[e, 0], E[e, 1]
    t1 = ET[e, 0]
    t2 = ET[e, 1]
    cx = V[i, 1] * V[j, 2] - V[i, 2] * V[j, 1]
    cy = V[i, 2] * V[j, 0] - V[i, 0] * V[j, 2]
    cz = V[i, 0] * V[j, 1] - V[i, 1] * V[j, 0]
    w = (
        (D[t1, 0] - D[t2, 0]) * cx + (D[t1, 1] - D[t2, 1]) * cy + (D[t1, 2] - D[t2, 2]) * cz
    ) / 6.0
    dn = abs(D[t1, 0]) + abs(D[t1, 1]) + abs(D[t1, 2]) + abs(D[t2, 0]) + abs(D[t2, 1])
    dn += abs(D[t2, 2])
    ui = max(abs(V[i, 0]), abs(V[i, 1]), abs(V[i, 2]))
    vj = max(abs(V[j, 0]), abs(V[j, 1]), abs(V[j, 2]))
    return w, TERM_ERR * U * dn * ui * vj + (Dcoef[t1] + Dcoef[t2]) * g / 3.0


@njit(cache=True, nogil=True, error_model="numpy")
def edge_weight(V, D, E, ET, e):
    """``W_e = (D_t1 − D_t2) · (u × v) / 6`` for edge e."""
    i, j = E[e, 0], E[e, 1]
    t1 = ET[e, 0]
    t2 = ET[e, 1]
    cx = V[i, 1] * V[j, 2] - V[i, 2] * V[j, 1]
    cy = V[i, 2] * V[j, 0] - V[i, 0] * V[j, 2]
    cz = V[i, 0] * V[j, 1] - V[i, 1] * V[j, 0]
    return (
        (D[t1, 0] - D[t2, 0]) * cx + (D[t1, 1] - D[t2, 1]) * cy + (D[t1, 2] - D[t2, 2]) * cz
    ) / 6.0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sep(ax, ay, az, x0, y0, z0, x1, y1, z1, x2, y2, z2, hx, hy, hz):
    """Is axis (ax, ay, az) separating a triangle and the box [-h*, h*] (half sizes h*)?"""
    p0 = ax * x0 + ay * y0 + az * z0
    p1 = ax * x1 + ay * y1 + az * z1
    p2 = ax * x2 + ay * y2 + az * z2
    r = hx * abs(ax) + hy * abs(ay) + hz * abs(az)
    return (min(p0, p1, p2) > r) | (max(p0, p1, p2) < -r)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sep2(a, b, p, q, r, s, ha, hb):
    """Is the axis with components (a, b) in two coordinates (0 in the third) separating a
    triangle whose corners project to a p + b q and a r + b s, and a box of half sizes
    ha, hb in those coordinates?"""
    p0 = a * p + b * q
    p1 = a * r + b * s
    rad = ha * abs(a) + hb * abs(b)
    return (min(p0, p1) > rad) | (max(p0, p1) < -rad)


@njit(cache=True, nogil=True, error_model="numpy")
def tri_box(cx, cy, cz, hh, a, b, c):
    """Separating-axis test: does triangle abc touch the cube of half-size hh at (cx, cy, cz)?"""
    return tri_box_xyz(
        cx, cy, cz, hh, hh, hh, a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]
    )


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
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


@njit(cache=True, nogil=True, error_model="numpy")
def tri_cell_range(V, F, f, lo, h, n, margin, rng):
    """Grid-index range of triangle f's bounding box (clipped); False when outside the grid.
    (Products with 1 / h, not quotients: the margin dwarfs the difference in rounding.)"""
    ih = 1.0 / h
    for ax in range(3):
        x0 = min(V[F[f, 0], ax], V[F[f, 1], ax], V[F[f, 2], ax]) - margin
        x1 = max(V[F[f, 0], ax], V[F[f, 1], ax], V[F[f, 2], ax]) + margin
        i0 = int(np.floor((x0 - lo[ax]) * ih))
        i1 = int(np.floor((x1 - lo[ax]) * ih))
        if i1 < 0 or i0 >= n[ax]:
            return False
        rng[ax, 0] = max(i0, 0)
        rng[ax, 1] = min(i1, n[ax] - 1)
    return True


@njit(cache=True, nogil=True, error_model="numpy")
def raster_triangles(V, F, lo, h, n, margin):
    """(cell, triangle) pairs of every triangle touching a grid cell (closed, grown by margin).

    Returns flat cell indices and triangle indices, sorted by cell.
    """
    cells = []
    tris = []
    rng = np.empty((3, 2), np.int64)
    hh = 0.5 * h + margin
    for f in range(F.shape[0]):
        if not tri_cell_range(V, F, f, lo, h, n, margin, rng):
            continue
        for i in range(rng[0, 0], rng[0, 1] + 1):
            for j in range(rng[1, 0], rng[1, 1] + 1):
                for k in range(rng[2, 0], rng[2, 1] + 1):
                    cx = lo[0] + (i + 0.5) * h
                    cy = lo[1] + (j + 0.5) * h
                    cz = lo[2] + (k + 0.5) * h
                    if tri_box(cx, cy, cz, hh, V[F[f, 0]], V[F[f, 1]], V[F[f, 2]]):
                        cells.append((i * n[1] + j) * n[2] + k)
                        tris.append(f)
    c = np.array(cells, np.int64)
    t = np.array(tris, np.int64)
    order = np.argsort(c, kind="mergesort")
    return c[order], t[order]


@njit(cache=True, nogil=True, error_model="numpy")
def surface_cells_in(table, n, rng):
    """Number of surface cells in the box of cells ``rng`` (3, 2) (inclusive index ranges),
    from the grid's summed-volume table (`build_grid`)."""
    s1 = n[2] + 1
    s0 = (n[1] + 1) * s1
    a0, a1 = rng[0, 0] * s0, (rng[0, 1] + 1) * s0
    b0, b1 = rng[1, 0] * s1, (rng[1, 1] + 1) * s1
    c0, c1 = rng[2, 0], rng[2, 1] + 1
    return (
        table[a1 + b1 + c1]
        - table[a0 + b1 + c1]
        - table[a1 + b0 + c1]
        - table[a1 + b1 + c0]
        + table[a0 + b0 + c1]
        + table[a0 + b1 + c0]
        + table[a1 + b0 + c0]
        - table[a0 + b0 + c0]
    )


@njit(cache=True, nogil=True, error_model="numpy")
def point_status(x, lo, h, n, status):
    """Inside (1) / outside (0) from the grid's cell statuses; -1 when x is in a surface cell."""
    c = cell_index(x[0], x[1], x[2], lo[0], lo[1], lo[2], 1.0 / h, n[0], n[1], n[2])
    return 0 if c < 0 else status[c]


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def cell_index(x, y, z, l0, l1, l2, ih, n0, n1, n2):
    """Flat index of the grid cell holding (x, y, z), or -1 outside the grid (lower corner
    (l0, l1, l2), inverse cell edge ih, n* cells per axis). Scalars only, so that per-vertex
    loops can inline it without reference counting the grid's arrays. A point within rounding
    of a cell's boundary may get either cell: a cell of known status lies at least the
    rasterisation margin away from the surface, so either answer is right."""
    i = int(np.floor((x - l0) * ih))
    j = int(np.floor((y - l1) * ih))
    k = int(np.floor((z - l2) * ih))
    if i < 0 or j < 0 or k < 0 or i >= n0 or j >= n1 or k >= n2:
        return -1
    return (i * n1 + j) * n2 + k


@njit(cache=True, nogil=True, error_model="numpy")
def ray_status(x, V, F, grid, fstamp, token):
    """Inside (1) or outside (0) of point x against a closed mesh with its cell grid, exactly.

    Walks from x's cell along +x in its row of cells to the first cell of known status, and
    flips that status by the parity of the faces crossed by the segment from x to that cell's
    centre (only faces listed in the cells walked can cross it). Every crossing is decided by
    certified orientation signs; returns -1 when one is uncertain (x on or very near a face).

    Parameters
    ----------
    x : numpy.ndarray, shape (3,)
        The point, in the mesh's frame.
    V, F : numpy.ndarray
        The mesh, shapes (n, 3) float64 and (m, 3) int64.
    grid : tuple
        `build_grid` of the mesh.
    fstamp : numpy.ndarray, shape (m,), int64
        Scratch space marking faces already tested; entries equal to `token` are skipped.
    token : int
        A value not yet used in `fstamp`.
    """
    lo, h, n, status, cs, ct = grid[0], grid[1], grid[2], grid[3], grid[4], grid[5]
    i = int(np.floor((x[0] - lo[0]) / h))
    j = int(np.floor((x[1] - lo[1]) / h))
    k = int(np.floor((x[2] - lo[2]) / h))
    if i < 0 or j < 0 or k < 0 or i >= n[0] or j >= n[1] or k >= n[2]:
        return 0
    end = i
    known = -1
    while end < n[0]:
        known = status[(end * n[1] + j) * n[2] + k]
        if known >= 0:
            break
        end += 1
    if known < 0:
        return -1
    yx = lo[0] + (end + 0.5) * h
    yy = lo[1] + (j + 0.5) * h
    yz = lo[2] + (k + 0.5) * h
    parity = 0
    for ii in range(i, end):
        c = (ii * n[1] + j) * n[2] + k
        for q in range(cs[c], cs[c + 1]):
            f = ct[q]
            if fstamp[f] == token:
                continue
            fstamp[f] = token
            a, b, d = V[F[f, 0]], V[F[f, 1]], V[F[f, 2]]
            ext = 0.0
            for ax in range(3):
                y_ax = yx if ax == 0 else (yy if ax == 1 else yz)
                hi = max(a[ax], b[ax], d[ax], x[ax], y_ax)
                lo_ = min(a[ax], b[ax], d[ax], x[ax], y_ax)
                ext = max(ext, hi - lo_)
            bound = orient_bound(ext * (1.0 + 1e-12))
            dp, okp = orient(a[0], a[1], a[2], b[0], b[1], b[2], d[0], d[1], d[2],
                             x[0], x[1], x[2], bound)  # fmt: skip
            dq, okq = orient(a[0], a[1], a[2], b[0], b[1], b[2], d[0], d[1], d[2],
                             yx, yy, yz, bound)  # fmt: skip
            sp = 0 if not okp else (1 if dp > 0 else -1)
            sq = 0 if not okq else (1 if dq > 0 else -1)
            code, _ = edge_triangle(x[0], x[1], x[2], yx, yy, yz, a[0], a[1], a[2],
                                    b[0], b[1], b[2], d[0], d[1], d[2], sp, dp, sq, dq,
                                    bound)  # fmt: skip
            if code == _DEGENERATE:
                return -1
            parity ^= code
    return known ^ parity
