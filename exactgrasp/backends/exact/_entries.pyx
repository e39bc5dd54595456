# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""The exact backend's compiled kernels that Python calls outside the per-pose kernel
(`_kernel.pose_volumes`): the grids' rasteriser (`raster_triangles`, for `grids`), the faces'
terms (`face_terms`, for `prepare`), the culling's certain-crossing test (`surfaces_cross`, for
`culling`) and the vertex derivatives' sums (`vertex_sums`, for `face_gradients`). Each runs
its inline kernel (``_cells.pxd``, ``_sums.pxd``, ``_classify.pxd``, ``_face_gradients.pxd``)
without the GIL.
"""

import numpy as np

from libc.stdint cimport int64_t, uint8_t

from exactgrasp.backends.exact cimport _cells, _classify, _face_gradients, _sums
from exactgrasp.backends.exact._tables cimport CellGrid, VertexSums


def raster_triangles(V, F, lo, double h, n, double margin):
    """(cell, triangle) pairs of every triangle touching a grid cell (closed, grown by margin).

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3), float64
        Vertices (length units).
    F : numpy.ndarray, shape (m, 3), int
        Triangles.
    lo : numpy.ndarray, shape (3,)
        Lower corner of cell (0, 0, 0).
    h, margin : float
        Cell edge length, and how far each cell is grown (length units).
    n : numpy.ndarray, shape (3,), int
        Cells per axis.

    Returns
    -------
    cells, triangles : numpy.ndarray, shape (p,), int64
        Flat cell indices and triangle indices, in triangle order (the caller sorts).
    """
    cdef const double[:, ::1] Vv = np.ascontiguousarray(V, np.float64)
    cdef const int64_t[:, ::1] Fv = np.ascontiguousarray(F, np.int64)
    cdef const double[::1] lov = np.ascontiguousarray(lo, np.float64)
    cdef const int64_t[::1] nv = np.ascontiguousarray(n, np.int64)
    cdef int64_t[:, ::1] rng = np.empty((3, 2), np.int64)
    # Room for a first guess at the number of pairs; where that is short, the kernel's count
    # sizes a second pass.
    cdef int64_t count, room = 8 * Fv.shape[0] + 65536
    cells, tris = np.empty(room, np.int64), np.empty(room, np.int64)
    cdef int64_t[::1] cv = cells, tv = tris
    with nogil:
        count = _cells.raster_triangles(Vv, Fv, lov, h, nv, margin, rng, cv, tv)
    if count > room:
        cells, tris = np.empty(count, np.int64), np.empty(count, np.int64)
        cv, tv = cells, tris
        with nogil:
            count = _cells.raster_triangles(Vv, Fv, lov, h, nv, margin, rng, cv, tv)
    return cells[:count], tris[:count]


def face_terms(V, F, double tiny, double[:, ::1] D, double[:, ::1] N):
    """Per face its normal and ``D`` (`_sums.face_terms`), written into ``D`` and ``N``.

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3), float64
        Vertices (length units).
    F : numpy.ndarray, shape (m, 3), int64
        Triangles.
    tiny : float
        ``D`` is zero where ``|N|² <= tiny``.
    D, N : numpy.ndarray, shape (m, 3), float64
        Written: ``D = (N·a) N / |N|²`` and the unnormalised normals ``N``.
    """
    cdef const double[:, ::1] v = np.ascontiguousarray(V)
    cdef const int64_t[:, ::1] f = np.ascontiguousarray(F)
    with nogil:
        _sums.face_terms(v, f, tiny, D, N)


def surfaces_cross(poses, AV, acomp, ancomp, agrid, BV0, bcomp, bncomp, bgrid):
    """Per pose, whether the moved object's surface certainly crosses the hand's: a connected
    shell of either mesh has one vertex in a cell wholly inside the other mesh and another in
    a cell wholly outside it. Such a pose can never be culled, so the broad phase is not asked
    about it (False means "not known", not "apart").

    Parameters
    ----------
    poses : numpy.ndarray, shape (k, 4, 4), float64
        Rigid motions of the object, local coordinates.
    AV, BV0 : numpy.ndarray, shape (n, 3), float64
        The hand's vertices and the object's (in its own frame).
    acomp, bcomp : numpy.ndarray, shape (n,), int64
        Each vertex's shell; ``ancomp``, ``bncomp`` shells in all.
    agrid, bgrid : tables.CellGrid
        The hand's grid and the object's.

    Returns
    -------
    numpy.ndarray, shape (k,), bool
    """
    cdef CellGrid ag = CellGrid(agrid), bg = CellGrid(bgrid)
    out = np.zeros(poses.shape[0], np.bool_)
    aseen = np.zeros((ancomp, 2), np.bool_)
    bseen = np.zeros((bncomp, 2), np.bool_)
    cdef const double[:, :, :] P = poses
    cdef const double[:, ::1] A = AV, B = BV0
    cdef const int64_t[::1] ac = acomp, bc = bcomp
    cdef uint8_t[::1] o = out.view(np.uint8)
    cdef uint8_t[:, ::1] sa = aseen.view(np.uint8), sb = bseen.view(np.uint8)
    with nogil:
        _classify.surfaces_cross(P, A, ac, ag, B, bc, bg, o, sa, sb)
    return out


def vertex_sums(
    begin, end, rows, values, tables, double[:, :, ::1] out_a, double[:, :, ::1] out_b
):
    """Each pose's moments summed onto the vertices (`_face_gradients.vertex_sums`).

    Parameters
    ----------
    begin, end, rows, values : numpy.ndarray
        `moment_entries.MomentEntries` of k poses: each pose's entries (``begin``, ``end``
        (k,)), their rows (t,) and moments (t, 6); local coordinates, the object's in its own
        frame.
    tables : face_gradients.VertexTables
        What each row gives each vertex.
    out_a, out_b : numpy.ndarray, shape (k, n_a, 3) and (k, n_b, 3), float64
        Written, every element: the derivatives by the hand's vertices and by the object's
        (squared length units).
    """
    cdef const int64_t[::1] b = np.ascontiguousarray(begin)
    cdef const int64_t[::1] e = np.ascontiguousarray(end)
    cdef const int64_t[::1] r = np.ascontiguousarray(rows)
    cdef const double[:, ::1] m = np.ascontiguousarray(values)
    cdef VertexSums S = VertexSums(tables)
    with nogil:
        _face_gradients.vertex_sums(b, e, r, m, S, out_a, out_b)
