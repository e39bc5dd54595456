# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""Certified tests of one pair of triangles, for the compiled crossings kernel
(``_crossings.pyx``; Cython, inline).

Orientation signs come with Shewchuk's static error bound (``_predicates.pxd``): a sign within
the bound is 0, *uncertain*. `edge_triangle` asks whether a segment meets a triangle;
`meets_beyond_shared` asks whether two triangles that share one or two corners (by identity:
copies of one point count as one) meet anywhere else, which is what decides whether neighbours
in a flat region touch only along their common edge or corner. Each answer is either certain or
"maybe", never a wrong "no". The six corners of a pair are rows of a scratch array ``X``
(6 x 3): scalar loads, no array views in the hot loop.
"""

from libc.stdint cimport int64_t

from exactgrasp.geometry._minmax cimport max2, max3
from exactgrasp.geometry._predicates cimport certain_sign, orient_bound, orient_det

# Result codes of a pair test: certainly apart, certainly crossing, or uncertain
# (`exactgrasp.geometry.crossings` names them for Python).
cdef enum:
    NO = 0
    CROSS = 1
    UNSURE = 2

ctypedef double Corner[3]

# A mesh as the kernels read it: row-major arrays, C-contiguous.
ctypedef struct Mesh:
    const double *V  # vertices (n, 3)
    const int64_t *F  # faces (m, 3)
    const int64_t *ident  # (n,): vertices of one identity are one point


cdef inline void load_corners(const Mesh *m, int64_t t, int64_t u, Corner *X) noexcept nogil:
    """Rows 0-2 of ``X``: the corners of triangle t; rows 3-5: those of u."""
    cdef int k, ax
    for k in range(3):
        for ax in range(3):
            X[k][ax] = m.V[3 * m.F[3 * t + k] + ax]
            X[k + 3][ax] = m.V[3 * m.F[3 * u + k] + ax]


cdef inline double spread(Corner *X, int ax) noexcept nogil:
    """Extent of the six corners along axis ``ax``."""
    cdef double lo = X[0][ax], hi = lo
    cdef int k
    for k in range(1, 6):
        if X[k][ax] < lo:
            lo = X[k][ax]
        if X[k][ax] > hi:
            hi = X[k][ax]
    return hi - lo


cdef inline double orient_rows(Corner *X, int a, int b, int c, int d) noexcept nogil:
    """`orient_det` of rows a, b, c, d of ``X``."""
    return orient_det(X[a][0], X[a][1], X[a][2], X[b][0], X[b][1], X[b][2],
                      X[c][0], X[c][1], X[c][2], X[d][0], X[d][1], X[d][2])


cdef inline int edge_triangle(
    Corner *X, int e0, int e1, int a, int b, int c, double bound, double *lam
) noexcept nogil:
    """Does the closed segment from corner ``e0`` to ``e1`` meet the closed triangle of
    corners ``a, b, c``? `NO` (certainly not), `CROSS` (certainly, through the triangle's
    interior, at ``X[e0] + lam (X[e1] - X[e0])``, ``lam`` written) or `UNSURE`."""
    cdef double dp = orient_rows(X, a, b, c, e0)
    cdef double dq = orient_rows(X, a, b, c, e1)
    cdef int sp = certain_sign(dp, bound), sq = certain_sign(dq, bound)
    if sp != 0 and sp == sq:
        return NO
    cdef int s1 = certain_sign(orient_rows(X, e0, e1, a, b), bound)
    cdef int s2 = certain_sign(orient_rows(X, e0, e1, b, c), bound)
    cdef int s3 = certain_sign(orient_rows(X, e0, e1, c, a), bound)
    if (s1 > 0 or s2 > 0 or s3 > 0) and (s1 < 0 or s2 < 0 or s3 < 0):
        return NO
    if sp == 0 or sq == 0 or s1 == 0 or s2 == 0 or s3 == 0:
        return UNSURE
    lam[0] = dp / (dp - dq)
    return CROSS


cdef inline int turn(
    Corner *X, int p, int q, int r, int i, int j, double bound
) noexcept nogil:
    """Certain sign of the turn p -> q -> r of rows of ``X`` in the coordinates (i, j)."""
    cdef double det = (X[q][i] - X[p][i]) * (X[r][j] - X[p][j]) - (X[q][j] - X[p][j]) * (
        X[r][i] - X[p][i]
    )
    return certain_sign(det, bound)


cdef inline int corner(int mask, int n, int shared) noexcept nogil:
    """Index of the n-th corner (0, 1, 2) whose bit in ``mask`` is ``shared`` (1 or 0), or
    -1."""
    cdef int k, seen = 0
    for k in range(3):
        if (mask >> k & 1) == shared:
            if seen == n:
                return k
            seen += 1
    return -1


cdef inline bint rays_outside(
    Corner *X, int p, int a, int b, int c, int d, int i, int j, double bound
) noexcept nogil:
    """Are the rays from corner p through c and through d certainly outside the closed cone
    from p spanned by a and b (an angle of a flat triangle, so under half a turn)? A corner
    seen exactly at p (its triangle edge-on) adds no ray."""
    cdef int s = turn(X, p, a, b, i, j, bound)
    cdef int r, k
    for k in range(2):
        r = c if k == 0 else d
        if X[r][i] == X[p][i] and X[r][j] == X[p][j]:
            continue
        if turn(X, p, a, r, i, j, bound) != -s and turn(X, p, r, b, i, j, bound) != -s:
            return False
    return True


cdef inline bint apart_but_shared_2d(
    Corner *X, int mask_t, int mask_u, int shared
) noexcept nogil:
    """Are triangles X[0:3] and X[3:6], sharing the corners in the bit masks (one or two),
    certainly apart but for those corners in a projection onto a coordinate plane that keeps
    one of them flat (so that meeting only there in projection means only there in space)?
    Across a shared edge: the free corners on opposite sides of it. At a shared corner: the
    projections are cones from it, which meet beyond it only if a bounding ray of one lies in
    the other (a cone seen edge-on is its rays)."""
    cdef int p = corner(mask_t, 0, 1)
    cdef int r0 = corner(mask_t, 0, 0), r1 = corner(mask_t, 1, 0)
    cdef int v0 = corner(mask_u, 0, 0) + 3, v1 = corner(mask_u, 1, 0) + 3
    cdef int k, i, j, q, s1, s2
    cdef double ext, bound
    cdef bint flat_t, flat_u
    for k in range(3):  # the planes (y, z), (z, x), (x, y)
        i, j = (k + 1) % 3, (k + 2) % 3
        ext = max2(spread(X, i), spread(X, j))
        # Rounding of a 2D orientation determinant is below 4 eps times its terms, 2 L^2.
        bound = 1e-14 * ext * ext
        flat_t = turn(X, 0, 1, 2, i, j, bound) != 0
        flat_u = turn(X, 3, 4, 5, i, j, bound) != 0
        if not flat_t and not flat_u:
            continue
        if shared == 2:
            q = corner(mask_t, 1, 1)
            s1 = turn(X, p, q, r0, i, j, bound)
            s2 = turn(X, p, q, v0, i, j, bound)
            if s1 != 0 and s2 != 0 and s1 != s2:
                return True
            continue
        if flat_t and not rays_outside(X, p, r0, r1, v0, v1, i, j, bound):
            continue
        if flat_u and not rays_outside(X, p, v0, v1, r0, r1, i, j, bound):
            continue
        return True
    return False


cdef inline int shared_masks(
    const Mesh *m, int64_t t, int64_t u, int *mask_t, int *mask_u
) noexcept nogil:
    """Bit masks of the corners of t and of u that share an identity; returns how many of
    t's do, or -1 where the two counts differ (a repeated corner)."""
    cdef int a, b
    mask_t[0] = 0
    mask_u[0] = 0
    for a in range(3):
        for b in range(3):
            if m.ident[m.F[3 * t + a]] == m.ident[m.F[3 * u + b]]:
                mask_t[0] |= 1 << a
                mask_u[0] |= 1 << b
    cdef int shared = (mask_t[0] & 1) + (mask_t[0] >> 1 & 1) + (mask_t[0] >> 2 & 1)
    cdef int shared_u = (mask_u[0] & 1) + (mask_u[0] >> 1 & 1) + (mask_u[0] >> 2 & 1)
    return shared if shared == shared_u else -1


cdef inline bint free_corners_split(
    Corner *X, int a, int b, int mask, double bound, bint *off
) noexcept nogil:
    """Are the free corners (bit 0 in ``mask``) of the triangle in rows b..b+2 not certainly
    on one side of the plane of rows a..a+2? ``off`` is cleared where one lies within the
    bound of it."""
    cdef int k, s, side = 0
    cdef bint split = False
    for k in range(3):
        if mask >> k & 1:
            continue
        s = certain_sign(orient_rows(X, a, a + 1, a + 2, b + k), bound)
        if s == 0:
            off[0] = False
            split = True
        elif side != 0 and s != side:
            split = True
        else:
            side = s
    return split


cdef inline bint meets_beyond_shared(
    const Mesh *m, int64_t t, int64_t u, Corner *X
) noexcept nogil:
    """Might triangles t and u, which share corners by identity, meet anywhere but at those
    corners (and the edge between two of them)? False only when certainly not."""
    cdef int mask_t, mask_u
    cdef int shared = shared_masks(m, t, u, &mask_t, &mask_u)
    if shared <= 0 or shared == 3:
        return True  # a repeated corner, or the same three points: for exact arithmetic
    load_corners(m, t, u, X)
    cdef double ext = max3(spread(X, 0), spread(X, 1), spread(X, 2))
    cdef double bound = orient_bound(ext * (1.0 + 1e-12))
    cdef bint off = True  # every unshared corner certainly off the other's plane
    if not free_corners_split(X, 0, 3, mask_u, bound, &off):
        return False  # u's free corners certainly on one side of t's plane
    if not free_corners_split(X, 3, 0, mask_t, bound, &off):
        return False
    cdef int c1, c2
    cdef double lam
    if shared == 1 and off:
        # Then they meet beyond the corner only if an edge opposite it meets the other.
        c1 = edge_triangle(X, corner(mask_t, 0, 0), corner(mask_t, 1, 0), 3, 4, 5, bound, &lam)
        c2 = edge_triangle(
            X, corner(mask_u, 0, 0) + 3, corner(mask_u, 1, 0) + 3, 0, 1, 2, bound, &lam
        )
        return c1 != NO or c2 != NO
    return not apart_but_shared_2d(X, mask_t, mask_u, shared)
