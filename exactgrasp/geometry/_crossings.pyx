# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False, embedsignature=True
"""Triangle pairs that cross or may touch, compiled ahead of time (Cython): the grid's cell
entries and the scan of every pair of triangles sharing a cell.
`exactgrasp.geometry.crossings` is the module to import; it documents the method and bins the
triangles. The single-pair tests are ``_pair_tests.pxd``.

Every floating-point operation is the one the former numba kernels did, in the same order, and
the extension is built without contraction into fused multiply-adds and without fast-math
(meson.build), so the results are the same to the bit. The loops run without the GIL.
"""

import numpy as np

from libc.math cimport fabs
from libc.stdint cimport int64_t
from libc.stdlib cimport free, realloc
from libc.string cimport memcpy

from exactgrasp.geometry._minmax cimport max2, max3
from exactgrasp.geometry._pair_tests cimport (
    CROSS, NO, UNSURE, Corner, Mesh, edge_triangle, load_corners, meets_beyond_shared, orient_rows,
    spread,
)
from exactgrasp.geometry._predicates cimport certain_sign, orient_bound


# The triangles' bounding boxes on the grid, row-major (m, 3) arrays.
ctypedef struct Boxes:
    const double *lo
    const double *hi
    const int64_t *i0  # first cell along each axis
    int64_t n1, n2  # cells along y and z
    const int64_t *shell  # (m,)

# The pairs found so far: (t, u, code) and a crossing's point per pair, grown by doubling.
ctypedef struct Found:
    int64_t *pairs
    double *points
    Py_ssize_t n, capacity


cdef inline bint _one_side(
    const Mesh *m, int64_t ta, int64_t tb, int a, int b, bint skip_shared, double bound,
    Corner *X,
) noexcept nogil:
    """Are the corners of triangle tb (rows b..b+2 of ``X``) certainly on one side of the plane
    of ta (rows a..a+2)? With ``skip_shared``, a corner shared with ta is left out: the pair
    then meets only there."""
    cdef int k, s, side = 0
    cdef int64_t vk
    cdef const int64_t *own = m.F + 3 * ta
    for k in range(3):
        vk = m.ident[m.F[3 * tb + k]]
        if skip_shared and (
            vk == m.ident[own[0]] or vk == m.ident[own[1]] or vk == m.ident[own[2]]
        ):
            continue
        s = certain_sign(orient_rows(X, a, a + 1, a + 2, b + k), bound)
        if s == 0 or (side != 0 and s != side):
            return False
        side = s
    return True


cdef inline bint _apart_2d(Corner *X, int i, int j) noexcept nogil:
    """Separating-axis test of the two triangles' projections onto axes (i, j), with an edge
    of either triangle as the axis; every sign certified."""
    cdef double ext = max2(spread(X, i), spread(X, j))
    # Rounding of a 2D orientation determinant is below 4 eps times its terms, at most 2 L^2.
    cdef double bound = 1e-14 * ext * ext
    cdef double area, side, d
    cdef int first, a, b, k, p, q, c
    cdef bint outside
    for first in range(2):
        a = 0 if first == 0 else 3
        b = 3 - a
        area = (X[a + 1][i] - X[a][i]) * (X[a + 2][j] - X[a][j]) - (X[a + 1][j] - X[a][j]) * (
            X[a + 2][i] - X[a][i]
        )
        if fabs(area) <= bound:
            continue
        side = 1.0 if area > 0 else -1.0
        for k in range(3):
            p, q = a + k, a + (k + 1) % 3
            outside = True
            for c in range(b, b + 3):
                d = (X[q][i] - X[p][i]) * (X[c][j] - X[p][j]) - (X[q][j] - X[p][j]) * (
                    X[c][i] - X[p][i]
                )
                if side * d >= -bound:
                    outside = False
                    break
            if outside:
                return True
    return False


cdef inline bint _apart_in_projection(Corner *X) noexcept nogil:
    """Are triangles X[0:3] and X[3:6] certainly apart in their projection onto one of the
    coordinate planes? Apart there means apart in space (the projection of a common point is
    common to both). Decides the coplanar and perpendicular neighbours that the orientation
    signs in space leave uncertain (triangles of one flat region, or of two flat regions
    meeting at a crease)."""
    return _apart_2d(X, 1, 2) or _apart_2d(X, 2, 0) or _apart_2d(X, 0, 1)


cdef inline int _tri_tri(
    const Mesh *m, int64_t t, int64_t u, bint skip_shared, bint flat_check, Corner *X,
    double *out,
) noexcept nogil:
    """Do triangles t and u meet? `NO`, `CROSS` (a certain crossing, its point written to
    ``out`` (3,)) or `UNSURE`. With ``skip_shared`` (triangles of one shell sharing one
    corner), meeting only at that corner counts as `NO`. With ``flat_check``, an uncertain
    pair that is apart in projection (`_apart_in_projection`) counts as `NO`.

    Two closed triangles meet iff an edge of one meets the other, so six edge tests decide.
    """
    load_corners(m, t, u, X)
    cdef double ext = max3(spread(X, 0), spread(X, 1), spread(X, 2))
    cdef double bound = orient_bound(ext * (1.0 + 1e-12))
    # Cheap rejection: one triangle certainly on one side of the other's plane.
    if _one_side(m, t, u, 0, 3, skip_shared, bound, X):
        return NO
    if _one_side(m, u, t, 3, 0, skip_shared, bound, X):
        return NO
    cdef int result = NO, code, first, a, b, k, e0, e1, ax
    cdef double lam = 0.0
    for first in range(2):
        a = 0 if first == 0 else 3
        b = 3 - a
        for k in range(3):
            e0, e1 = a + k, a + (k + 1) % 3
            code = edge_triangle(X, e0, e1, b, b + 1, b + 2, bound, &lam)
            if code == CROSS:
                for ax in range(3):
                    out[ax] = X[e0][ax] + lam * (X[e1][ax] - X[e0][ax])
                return CROSS
            if code == UNSURE:
                result = UNSURE
    if result == UNSURE and flat_check and _apart_in_projection(X):
        return NO
    return result


cdef inline int _pair_code(
    const Mesh *m, int64_t t, int64_t u, bint same, bint self_contacts, bint everything,
    Corner *X, double *out,
) noexcept nogil:
    """The code of one candidate pair, or -1 when it is not reported (see `pair_scan`)."""
    cdef int a, b, code, shared = 0
    for a in range(3):
        for b in range(3):
            if m.ident[m.F[3 * t + a]] == m.ident[m.F[3 * u + b]]:
                shared += 1
    if everything:
        if shared == 0:
            code = _tri_tri(m, t, u, False, True, X, out)
            return -1 if code == NO else code
        return UNSURE if meets_beyond_shared(m, t, u, X) else -1
    if shared >= 2:
        # Triangles on one edge meet elsewhere only where they fold onto each other.
        if same and not self_contacts:
            return -1
        return UNSURE if meets_beyond_shared(m, t, u, X) else -1
    code = _tri_tri(m, t, u, shared == 1 and same, same, X, out)
    if code == NO:
        return -1
    if code == UNSURE and same:
        if not self_contacts or (shared != 0 and not meets_beyond_shared(m, t, u, X)):
            return -1
    return code


cdef inline int _append(
    Found *found, int64_t t, int64_t u, int code, const double *out
) noexcept nogil:
    """Add a pair (its point read from ``out``); -1 where memory runs out."""
    cdef Py_ssize_t k = found.n, capacity
    cdef void *grown
    if k == found.capacity:
        capacity = 2 * found.capacity + 64
        grown = realloc(found.pairs, 3 * capacity * sizeof(int64_t))
        if grown == NULL:
            return -1
        found.pairs = <int64_t *>grown
        grown = realloc(found.points, 3 * capacity * sizeof(double))
        if grown == NULL:
            return -1
        found.points = <double *>grown
        found.capacity = capacity
    found.pairs[3 * k], found.pairs[3 * k + 1], found.pairs[3 * k + 2] = t, u, code
    found.points[3 * k], found.points[3 * k + 1], found.points[3 * k + 2] = out[0], out[1], out[2]
    found.n = k + 1
    return 0


cdef inline bint _first_shared_cell(
    const Boxes *g, int64_t t, int64_t u, int64_t cell
) noexcept nogil:
    """Do the boxes of t and u overlap in y and z, and is ``cell`` the first cell they share?"""
    cdef const double *lo = g.lo
    cdef const double *hi = g.hi
    if lo[3 * t + 1] > hi[3 * u + 1] or lo[3 * u + 1] > hi[3 * t + 1]:
        return False
    if lo[3 * t + 2] > hi[3 * u + 2] or lo[3 * u + 2] > hi[3 * t + 2]:
        return False
    cdef const int64_t *i0 = g.i0
    cdef int64_t first = (max(i0[3 * t], i0[3 * u]) * g.n1 + max(i0[3 * t + 1], i0[3 * u + 1]))
    return first * g.n2 + max(i0[3 * t + 2], i0[3 * u + 2]) == cell


cdef int _scan_cell(
    const Mesh *m, const Boxes *g, const int64_t *run, Py_ssize_t count, int64_t cell,
    bint self_contacts, bint everything, Corner *X, double *out, Found *found,
) noexcept nogil:
    """Test the pairs of one cell's triangles ``run`` (sorted by lower x) whose first common
    cell it is; -1 where memory runs out."""
    cdef Py_ssize_t p, q
    cdef int64_t t, u
    cdef int code
    for p in range(count):
        t = run[p]
        for q in range(p + 1, count):
            u = run[q]
            # Sweep along x: a cell's later triangles start past t's end.
            if g.lo[3 * u] > g.hi[3 * t]:
                break
            if not _first_shared_cell(g, t, u, cell):
                continue
            code = _pair_code(
                m, t, u, g.shell[t] == g.shell[u], self_contacts, everything, X, out
            )
            if code >= 0 and _append(found, t, u, code, out) < 0:
                return -1
    return 0


cdef int _scan_cells(
    const Mesh *m, const Boxes *g, const int64_t[::1] keys, const int64_t[::1] tris,
    bint self_contacts, bint everything, Found *found,
) noexcept nogil:
    """`_scan_cell` of every run of equal keys; -1 where memory runs out."""
    cdef Corner X[6]
    cdef double out[3]
    out[0] = out[1] = out[2] = 0.0
    cdef Py_ssize_t start = 0, end, total = keys.shape[0]
    while start < total:
        end = start + 1
        while end < total and keys[end] == keys[start]:
            end += 1
        if _scan_cell(
            m, g, &tris[start], end - start, keys[start], self_contacts, everything, X, out,
            found,
        ) < 0:
            return -1
        start = end
    return 0


def pair_scan(mesh, grid, bint self_contacts, bint everything):
    """Test every pair of triangles sharing a grid cell, once (in the first cell they share).

    Parameters
    ----------
    mesh : tuple
        ``(V, F, ident, shell)``: vertices (n, 3) float64, faces (m, 3) int64, the identity of
        every vertex (n,) int64 and the shell of every face (m,) int64, C-contiguous.
    grid : tuple
        ``(lo, hi, i0, n, keys, tris)``: the faces' bounding boxes (m, 3) float64, their first
        cells (m, 3) int64, the cells along each axis (3,) int64, and the (flat cell, face)
        entries sorted by cell, then lower x (k,) int64 each.
    self_contacts, everything : bool
        As `exactgrasp.geometry.crossings` scans.

    Returns
    -------
    t, u, code : numpy.ndarray, shape (k,), int64
        The pairs that matter: certain crossings within one shell, certain or uncertain
        contacts between two shells, and with ``self_contacts`` uncertain contacts within one
        shell too (neighbours included where they may meet beyond their common corners). With
        ``everything``, every pair that may meet anywhere but at the corners (and edge) it
        shares.
    point : numpy.ndarray, shape (k, 3), float64
        A certain crossing's point, NaN for the others.
    """
    cdef const double[:, ::1] V = mesh[0]
    cdef const int64_t[:, ::1] F = mesh[1]
    cdef const int64_t[::1] ident = mesh[2], shell = mesh[3], n = grid[3]
    cdef const double[:, ::1] lo = grid[0], hi = grid[1]
    cdef const int64_t[:, ::1] i0 = grid[2]
    cdef const int64_t[::1] keys = grid[4], tris = grid[5]
    if keys.shape[0] == 0:
        empty = np.empty(0, np.int64)
        return empty, empty.copy(), empty.copy(), np.empty((0, 3))
    cdef Mesh m = Mesh(&V[0, 0], &F[0, 0], &ident[0])
    cdef Boxes g = Boxes(&lo[0, 0], &hi[0, 0], &i0[0, 0], n[1], n[2], &shell[0])
    cdef Found found = Found(NULL, NULL, 0, 0)
    cdef int status
    cdef int64_t[:, ::1] pairs_view
    cdef double[:, ::1] point_view
    try:
        with nogil:
            status = _scan_cells(&m, &g, keys, tris, self_contacts, everything, &found)
        if status < 0:
            raise MemoryError("exactgrasp.geometry.crossings: no memory for the pairs found")
        pairs = np.empty((found.n, 3), np.int64)
        point = np.empty((found.n, 3), np.float64)
        pairs_view, point_view = pairs, point
        if found.n:
            memcpy(&pairs_view[0, 0], found.pairs, 3 * found.n * sizeof(int64_t))
            memcpy(&point_view[0, 0], found.points, 3 * found.n * sizeof(double))
    finally:
        free(found.pairs)
        free(found.points)
    t, u, code = (np.ascontiguousarray(pairs[:, k]) for k in range(3))
    point[code != CROSS] = np.nan
    return t, u, code, point


cdef void _fill_cells(
    const int64_t[:, ::1] i0, const int64_t[:, ::1] i1, int64_t n1, int64_t n2,
    const int64_t[::1] offsets, int64_t[::1] keys, int64_t[::1] tris,
) noexcept nogil:
    """Write the (flat cell, triangle) entries of every triangle's bounding-box cell range."""
    cdef Py_ssize_t f, q
    cdef int64_t i, j, k
    for f in range(i0.shape[0]):
        q = offsets[f]
        for i in range(i0[f, 0], i1[f, 0] + 1):
            for j in range(i0[f, 1], i1[f, 1] + 1):
                for k in range(i0[f, 2], i1[f, 2] + 1):
                    keys[q] = (i * n1 + j) * n2 + k
                    tris[q] = f
                    q += 1


def fill_cells(
    const int64_t[:, ::1] i0, const int64_t[:, ::1] i1, const int64_t[::1] n,
    const int64_t[::1] offsets, int64_t[::1] keys, int64_t[::1] tris,
):
    """Write the grid's entries: every triangle in every cell of its bounding box.

    Parameters
    ----------
    i0, i1 : numpy.ndarray, shape (m, 3), int64
        The first and last cell of each triangle's bounding box along each axis.
    n : numpy.ndarray, shape (3,), int64
        Cells along each axis.
    offsets : numpy.ndarray, shape (m + 1,), int64
        Where each triangle's entries start (cumulative counts of its cells).
    keys, tris : numpy.ndarray, shape (offsets[-1],), int64
        Written: the flat cell ``(i n1 + j) n2 + k`` and the triangle of each entry.

    Returns
    -------
    None
    """
    with nogil:
        _fill_cells(i0, i1, n[1], n[2], offsets, keys, tris)
