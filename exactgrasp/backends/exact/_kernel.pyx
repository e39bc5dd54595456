# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
# cython: cdivision=True, cpow=True
"""The exact kernel, compiled: hand ∩ moved object for a batch of poses (`pose_volumes`). The
exact backend's other compiled entries are ``_entries.pyx``.

`pose_volumes` runs its poses, each pose's stages (``_pose.pxd`` and the modules it cimports),
without the GIL from the first pose to the last; it takes the GIL only to grow a table a pose
filled and the moment entries' arrays. ``_kernel_avx2.pyx`` compiles this same source for
CPUs with AVX2. The tables are the named tuples of `tables`, read
through the extension types of ``_tables.pxd``. It gives, to the bit, what the numba kernel it
replaced gave (``tests/test_exact_kernel_goldens.py``).
"""

import numpy as np

from libc.stdint cimport int64_t

from exactgrasp.backends.exact import tables as named
from exactgrasp.backends.exact._constants cimport (
    GROW,
    LENGTH_FLOOR,
    MOMENT_COLUMNS,
    OK,
    OVERFLOW,
    POINT_COLUMNS,
    SEGMENT_COLUMNS,
    STAT_CROSSING,
    STAT_PAIRS,
)
from exactgrasp.backends.exact._classify cimport classify_vertices
from exactgrasp.backends.exact._face_gradients cimport pose_sums, zero_pose
from exactgrasp.backends.exact._pose cimport (
    cell_stats,
    clear_records,
    copy_rows,
    move_object,
    near_pass,
    pose_moments,
    vertex_bound,
)
from exactgrasp.backends.exact._search cimport trace_pairs
from exactgrasp.backends.exact._seeds cimport cotree_seeds, object_edge_seeds
from exactgrasp.backends.exact._sums cimport volume_sum
from exactgrasp.backends.exact._tables cimport (
    CellGrid,
    HandTables,
    MeshTables,
    MomentRows,
    MomentTables,
    ObjectTables,
    PoseScratch,
    VertexSums,
    Workspace,
)
from exactgrasp.geometry._minmax cimport max2

#: First size of the pair table (a power of two) and of the seed buffer; both double when a
#: pose needs more (the pose is then computed again).
PAIR_TABLE, SEED_ROWS = 2**14, 2**13
#: Rows of moments a call's output holds at first, per pose (it grows when full).
ROWS_PER_POSE = 64
#: First size of the crossing records of each mesh (and of the scratch of edges crossed more
#: than once); they double, up to the call's capacity, when a pose fills them (the pose is
#: then computed again). Made at the capacity (400,000 by default: 19 MB a call) they were
#: mostly never touched, but a call's freeing them let the allocator hand its memory back to
#: the system, and the next call's arrays came back as fresh pages, faulted in one by one.
CROSSINGS = 2**14
# Which table a pose filled (`_search`, `_Call.grow`).
cdef enum:
    FULL_SEEDS = 1
    FULL_CROSSINGS = 2
    FULL_PAIRS = 3


cdef class _Call:
    """One call's tables (read through `_tables`), scratch, and counters."""

    cdef MeshTables hand_mesh, object_mesh
    cdef HandTables hand
    cdef ObjectTables obj
    cdef CellGrid hand_grid, object_grid
    cdef MomentTables mom
    cdef PoseScratch scratch
    cdef MomentRows G
    cdef VertexSums sums
    cdef double[:, :, ::1] out_a, out_b
    cdef int64_t[::1] slots
    cdef bint summing
    cdef object tuples
    cdef int64_t cap, pairs, rows, crossings, attempt, token
    cdef int64_t full
    cdef bint segs
    cdef double tiny, amax, bmax, hcell
    cdef double[:, ::1] R
    cdef double[::1] t

    def __init__(
        self, hand_mesh, hand, hand_grid, object_mesh, obj, object_grid, tiny, cap, mom, sums
    ):
        self.summing = sums is not None
        if self.summing:
            self.sums = VertexSums(sums[0])
            self.out_a, self.out_b, self.slots = sums[1], sums[2], sums[3]
        self.tuples = (hand_mesh, hand, hand_grid, object_mesh, obj, object_grid)
        self.hand_mesh, self.hand = MeshTables(hand_mesh), HandTables(hand)
        self.object_mesh, self.obj = MeshTables(object_mesh), ObjectTables(obj)
        self.hand_grid, self.object_grid = CellGrid(hand_grid), CellGrid(object_grid)
        self.mom = MomentTables(mom)
        self.tiny, self.cap = tiny, cap
        self.pairs, self.rows, self.crossings = PAIR_TABLE, SEED_ROWS, min(cap, CROSSINGS)
        self.segs = self.mom.row_count[0] > 0
        self.attempt, self.token = 0, -1
        self.hcell = self.hand_grid.cell
        self.R, self.t = np.zeros((3, 3)), np.zeros(3)
        n_rows = int(self.mom.row_count[0])
        self.G = MomentRows(
            named.MomentRows(
                np.zeros((n_rows, MOMENT_COLUMNS)), np.full(n_rows, -1, np.int64),
                np.zeros(n_rows + 1, np.int64), np.zeros(2, np.int64),
            )
        )
        self.scratch = PoseScratch(_scratch(*self.tuples, self.crossings, self.workspace()))
        # Bounds on every vertex's length (hand; object in its frame): the error bounds'
        # coordinate scale. The coordinates are local (about the hand's centre), so it
        # measures the geometry's size, not its position.
        self.amax = max2(vertex_bound(self.hand_mesh.vertices), LENGTH_FLOOR)
        self.bmax = vertex_bound(self.object_mesh.vertices)

    cdef int grow(self) except -1:
        """The table the pose filled (``full``, `_search`) made larger: the seed buffer or the
        pair table twice as large, the crossing records twice as large up to the capacity."""
        if self.full == FULL_SEEDS:
            self.rows *= 2
        elif self.full == FULL_CROSSINGS:
            self.crossings = min(2 * self.crossings, self.cap)
            self.scratch.multi = np.empty(self.crossings, np.int64)
        else:
            self.pairs *= 2
        clear_records(self.scratch.work)
        self.scratch.work = self.workspace()
        return 0

    cdef Workspace workspace(self):
        """The search's scratch arrays (`tables.Workspace`) at the current sizes."""
        hand_mesh, hand, hand_grid, object_mesh, _, object_grid = self.tuples
        cap, pairs = self.crossings, self.pairs
        acs, bcs = hand_grid.cell_start, object_grid.cell_start
        longest = max(1, np.max(np.diff(acs)), np.max(np.diff(bcs)))
        return Workspace(
            named.Workspace(
                np.zeros(hand_mesh.edges.shape[0], np.int64),
                np.zeros(object_mesh.edges.shape[0], np.int64),
                named.Crossings(np.empty(cap, np.int64), np.empty(cap), np.empty(cap)),
                named.Crossings(np.empty(cap, np.int64), np.empty(cap), np.empty(cap)),
                np.zeros(2, np.int64), np.zeros(pairs, np.int64), np.zeros(pairs, np.int32),
                np.empty((self.rows, 2), np.int64), np.empty((2, POINT_COLUMNS)),
                np.empty((2, 3), np.int64), np.empty((2, 4)),
                np.zeros(hand.parts.shape[0] - 1, np.bool_), np.empty(longest, np.int64),
                np.empty((pairs if self.segs else 0, SEGMENT_COLUMNS)),
            )
        )


def _scratch(hand_mesh, hand, hand_grid, object_mesh, obj, object_grid, cap, work):
    """The per-pose scratch arrays (`tables.PoseScratch`), ``cap`` crossings, around
    the search's ``work`` (a compiled `Workspace`, which `PoseScratch` takes as it is)."""
    na, nb = hand_mesh.vertices.shape[0], object_mesh.vertices.shape[0]
    ma, mb = hand_mesh.faces.shape[0], object_mesh.faces.shape[0]
    return named.PoseScratch(
        np.empty_like(object_mesh.vertices), np.empty((mb, 3)), np.empty((mb, 3)),
        np.empty(na, np.int8), np.empty(nb, np.int8), np.zeros(hand.parts.shape[0] - 1, np.bool_),
        np.empty(max(na, nb), np.int64), np.empty(cap, np.int64), np.empty(3),
        np.full(ma, -1, np.int64), np.full(mb, -1, np.int64),
        np.zeros(obj.edge_runs.shape[0], np.bool_), np.zeros(hand.cotree_runs.shape[0], np.bool_),
        np.zeros(hand.cotree_blocks.shape[0], np.bool_), np.zeros(0, np.bool_), work,
    )


cdef inline (double, double, int64_t, int64_t, int64_t) _search(
    _Call c, double gscale, double gb, double ferr
) noexcept nogil:
    """Stages "seeds" and "pairs" of the current pose, once: (segment sum, its error bound,
    crossings, pairs evaluated, code). The code is `GROW` where the seed buffer, the crossing
    records (below the capacity) or the pair table filled up (``c.full`` says which): the pose
    is searched again after `_Call.grow`."""
    cdef int64_t nseeds, code
    cdef (double, double, int64_t, int64_t, int64_t) traced
    c.attempt += 1
    if c.attempt >= 2**30:
        # The pair table's tags would overflow: start them again.
        c.scratch.work.pair_tags[:] = 0
        c.attempt = 1
    clear_records(c.scratch.work)
    nseeds = object_edge_seeds(
        c.object_mesh, c.obj, c.hand, c.hand_grid, c.scratch.object_V, c.scratch.near,
        gscale, c.scratch.work, 0,
    )
    if nseeds >= 0:
        nseeds = cotree_seeds(
            c.hand_mesh, c.hand, c.obj, c.object_grid, c.R, c.t, c.scratch.near_cotree,
            gscale, ferr, c.hcell, c.scratch.work, nseeds,
        )
    if nseeds < 0:
        c.full = FULL_SEEDS
        return 0.0, 0.0, 0, 0, GROW
    traced = trace_pairs(
        c.hand_mesh, c.hand, c.object_mesh, c.obj, c.scratch.object_V, c.scratch.object_D,
        c.scratch.object_N, c.scratch.work, nseeds, gscale, gb, c.hcell, c.attempt,
    )
    code = traced[4]
    if code == OVERFLOW and c.crossings < c.cap:
        c.full = FULL_CROSSINGS
        return 0.0, 0.0, 0, 0, GROW
    c.full = FULL_PAIRS
    return traced


cdef class _Entries:
    """The moment entries of a call: rows and values, grown as poses add to them."""

    cdef int64_t[::1] rows
    cdef double[:, ::1] values
    cdef int64_t n

    def __init__(self, int64_t first):
        self.rows, self.values = np.empty(first, np.int64), np.empty((first, MOMENT_COLUMNS))
        self.n = 0

    cdef int add(self, MomentRows G, int64_t done, int64_t poses) except -1 nogil:
        """The rows pose number ``done`` (from 1) touched, appended (`_pose.copy_rows`); the
        GIL is taken only to grow the arrays (`_grow`)."""
        if self.n + G.state[0] > self.rows.shape[0]:
            with gil:
                self._grow(G.state[0], done, poses)
        self.n = copy_rows(G, self.rows, self.values, self.n)
        return 0

    cdef int _grow(self, int64_t count, int64_t done, int64_t poses) except -1:
        """New arrays long enough for all ``poses`` at 5/4 of the rate so far, and at least
        twice as long, holding the ``n`` entries so far."""
        cdef int64_t size
        size = max(2 * self.rows.shape[0], (self.n + count) * poses * 5 // (4 * done) + count)
        rows, values = np.empty(size, np.int64), np.empty((size, MOMENT_COLUMNS))
        rows[: self.n] = self.rows[: self.n]
        values[: self.n] = self.values[: self.n]
        self.rows, self.values = rows, values
        return 0


def pose_volumes(
    const double[:, :, ::1] poses, hand_mesh, hand, hand_grid, object_mesh, obj, object_grid,
    double tiny, int64_t cap, double[::1] out, double[::1] bounds, int64_t[::1] codes,
    int64_t[:, ::1] stats, mom, int64_t[::1] moment_start, sums=None,
):
    """Volume of hand ∩ (pose · object) for each pose; the hand is fixed, the object is in its
    own frame. Arguments and results as the numba kernel's were (see ``docs/exact-backend.md``):

    Parameters
    ----------
    poses : numpy.ndarray, shape (k, 4, 4)
        Rigid motions of the object, in local coordinates.
    hand_mesh, object_mesh : tables.MeshTables
    hand : tables.HandTables
    hand_grid, object_grid : tables.CellGrid
    obj : tables.ObjectTables
    tiny : float
        Faces with ``|N|² <= tiny`` get ``D = 0``.
    cap : int
        Edge crossings recorded per mesh and pose before the pose gives up (`OVERFLOW`).
    out, bounds : numpy.ndarray, shape (k,), float64
        Filled with the volumes and their error bounds; left alone where the pose is not `OK`.
    codes : numpy.ndarray, shape (k,), int64
        `OK`, `DEGENERATE` or `OVERFLOW`.
    stats : numpy.ndarray, shape (k, N_STATS), int64
        Face pairs evaluated, crossing pairs, and the hand's parts classified vertex by vertex
        / whole inside / whole outside (columns ``STAT_*``).
    mom : tables.MomentTables
        The hand's moment tables, or empty ones (volumes only: ``mom.row_count[0]`` is 0).
    moment_start : numpy.ndarray, shape (k + 1,), int64
        Filled with where each pose's moment entries start in the returned arrays.
    sums : tuple, optional
        ``(tables, out_a, out_b, slots)``: each pose's moments summed onto the vertices
        instead of listed (`_face_gradients.pose_sums`; none are returned), by ``tables``
        (`face_gradients.VertexTables`), into rows ``slots`` (k,) int64 of ``out_a``
        (m, n_a, 3) and ``out_b`` (m, n_b, 3), written whole (zeros where the pose has no
        moments: not `OK`, or a volume of 0).

    Returns
    -------
    rows : numpy.ndarray, shape (t,), int64
    values : numpy.ndarray, shape (t, 6), float64
        The moment rows each `OK` pose with a non-zero volume touched, in the order first
        touched, and their moments (local coordinates). Empty for volumes only, and with
        ``sums``.
    """
    cdef _Call c = _Call(
        hand_mesh, hand, hand_grid, object_mesh, obj, object_grid, tiny, cap, mom, sums
    )
    cdef int64_t k = poses.shape[0]
    cdef _Entries entries = _Entries(
        0 if c.summing else k * min(int(c.mom.row_count[0]), ROWS_PER_POSE)
    )
    cdef Py_ssize_t ip
    moment_start[0] = 0
    with nogil:
        for ip in range(k):
            _one_pose(c, poses, ip, out, bounds, codes, stats, entries)
            moment_start[ip + 1] = entries.n
    return np.asarray(entries.rows)[: entries.n], np.asarray(entries.values)[: entries.n]


cdef inline void _take_pose(
    const double[:, :, ::1] poses, Py_ssize_t ip, double[:, ::1] R, double[::1] t
) noexcept nogil:
    """Pose ``ip``'s rotation and translation copied into ``R`` (3, 3) and ``t`` (3,), which
    the stages read as contiguous arrays."""
    cdef Py_ssize_t a, b
    for a in range(3):
        t[a] = poses[ip, a, 3]
        for b in range(3):
            R[a, b] = poses[ip, a, b]


cdef int _one_pose(
    _Call c, const double[:, :, ::1] poses, Py_ssize_t ip, double[::1] out,
    double[::1] bounds, int64_t[::1] codes, int64_t[:, ::1] stats, _Entries entries,
) except -1 nogil:
    """Pose ``ip``: its volume, bound, code, statistics and, where asked, moments. The GIL is
    taken only to grow a table the pose filled, or the moment entries."""
    cdef double gb, gscale, ferr, seg, segerr, bound, vol = 0.0
    cdef int64_t ncross, npairs, code
    _take_pose(poses, ip, c.R, c.t)
    gb = move_object(
        c.R, c.t, c.object_mesh.vertices, c.object_mesh.faces, c.tiny, c.bmax,
        c.scratch.object_V, c.scratch.object_D, c.scratch.object_N,
    )
    gscale = max2(c.amax, gb)
    ferr = near_pass(c.R, c.t, gscale, c.hand, c.hand_grid, c.obj, c.object_grid, c.scratch)
    seg, segerr, ncross, npairs, code = _search(c, gscale, gb, ferr)
    while code == GROW:
        with gil:
            c.grow()
        seg, segerr, ncross, npairs, code = _search(c, gscale, gb, ferr)
    # After the pairs: the parts whose own edges nothing crosses are classified whole.
    code, c.token = classify_vertices(
        c.R, c.t, c.hand_mesh, c.hand, c.object_mesh, c.obj, c.hand_grid, c.object_grid,
        c.scratch, code, c.token, ferr,
    )
    if code == OK:
        vol, bound, code = volume_sum(
            c.hand_mesh, c.hand, c.object_mesh, c.obj, c.scratch, seg, segerr, gscale, gb
        )
        out[ip] = vol
        bounds[ip] = bound
        if code == OK and vol > 0.0 and c.segs:
            c.G.state[1] = ip
            pose_moments(
                c.R, c.t, c.hand_mesh, c.hand, c.object_mesh, c.mom, c.scratch, ncross, c.G
            )
    if c.summing:
        zero_pose(c.out_a, c.out_b, c.slots[ip])
        if code == OK and vol > 0.0 and c.segs:
            pose_sums(c.G, c.sums, c.out_a, c.out_b, c.slots[ip])
    elif code == OK and vol > 0.0 and c.segs:
        entries.add(c.G, ip + 1, poses.shape[0])
    codes[ip] = code
    stats[ip, STAT_PAIRS] = npairs
    stats[ip, STAT_CROSSING] = ncross
    cell_stats(stats, ip, c.hand.parts, c.scratch.uniform, c.scratch.hand_status)
    return 0
