"""The seeds' filters (numba): the tests `seeds` runs on what a grid cell holds and on each
listed face, before a candidate pair is kept.

Each test may keep what does not cross, never drop what does: its tolerance exceeds its
rounding (and, in the object's frame, the pose's departure from a rotation). Per cell: a run's
bounding sphere (`sphere_meets_cell`) or a segment's piece (`piece_meets_cell`) against the
cell's slab and clipped common box, then the listed faces' clipped boxes (`cell_survivors`);
per face: the plane and edge tests of a segment (`may_cross`). Arrays enter as tuples of a row
(`cell_row`, `filter_row`): an array argument would cost atomic reference-count updates a
call. See "Method", step 2, in ``docs/exact-backend.md``.
"""

from __future__ import annotations

from exactgrasp.backends.exact.tables import (
    BOX_MAX,
    BOX_MIN,
    CELL_AXIS,
    CELL_BOX_MAX,
    CELL_BOX_MIN,
    CELL_SLAB_HIGH,
    CELL_SLAB_LOW,
    FILTER_NORMAL,
    FILTER_OFFSET,
    FILTER_SIDE_COLUMNS,
    FILTER_SIDE_OFFSET,
    FILTER_SIDES,
    LIST_GROUP,
)
from exactgrasp.backends.exact.tolerances import U
from exactgrasp.compiling import inner


@inner(nogil=True, error_model="numpy")
def sphere_meets_cell(row, m, r, margin):
    """Whether the sphere of centre m (x, y, z) and radius r may meet what a cell holds (its
    bounds row ``row``, `cell_row`): the slab along the cell's axis (widened by ``margin``)
    and the clipped common box, with one branch."""
    m0, m1, m2 = m
    a = row[CELL_AXIS] * m0 + row[CELL_AXIS + 1] * m1 + row[CELL_AXIS + 2] * m2
    lo, hi = CELL_BOX_MIN, CELL_BOX_MAX
    return (
        (a - r <= row[CELL_SLAB_HIGH] + margin) & (a + r >= row[CELL_SLAB_LOW] - margin)
        & (row[lo] <= m0 + r) & (row[hi] >= m0 - r)
        & (row[lo + 1] <= m1 + r) & (row[hi + 1] >= m1 - r)
        & (row[lo + 2] <= m2 + r) & (row[hi + 2] >= m2 - r)
    )  # fmt: skip


@inner(nogil=True, error_model="numpy")
def _crossing_point(p, q, dp, dq, eps, ptol, g):
    """Where segment p q (ends (x, y, z)) crosses a plane, from its ends' distances dp, dq
    (opposite signs or within the tolerance ``max(ptol, 2 eps)``, each erring by up to eps),
    and the tolerance of a test of that point against the face's edges
    (`prepare.face_filters`): (fixed, x, y, z, tolerance), ``fixed`` False where the distances
    do not fix the point well enough (the face is then kept). ``g`` bounds every coordinate.
    Scalars only: a routine taking arrays would update their reference counts."""
    px, py, pz = p
    qx, qy, qz = q
    tol = max(ptol, 2.0 * eps)
    span = abs(dp) + abs(dq)
    if span <= 4.0 * tol:
        return False, 0.0, 0.0, 0.0, 0.0
    lam = dp / (dp - dq)
    dx, dy, dz = qx - px, qy - py, qz - pz
    # The parameter errs by at most 4 eps / span (`pairs.param_err`), the point by that times
    # the segment's extent plus rounding; the edge distances by about a plane distance's error.
    xerr = (4.0 * eps / span + 4.0 * U) * max(abs(dx), abs(dy), abs(dz)) + 6.0 * U * g
    return True, px + lam * dx, py + lam * dy, pz + lam * dz, 4.0 * eps + 2.0 * xerr + ptol


@inner(nogil=True, error_model="numpy")
def _filter_dot(row, column, x, y, z):
    """``normal · x`` of the filter normal (3) at ``column`` of a face's filter row ``row``."""
    return row[column] * x + row[column + 1] * y + row[column + 2] * z


@inner(nogil=True, error_model="numpy")
def may_cross(row, p, q, eps, ptol, g):
    """Whether segment p q (ends (x, y, z)) may cross a face whose filter row
    (`prepare.face_filters`, columns ``FILTER_*``) is ``row``, a tuple of its values: False
    only where both ends lie beyond the tolerance ``max(ptol, 2 eps)`` on one side of its
    plane, or where the crossing point lies beyond its tolerance outside one of its edges.
    ``eps`` bounds a plane distance's error, ``g`` every coordinate. A tuple, not the filters'
    array: an array argument would cost two atomic reference-count updates a call."""
    dp = _filter_dot(row, FILTER_NORMAL, p[0], p[1], p[2]) - row[FILTER_OFFSET]
    dq = _filter_dot(row, FILTER_NORMAL, q[0], q[1], q[2]) - row[FILTER_OFFSET]
    tol = max(ptol, 2.0 * eps)
    if ((dp > tol) & (dq > tol)) | ((dp < -tol) & (dq < -tol)):
        return False
    fixed, x, y, z, st = _crossing_point(p, q, dp, dq, eps, ptol, g)
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


@inner(nogil=True, error_model="numpy")
def filter_row(FL, f):
    """Row f of the filters (m, `FILTER_COLUMNS`) as a tuple, for `may_cross`."""
    return (
        FL[f, 0], FL[f, 1], FL[f, 2], FL[f, 3], FL[f, 4], FL[f, 5], FL[f, 6], FL[f, 7],
        FL[f, 8], FL[f, 9], FL[f, 10], FL[f, 11], FL[f, 12], FL[f, 13], FL[f, 14], FL[f, 15],
    )  # fmt: skip


@inner(nogil=True, error_model="numpy")
def cell_row(PT, c):
    """Row c of a grid's cell bounds (`tables.CellGrid.bounds`, `CELL_BOUNDS_COLUMNS` values)
    as a tuple, for `piece_meets_cell`."""
    return (
        PT[c, 0], PT[c, 1], PT[c, 2], PT[c, 3], PT[c, 4], PT[c, 5], PT[c, 6], PT[c, 7],
        PT[c, 8], PT[c, 9], PT[c, 10],
    )  # fmt: skip


@inner(nogil=True, error_model="numpy")
def piece_box(a, b, grow):
    """The box of the piece a b of a segment (ends (x, y, z)), grown by ``grow``: (lower
    corner, upper corner)."""
    ax, ay, az = a
    bx, by, bz = b
    x0, x1 = min(ax, bx) - grow, max(ax, bx) + grow
    y0, y1 = min(ay, by) - grow, max(ay, by) + grow
    z0, z1 = min(az, bz) - grow, max(az, bz) + grow
    return (x0, y0, z0), (x1, y1, z1)


@inner(nogil=True, error_model="numpy")
def piece_meets_cell(row, a, b, box, tol):
    """Whether the piece a b of a segment (its box ``box``, already grown) may meet what a cell
    holds of its faces: their clipped common box and the slab ``row[CELL_SLAB_LOW] - tol <= n·x
    <= row[CELL_SLAB_HIGH] + tol`` along the direction ``n`` at ``row[CELL_AXIS]`` (the cell's
    bounds row, `cell_row`), with one branch. A tuple, not the bounds' array: an array
    argument would cost atomic reference-count updates a call."""
    (x0, y0, z0), (x1, y1, z1) = box
    ax, ay, az = a
    bx, by, bz = b
    n0, n1, n2 = row[CELL_AXIS], row[CELL_AXIS + 1], row[CELL_AXIS + 2]
    pa = n0 * ax + n1 * ay + n2 * az
    pb = n0 * bx + n1 * by + n2 * bz
    lo, hi = CELL_BOX_MIN, CELL_BOX_MAX
    return (
        (row[lo] <= x1) & (row[hi] >= x0) & (row[lo + 1] <= y1) & (row[hi + 1] >= y0)
        & (row[lo + 2] <= z1) & (row[hi + 2] >= z0)
        & (min(pa, pb) <= row[CELL_SLAB_HIGH] + tol) & (max(pa, pb) >= row[CELL_SLAB_LOW] - tol)
    )  # fmt: skip


@inner(nogil=True, error_model="numpy")
def box_meets(B, i, box):
    """Whether box row i of ``B`` (columns `BOX_MIN`, `BOX_MAX`) meets ``box`` (lower corner,
    upper corner), with one branch."""
    (x0, y0, z0), (x1, y1, z1) = box
    lo, hi = BOX_MIN, BOX_MAX
    return (
        (B[i, lo] <= x1) & (B[i, hi] >= x0) & (B[i, lo + 1] <= y1) & (B[i, hi + 1] >= y0)
        & (B[i, lo + 2] <= z1) & (B[i, hi + 2] >= z0)
    )  # fmt: skip


# Compiled into each search (numba inlines it before typing): called per cell with five
# arrays, it would otherwise stay a call that LLVM does not inline.
@inner(nogil=True, error_model="numpy", inline="always")
def cell_survivors(cs, gs, GB, CBB, c, box, buf):
    """The entries of cell c's list (`tables.CellGrid`) whose clipped boxes meet ``box`` (lower
    corner, upper corner; ``cs``, ``gs``, ``GB``, ``CBB``: the grid's ``cell_start``,
    ``group_start``, ``groups`` and ``boxes``): the list's groups' boxes first, then the boxes
    of the groups that meet it, each comparison evaluated in full and decided with one branch.
    The entries go to ``buf``; returns how many."""
    m = 0
    for g in range(gs[c], gs[c + 1]):
        if not box_meets(GB, g, box):
            continue
        q0 = cs[c] + LIST_GROUP * (g - gs[c])
        for q in range(q0, min(q0 + LIST_GROUP, cs[c + 1])):
            buf[m] = q
            m += 1 if box_meets(CBB, q, box) else 0
    return m
