# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False
"""The exact kernel's per-pose stages (Cython, inline): hand ∩ moved object, pose by pose.

Each pose runs the stages of "Method, per pose" in ``docs/exact-backend.md`` in order: move
(`move_object`), near runs (`near_pass`), seeds (`_seeds.object_edge_seeds`,
`_seeds.cotree_seeds`), pairs (`_search.trace_pairs`), classify
(`_classify.classify_vertices`) and sum (`_sums.volume_sum`), then, where asked, the
derivatives' moments (`pose_moments`). The driver that loops over the poses, and grows the
tables when a pose needs more, is `_kernel.pose_volumes`.
"""

from libc.math cimport sqrt
from libc.stdint cimport int8_t, int64_t, uint8_t

from exactgrasp.backends.exact._constants cimport (
    COTREE_BLOCK,
    MOMENT_COLUMNS,
    PART_FIRST_VERTEX,
    ROUNDING_PAD,
    STAT_CELLS_INSIDE,
    STAT_CELLS_OUTSIDE,
    STAT_CELLS_TOUCHED,
    U,
)
from exactgrasp.backends.exact._moment_sums cimport hand_moments
from exactgrasp.backends.exact._object_moments cimport object_moments
from exactgrasp.backends.exact._seeds cimport frame_defect, near_runs
from exactgrasp.backends.exact._sums cimport face_terms
from exactgrasp.backends.exact._tables cimport (
    CellGrid,
    HandTables,
    MeshTables,
    MomentRows,
    MomentTables,
    ObjectTables,
    PoseScratch,
    Workspace,
)


cdef inline double move_object(
    const double[:, ::1] R, const double[::1] t, const double[:, ::1] BV0,
    const int64_t[:, ::1] BF, double tiny, double bmax, double[:, ::1] BV, double[:, ::1] BD,
    double[:, ::1] BN,
) noexcept nogil:
    """Stage "move" of a pose (``docs/exact-backend.md``, "Method", step 1): the object's
    vertices ``BV0`` (its own frame) moved by ``x -> R x + t`` into ``BV``, and its faces'
    normals ``BN`` and ``D`` ``BD`` there (`_sums.face_terms`; ``|N|² <= tiny`` gives 0).
    Returns a bound on every moved coordinate, from ``bmax`` bounding every ``|x|``:
    ``|R x + t| <= |x| + |t|``."""
    cdef double r00 = R[0, 0], r01 = R[0, 1], r02 = R[0, 2]
    cdef double r10 = R[1, 0], r11 = R[1, 1], r12 = R[1, 2]
    cdef double r20 = R[2, 0], r21 = R[2, 1], r22 = R[2, 2]
    cdef double t0 = t[0], t1 = t[1], t2 = t[2]
    cdef double x, y, z
    cdef Py_ssize_t i
    for i in range(BV0.shape[0]):
        x, y, z = BV0[i, 0], BV0[i, 1], BV0[i, 2]
        BV[i, 0] = r00 * x + r01 * y + r02 * z + t0
        BV[i, 1] = r10 * x + r11 * y + r12 * z + t1
        BV[i, 2] = r20 * x + r21 * y + r22 * z + t2
    face_terms(BV, BF, tiny, BD, BN)
    return bmax + sqrt(t0 * t0 + t1 * t1 + t2 * t2) * ROUNDING_PAD


cdef inline double near_pass(
    const double[:, ::1] R, const double[::1] t, double gscale, HandTables hand,
    CellGrid hand_grid, ObjectTables obj, CellGrid object_grid, PoseScratch scratch,
) noexcept nogil:
    """Stage "near runs" of a pose: which runs of object edges may come near the hand's surface
    (``scratch.near``) and which runs of the hand's co-tree edges near the object's
    (``scratch.near_cotree``, through their blocks, ``scratch.near_block``),
    `_seeds.near_runs`. Returns ``ferr``: how far a point moved into the object's frame by
    ``R^T`` may lie from where the pose's inverse puts it (R's departure from a rotation,
    `_seeds.frame_defect`, and rounding; ``gscale`` bounds every coordinate), which widens
    every test made there."""
    cdef double defect = frame_defect(R)
    cdef double stretch = 1.0 + 4.0 * defect + 16.0 * U
    cdef double ferr = 2.0 * (4.0 * defect + 16.0 * U) * gscale
    near_runs(
        obj.edge_runs, R, t, False, stretch, 0.0, False, hand_grid,
        scratch.none, 1, scratch.near,
    )
    # The co-tree's runs in two levels: blocks of runs by the surface cells alone, then the
    # runs of near blocks against what those cells hold.
    near_runs(
        hand.cotree_blocks, R, t, True, stretch, ferr, False, object_grid,
        scratch.none, 1, scratch.near_block,
    )
    near_runs(
        hand.cotree_runs, R, t, True, stretch, ferr, True, object_grid,
        scratch.near_block, COTREE_BLOCK, scratch.near_cotree,
    )
    return ferr


cdef inline void clear_records(Workspace W) noexcept nogil:
    """Clear the crossing counters where the last pose set them, and the records (the pair
    table is stamped per pose, so it needs no pass)."""
    cdef int64_t k
    for k in range(W.nrec[0]):
        W.hand_count[W.hand_rec.edge[k]] = 0
    for k in range(W.nrec[1]):
        W.object_count[W.object_rec.edge[k]] = 0
    W.nrec[0] = 0
    W.nrec[1] = 0


cdef inline void cell_stats(
    int64_t[:, ::1] stats, Py_ssize_t ip, const int64_t[:, ::1] parts,
    const uint8_t[::1] uniform, const int8_t[::1] AS,
) noexcept nogil:
    """The hand parts of pose ``ip`` classified vertex by vertex, and of the others (classified
    whole, ``uniform``) those inside and outside (from their first vertex's status ``AS``)."""
    cdef Py_ssize_t nparts = parts.shape[0] - 1, k
    cdef int64_t touched = 0, inside = 0
    for k in range(nparts):
        if not uniform[k]:
            touched += 1
        elif AS[parts[k, PART_FIRST_VERTEX]] == 1:
            inside += 1
    stats[ip, STAT_CELLS_TOUCHED] = touched
    stats[ip, STAT_CELLS_INSIDE] = inside
    stats[ip, STAT_CELLS_OUTSIDE] = nparts - touched - inside


cdef inline double vertex_bound(const double[:, ::1] V) noexcept nogil:
    """A bound on every vertex's length ``|x|`` of V (n, 3), widened by `ROUNDING_PAD`."""
    cdef double vmax = 0.0, r
    cdef Py_ssize_t i
    for i in range(V.shape[0]):
        r = V[i, 0] * V[i, 0] + V[i, 1] * V[i, 1] + V[i, 2] * V[i, 2]
        if r > vmax:
            vmax = r
    return sqrt(vmax) * ROUNDING_PAD


cdef inline int64_t copy_rows(
    MomentRows G, int64_t[::1] rows_out, double[:, ::1] values_out, int64_t n
) noexcept nogil:
    """The rows a pose touched (``G``), in the order first touched, copied to ``rows_out``
    (row numbers) and ``values_out`` (moments) from entry ``n`` on (room checked by the
    caller) and cleared in ``G``. Returns the entries now in them."""
    cdef int64_t i, r, d
    for i in range(G.state[0]):
        r = G.touched[i]
        rows_out[n] = r
        for d in range(MOMENT_COLUMNS):
            values_out[n, d] = G.values[r, d]
            G.values[r, d] = 0.0
        n += 1
    G.state[0] = 0
    return n


cdef inline void pose_moments(
    const double[:, ::1] R, const double[::1] t, MeshTables hand_mesh, HandTables hand,
    MeshTables object_mesh, MomentTables mom, PoseScratch scratch, int64_t ncross,
    MomentRows G,
) noexcept nogil:
    """Stage "moments" of pose ``x -> R x + t``, after its volume: the moments of each link's
    boundary inside the object (`_moment_sums.hand_moments`) and, where
    ``mom.object_from[0]`` is not -1, of each object face's part inside the hand from that row
    on, in the object's frame (`_object_moments.object_moments`), added to ``G``'s rows (each
    row touched listed there)."""
    hand_moments(
        hand_mesh, hand, mom, scratch.hand_status, scratch.uniform, scratch.work.hand_count,
        scratch.work.hand_rec.edge, scratch.work.hand_rec.lam, scratch.work.nrec[0],
        scratch.multi, scratch.work.segments, ncross, G,
    )
    if mom.object_from[0] >= 0:
        object_moments(
            object_mesh, mom, R, t, scratch.object_status, scratch.work.object_count,
            scratch.work.object_rec.edge, scratch.work.object_rec.lam, scratch.work.nrec[1],
            scratch.multi, scratch.work.segments, ncross, G,
        )
