# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""Single stages of the compiled exact kernel, callable from Python: the tests check each
against a reference of its own (numpy's stable sort, winding numbers, a linear programme, a
cell's known status). The kernel itself never calls these wrappers; each runs its inline
function without the GIL.
"""

import numpy as np

from libc.stdint cimport int8_t, int64_t, uint8_t

from exactgrasp.backends.exact cimport _cells, _classify, _predicates, _sums
from exactgrasp.backends.exact._tables cimport CellGrid


def order_by_key(keys):
    """The order that sorts ``keys`` (n,) int64 by (key, position), as the crossed-edge sum
    groups its records (`_sums._order_by_key`).

    Returns
    -------
    numpy.ndarray, shape (n,), int64
    """
    cdef int64_t[::1] key = np.array(keys, np.int64)
    order = np.arange(key.shape[0], dtype=np.int64)
    cdef int64_t[::1] o = order
    with nogil:
        _sums._order_by_key(key, o, key.shape[0])
    return order


def hand_statuses(S, V, R, t, grid, reps, crossed, bint whole, uniform, double err):
    """The hand's vertices' statuses in the object's grid, part by part
    (`_classify.hand_statuses`), written into ``S`` (n,) int8 and ``uniform`` (parts,) bool.

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3), float64
        The hand's vertices, moved into the object's frame by ``x -> R^T (x - t)``.
    R, t : numpy.ndarray, shape (3, 3) and (3,)
    grid : tables.CellGrid
    reps, crossed : numpy.ndarray
        The parts (as `tables.HandTables.parts`) and whether each part's own edges are crossed.
    whole : bool
        Whether parts none of whose edges is crossed are classified whole.
    err : float
        How far a vertex may lie from where it is computed (length units).
    """
    cdef CellGrid g = CellGrid(grid)
    cdef int8_t[::1] s = S
    cdef double[:, ::1] v = V
    cdef const double[:, :] r = np.asarray(R, np.float64)
    cdef const double[:] tt = np.asarray(t, np.float64)
    cdef int64_t[:, ::1] p = reps
    cdef uint8_t[::1] c = crossed.view(np.uint8), u = uniform.view(np.uint8)
    with nogil:
        _classify.hand_statuses(s, v, r, tt, g, p, c, whole, u, err)


def ray_status(x, V, F, grid, fstamp, int64_t token, double xerr):
    """Inside (1), outside (0) or unknown (-1) of point ``x`` (3,) against the closed mesh
    ``V`` (n, 3), ``F`` (m, 3), by the exact point test (`_classify.ray_status`).

    Returns
    -------
    int
    """
    cdef double[::1] p = np.array(x, np.float64)
    cdef double[:, ::1] v = V
    cdef int64_t[:, ::1] f = F
    cdef CellGrid g = CellGrid(grid)
    cdef int64_t[::1] stamp = fstamp
    cdef int64_t status
    with nogil:
        status = _classify.ray_status(p, v, f, g, stamp, token, xerr)
    return status


def point_status(x, lo, double h, n, status):
    """Inside (1) / outside (0) from a grid's cell statuses, or -1 in a surface cell
    (`_cells.point_status`).

    Returns
    -------
    int
    """
    cdef const double[::1] p = np.array(x, np.float64)
    cdef const double[::1] corner = np.asarray(lo, np.float64)
    cdef const int64_t[::1] shape = np.asarray(n, np.int64)
    cdef const int64_t[::1] cells = np.asarray(status, np.int64)
    cdef int64_t got
    with nogil:
        got = _cells.point_status(p, corner, h, shape, cells)
    return got


def tri_box_xyz(
    double cx, double cy, double cz, double hx, double hy, double hz, double ax, double ay,
    double az, double bx, double by, double bz, double qx, double qy, double qz,
):
    """Whether a triangle touches a box of centre ``c*`` and half sizes ``h*``
    (`_predicates.tri_box_xyz`).

    Returns
    -------
    bool
    """
    cdef bint touches
    with nogil:
        touches = _predicates.tri_box_xyz(
            cx, cy, cz, hx, hy, hz, ax, ay, az, bx, by, bz, qx, qy, qz
        )
    return touches
