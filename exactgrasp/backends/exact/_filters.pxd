# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""The seeds' filters (Cython, inline): the tests `_seeds` runs on what a grid cell holds and
on each listed face, before a candidate pair is kept.

Each test may keep what does not cross, never drop what does: its tolerance exceeds its
rounding (and, in the object's frame, the pose's departure from a rotation). Per cell: a run's
bounding sphere (`sphere_meets_cell`) or a segment's piece (`piece_meets_cell`) against the
cell's slab and clipped common box, then the listed faces' clipped boxes (`cell_survivors`),
and against an object edge's piece itself (`piece_survivors`); per face: the plane and edge
tests of a segment (`may_cross`). A cell's bounds row and a face's filter row enter as
pointers to their first value (`cell_row`, `filter_row`), points and boxes as their
coordinates. See "Method", step 2, in ``docs/exact-backend.md``.
"""

from libc.math cimport fabs
from libc.stdint cimport int64_t

from exactgrasp.backends.exact._constants cimport (
    BOX_MAX, BOX_MIN, CELL_AXIS, CELL_BOX_MAX, CELL_BOX_MIN, CELL_SLAB_HIGH, CELL_SLAB_LOW,
    FILTER_NORMAL, FILTER_OFFSET, FILTER_SIDE_COLUMNS, FILTER_SIDE_OFFSET, FILTER_SIDES,
    LIST_GROUP, U,
)
from exactgrasp.geometry._minmax cimport max2, max3, min2


cdef inline bint sphere_meets_cell(
    const double *row, double m0, double m1, double m2, double r, double margin
) noexcept nogil:
    """Whether the sphere of centre (m0, m1, m2) and radius r may meet what a cell holds (its
    bounds row ``row``, `cell_row`): the slab along the cell's axis (widened by ``margin``)
    and the clipped common box, with one branch."""
    cdef double a = row[CELL_AXIS] * m0 + row[CELL_AXIS + 1] * m1 + row[CELL_AXIS + 2] * m2
    cdef int lo = CELL_BOX_MIN, hi = CELL_BOX_MAX
    return (
        (a - r <= row[CELL_SLAB_HIGH] + margin) & (a + r >= row[CELL_SLAB_LOW] - margin)
        & (row[lo] <= m0 + r) & (row[hi] >= m0 - r)
        & (row[lo + 1] <= m1 + r) & (row[hi + 1] >= m1 - r)
        & (row[lo + 2] <= m2 + r) & (row[hi + 2] >= m2 - r)
    )


ctypedef (bint, double, double, double, double) CrossingPoint
ctypedef (double, double, double, double, double, double) Box


cdef inline CrossingPoint _crossing_point(
    double px, double py, double pz, double qx, double qy, double qz, double dp, double dq,
    double eps, double ptol, double g,
) noexcept nogil:
    """Where segment p q crosses a plane, from its ends' distances dp, dq (opposite signs or
    within the tolerance ``max(ptol, 2 eps)``, each erring by up to eps), and the tolerance of
    a test of that point against the face's edges (`prepare.face_filters`): (fixed, x, y, z,
    tolerance), ``fixed`` False where the distances do not fix the point well enough (the face
    is then kept). ``g`` bounds every coordinate."""
    cdef double tol = max2(ptol, 2.0 * eps)
    cdef double span = fabs(dp) + fabs(dq)
    cdef double lam, dx, dy, dz, xerr
    if span <= 4.0 * tol:
        return False, 0.0, 0.0, 0.0, 0.0
    lam = dp / (dp - dq)
    dx, dy, dz = qx - px, qy - py, qz - pz
    # The parameter errs by at most 4 eps / span (`_pairs.param_err`), the point by that times
    # the segment's extent plus rounding; the edge distances by about a plane distance's error.
    xerr = (4.0 * eps / span + 4.0 * U) * max3(fabs(dx), fabs(dy), fabs(dz)) + 6.0 * U * g
    return True, px + lam * dx, py + lam * dy, pz + lam * dz, 4.0 * eps + 2.0 * xerr + ptol


cdef inline double _filter_dot(
    const float *row, int column, double x, double y, double z
) noexcept nogil:
    """``normal · x`` of the filter normal (3) at ``column`` of a face's filter row ``row``
    (float32 values, each widened to double before its product)."""
    return row[column] * x + row[column + 1] * y + row[column + 2] * z


cdef inline bint may_cross(
    const float *row, double px, double py, double pz, double qx, double qy, double qz,
    double eps, double ptol, double g,
) noexcept nogil:
    """Whether segment p q may cross a face whose filter row (`prepare.face_filters`, columns
    ``FILTER_*``, `filter_row`) is ``row``: False only where both ends lie beyond the tolerance
    ``max(ptol, 2 eps)`` on one side of its plane, or where the crossing point lies beyond its
    tolerance outside one of its edges. ``eps`` bounds a plane distance's error, ``g`` every
    coordinate."""
    cdef double dp = _filter_dot(row, FILTER_NORMAL, px, py, pz) - row[FILTER_OFFSET]
    cdef double dq = _filter_dot(row, FILTER_NORMAL, qx, qy, qz) - row[FILTER_OFFSET]
    cdef double tol = max2(ptol, 2.0 * eps)
    cdef bint fixed
    cdef double x, y, z, st
    cdef int s0, s1, s2
    if ((dp > tol) & (dq > tol)) | ((dp < -tol) & (dq < -tol)):
        return False
    fixed, x, y, z, st = _crossing_point(px, py, pz, qx, qy, qz, dp, dq, eps, ptol, g)
    # Corner k's edge: its normal from FILTER_SIDES + FILTER_SIDE_COLUMNS k, then its offset.
    s0 = FILTER_SIDES
    s1 = FILTER_SIDES + FILTER_SIDE_COLUMNS
    s2 = FILTER_SIDES + 2 * FILTER_SIDE_COLUMNS
    return not (
        fixed
        and (
            (_filter_dot(row, s0, x, y, z) < row[s0 + FILTER_SIDE_OFFSET] - st)
            | (_filter_dot(row, s1, x, y, z) < row[s1 + FILTER_SIDE_OFFSET] - st)
            | (_filter_dot(row, s2, x, y, z) < row[s2 + FILTER_SIDE_OFFSET] - st)
        )
    )


cdef inline const float *filter_row(const float[:, ::1] FL, int64_t f) noexcept nogil:
    """Row f of the filters (m, `FILTER_COLUMNS`), for `may_cross`."""
    return &FL[f, 0]


cdef inline const double *cell_row(const double[:, ::1] PT, int64_t c) noexcept nogil:
    """Row c of a grid's cell bounds (`tables.CellGrid.bounds`, `CELL_BOUNDS_COLUMNS` values),
    for `piece_meets_cell` and `sphere_meets_cell`."""
    return &PT[c, 0]


cdef inline Box piece_box(
    double ax, double ay, double az, double bx, double by, double bz, double grow
) noexcept nogil:
    """The box of the piece a b of a segment, grown by ``grow``: (x0, y0, z0, x1, y1, z1),
    lower corner then upper corner."""
    return (
        min2(ax, bx) - grow, min2(ay, by) - grow, min2(az, bz) - grow,
        max2(ax, bx) + grow, max2(ay, by) + grow, max2(az, bz) + grow,
    )


cdef inline bint piece_meets_cell(
    const double *row, double ax, double ay, double az, double bx, double by, double bz,
    double x0, double y0, double z0, double x1, double y1, double z1, double tol,
) noexcept nogil:
    """Whether the piece a b of a segment (its box (x0, y0, z0, x1, y1, z1), already grown) may
    meet what a cell holds of its faces: their clipped common box and the slab
    ``row[CELL_SLAB_LOW] - tol <= n·x <= row[CELL_SLAB_HIGH] + tol`` along the direction ``n``
    at ``row[CELL_AXIS]`` (the cell's bounds row, `cell_row`), with one branch."""
    cdef double n0 = row[CELL_AXIS], n1 = row[CELL_AXIS + 1], n2 = row[CELL_AXIS + 2]
    cdef double pa = n0 * ax + n1 * ay + n2 * az
    cdef double pb = n0 * bx + n1 * by + n2 * bz
    cdef int lo = CELL_BOX_MIN, hi = CELL_BOX_MAX
    return (
        (row[lo] <= x1) & (row[hi] >= x0) & (row[lo + 1] <= y1) & (row[hi + 1] >= y0)
        & (row[lo + 2] <= z1) & (row[hi + 2] >= z0)
        & (min2(pa, pb) <= row[CELL_SLAB_HIGH] + tol)
        & (max2(pa, pb) >= row[CELL_SLAB_LOW] - tol)
    )


cdef inline bint box_meets(
    const float *row, double x0, double y0, double z0, double x1, double y1, double z1
) noexcept nogil:
    """Whether the box of row ``row`` (a pointer to its first value; float32, columns
    `BOX_MIN`, `BOX_MAX`) meets the box (x0, y0, z0, x1, y1, z1) (lower corner, upper corner),
    with one branch."""
    cdef int lo = BOX_MIN, hi = BOX_MAX
    return (
        (row[lo] <= x1) & (row[hi] >= x0) & (row[lo + 1] <= y1) & (row[hi + 1] >= y0)
        & (row[lo + 2] <= z1) & (row[hi + 2] >= z0)
    )


cdef inline int64_t cell_survivors(
    const int64_t[::1] cs, const int64_t[::1] gs, const float[:, ::1] GB,
    const float[:, ::1] CBB, int64_t c, double x0, double y0, double z0, double x1, double y1,
    double z1, int64_t[::1] buf,
) noexcept nogil:
    """The entries of cell c's list (`tables.CellGrid`) whose clipped boxes meet the box
    (x0, y0, z0, x1, y1, z1) (``cs``, ``gs``, ``GB``, ``CBB``: the grid's ``cell_start``,
    ``group_start``, ``groups`` and ``boxes``): the list's groups' boxes first, then the boxes
    of the groups that meet it, each comparison evaluated in full and decided with one branch.
    The entries go to ``buf``; returns how many."""
    # Base pointers and row lengths read once (stores to ``buf`` could alias them otherwise).
    cdef const float *groups = &GB[0, 0]
    cdef const float *boxes = &CBB[0, 0]
    cdef int64_t *out = &buf[0]
    cdef int64_t gw = GB.shape[1], bw = CBB.shape[1]
    cdef int64_t g0 = gs[c], g1 = gs[c + 1], start = cs[c], end = cs[c + 1]
    cdef int64_t m = 0, g, q, q0, q1
    for g in range(g0, g1):
        if not box_meets(groups + g * gw, x0, y0, z0, x1, y1, z1):
            continue
        q0 = start + LIST_GROUP * (g - g0)
        q1 = q0 + LIST_GROUP
        if end < q1:
            q1 = end
        for q in range(q0, q1):
            out[m] = q
            m += 1 if box_meets(boxes + q * bw, x0, y0, z0, x1, y1, z1) else 0
    return m


cdef inline int64_t piece_survivors(
    const float[:, ::1] CBB, int64_t[::1] buf, int64_t m, double ax_, double ay_, double az_,
    double bx_, double by_, double bz_, double margin,
) noexcept nogil:
    """The first ``m`` entries of ``buf`` (rows of a grid's ``boxes`` ``CBB``, float32, as
    `cell_survivors` leaves them) against the piece a b of a segment itself, not its box: the
    three axes d × e_k separating a segment from a box, with one branch each (``margin``
    widens them). The entries kept stay first in ``buf``; returns how many."""
    cdef double dx_ = bx_ - ax_, dy_ = by_ - ay_, dz_ = bz_ - az_
    cdef double adx = fabs(dx_), ady = fabs(dy_), adz = fabs(dz_)
    cdef double slack = 4.0 * margin * (adx + ady + adz)
    cdef double hx, hy, hz, cx, cy, cz
    cdef const float *boxes = &CBB[0, 0]
    cdef const float *row
    cdef int64_t *out = &buf[0]
    cdef int64_t bw = CBB.shape[1]
    cdef int64_t j, q, kept = 0
    cdef bint apart
    for j in range(m):
        q = out[j]
        row = boxes + q * bw
        # Sums and differences of two float32 values stay float32 (as numba kept them).
        hx = 0.5 * <float>(row[BOX_MAX] - row[BOX_MIN])
        hy = 0.5 * <float>(row[BOX_MAX + 1] - row[BOX_MIN + 1])
        hz = 0.5 * <float>(row[BOX_MAX + 2] - row[BOX_MIN + 2])
        cx = 0.5 * <float>(row[BOX_MAX] + row[BOX_MIN]) - ax_
        cy = 0.5 * <float>(row[BOX_MAX + 1] + row[BOX_MIN + 1]) - ay_
        cz = 0.5 * <float>(row[BOX_MAX + 2] + row[BOX_MIN + 2]) - az_
        apart = (
            (fabs(dz_ * cy - dy_ * cz) > adz * hy + ady * hz + slack)
            | (fabs(dx_ * cz - dz_ * cx) > adz * hx + adx * hz + slack)
            | (fabs(dy_ * cx - dx_ * cy) > ady * hx + adx * hy + slack)
        )
        out[kept] = q
        kept += 0 if apart else 1
    return kept
