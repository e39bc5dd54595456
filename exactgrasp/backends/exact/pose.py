"""The exact kernel's per-pose driver (numba): hand ∩ moved object for a batch of poses.

Each pose runs the stages of "Method, per pose" in ``docs/exact-backend.md`` in order: move
(`move_object`), near runs (`near_pass`), seeds (`seeds.object_edge_seeds`,
`seeds.cotree_seeds`), pairs
(`search.trace_pairs`), classify (`classify.classify_vertices`) and sum (`sums.volume_sum`),
then, where asked, the derivatives' moments (`moment_sums.hand_moments`, and per object face
`object_moments.object_moments`). The tables are
`tables`' named tuples.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.classify import classify_vertices
from exactgrasp.backends.exact.moment_sums import hand_moments
from exactgrasp.backends.exact.object_moments import object_moments
from exactgrasp.backends.exact.search import trace_pairs
from exactgrasp.backends.exact.seeds import (
    cotree_seeds,
    frame_defect,
    near_runs,
    object_edge_seeds,
)
from exactgrasp.backends.exact.sums import face_terms, volume_sum
from exactgrasp.backends.exact.tables import (
    COTREE_BLOCK,
    GROW,
    MOMENT_COLUMNS,
    OK,
    PART_FIRST_VERTEX,
    POINT_COLUMNS,
    SEGMENT_COLUMNS,
    STAT_CELLS_INSIDE,
    STAT_CELLS_OUTSIDE,
    STAT_CELLS_TOUCHED,
    STAT_CROSSING,
    STAT_PAIRS,
    Crossings,
    MomentRows,
    PoseScratch,
    Workspace,
)
from exactgrasp.backends.exact.tolerances import LENGTH_FLOOR, ROUNDING_PAD, U
from exactgrasp.compiling import inner, kernel

#: First size of the pair table (a power of two) and of the seed buffer; both double when a
#: pose needs more (the pose is then computed again).
PAIR_TABLE, SEED_ROWS = 2**14, 2**13
#: Rows of moments a call's output holds at first, per pose (it grows when full,
#: `emit_rows`).
ROWS_PER_POSE = 64


@inner(nogil=True, error_model="numpy")
def move_object(R, t, BV0, BF, tiny, bmax, BV, BD, BN):
    """Stage "move" of a pose (``docs/exact-backend.md``, "Method", step 1): the object's
    vertices ``BV0`` (its own frame) moved by ``x -> R x + t`` into ``BV``, and its faces'
    normals ``BN`` and ``D`` ``BD`` there (`sums.face_terms`; ``|N|² <= tiny`` gives 0).
    Returns a bound on every moved coordinate, from ``bmax`` bounding every ``|x|``:
    ``|R x + t| <= |x| + |t|``. Scalar loads: array views per vertex would update reference
    counts."""
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    t0, t1, t2 = t[0], t[1], t[2]
    for i in range(BV0.shape[0]):
        x, y, z = BV0[i, 0], BV0[i, 1], BV0[i, 2]
        BV[i, 0] = r00 * x + r01 * y + r02 * z + t0
        BV[i, 1] = r10 * x + r11 * y + r12 * z + t1
        BV[i, 2] = r20 * x + r21 * y + r22 * z + t2
    face_terms(BV, BF, tiny, BD, BN)
    return bmax + np.sqrt(t0 * t0 + t1 * t1 + t2 * t2) * ROUNDING_PAD


@inner(nogil=True, error_model="numpy")
def near_pass(R, t, gscale, hand, hand_grid, obj, object_grid, scratch):
    """Stage "near runs" of a pose: which runs of object edges may come near the hand's surface
    (``scratch.near``) and which runs of the hand's co-tree edges near the object's
    (``scratch.near_cotree``, through their blocks, ``scratch.near_block``), `seeds.near_runs`.
    Returns ``ferr``: how far a point moved into the object's frame by ``R^T`` may lie from
    where the pose's inverse puts it (R's departure from a rotation, `seeds.frame_defect`, and
    rounding; ``gscale`` bounds every coordinate), which widens every test made there."""
    W = scratch.work
    defect = frame_defect(R)
    stretch = 1.0 + 4.0 * defect + 16.0 * U
    ferr = 2.0 * (4.0 * defect + 16.0 * U) * gscale
    near_runs(
        obj.edge_runs, R, t, False, stretch, 0.0, False, hand_grid, W.cell_range,
        scratch.none, 1, scratch.near,
    )  # fmt: skip
    # The co-tree's runs in two levels: blocks of runs by the surface cells alone, then the
    # runs of near blocks against what those cells hold.
    near_runs(
        hand.cotree_blocks, R, t, True, stretch, ferr, False, object_grid, W.cell_range,
        scratch.none, 1, scratch.near_block,
    )  # fmt: skip
    near_runs(
        hand.cotree_runs, R, t, True, stretch, ferr, True, object_grid, W.cell_range,
        scratch.near_block, COTREE_BLOCK, scratch.near_cotree,
    )  # fmt: skip
    return ferr


@inner(nogil=True, error_model="numpy")
def _clear_records(W):
    """Clear the crossing counters where the last pose set them, and the records (the pair
    table is stamped per pose, so it needs no pass)."""
    acnt, bcnt, nrec = W.hand_count, W.object_count, W.nrec
    for k in range(nrec[0]):
        acnt[W.hand_rec.edge[k]] = 0
    for k in range(nrec[1]):
        bcnt[W.object_rec.edge[k]] = 0
    nrec[:] = 0


@inner(nogil=True, error_model="numpy")
def _cell_stats(stats, ip, parts, uniform, AS):
    """The hand parts of pose ``ip`` classified vertex by vertex, and of the others (classified
    whole, ``uniform``) those inside and outside (from their first vertex's status ``AS``)."""
    nparts = parts.shape[0] - 1
    touched = 0
    inside = 0
    for k in range(nparts):
        if not uniform[k]:
            touched += 1
        elif AS[parts[k, PART_FIRST_VERTEX]] == 1:
            inside += 1
    stats[ip, STAT_CELLS_TOUCHED] = touched
    stats[ip, STAT_CELLS_INSIDE] = inside
    stats[ip, STAT_CELLS_OUTSIDE] = nparts - touched - inside


@inner(nogil=True, error_model="numpy")
def _workspace(hand_mesh, hand, hand_grid, object_mesh, object_grid, cap, pairs, rows, segs):
    """The search's scratch arrays (`tables.Workspace`): ``cap`` crossings per mesh, a pair
    table of ``pairs`` slots (a power of two), ``rows`` seed rows, and room for the traced
    segments where ``segs`` (else none: volumes only)."""
    acs, bcs = hand_grid.cell_start, object_grid.cell_start
    longest = max(1, np.max(acs[1:] - acs[:-1]), np.max(bcs[1:] - bcs[:-1]))
    return Workspace(
        np.zeros(hand_mesh.edges.shape[0], np.int64),
        np.zeros(object_mesh.edges.shape[0], np.int64),
        Crossings(np.empty(cap, np.int64), np.empty(cap), np.empty(cap)),
        Crossings(np.empty(cap, np.int64), np.empty(cap), np.empty(cap)),
        np.zeros(2, np.int64),
        np.zeros(pairs, np.int64),
        np.zeros(pairs, np.int32),
        np.empty((rows, 2), np.int64),
        np.empty((2, POINT_COLUMNS)),
        np.empty((2, 3), np.int64),
        np.empty((2, 4)),
        np.empty((3, 2), np.int64),
        np.zeros(hand.parts.shape[0] - 1, np.bool_),
        np.empty(longest, np.int64),
        np.empty((pairs if segs else 0, SEGMENT_COLUMNS)),
    )


@inner(nogil=True, error_model="numpy")
def _scratch(hand_mesh, hand, hand_grid, object_mesh, obj, object_grid, cap, work):
    """The per-pose scratch arrays (`tables.PoseScratch`), ``cap`` crossings per mesh, around
    the search's ``work``."""
    na, nb = hand_mesh.vertices.shape[0], object_mesh.vertices.shape[0]
    ma, mb = hand_mesh.faces.shape[0], object_mesh.faces.shape[0]
    return PoseScratch(
        np.empty_like(object_mesh.vertices),
        np.empty((mb, 3)),
        np.empty((mb, 3)),
        np.empty(na, np.int8),
        np.empty(nb, np.int8),
        np.zeros(hand.parts.shape[0] - 1, np.bool_),
        np.empty(max(na, nb), np.int64),
        np.empty(cap, np.int64),
        np.empty(3),
        np.full(ma, -1, np.int64),
        np.full(mb, -1, np.int64),
        np.zeros(obj.edge_runs.shape[0], np.bool_),
        np.zeros(hand.cotree_runs.shape[0], np.bool_),
        np.zeros(hand.cotree_blocks.shape[0], np.bool_),
        np.zeros(0, np.bool_),
        work,
    )


@inner(nogil=True, error_model="numpy")
def _vertex_bound(V):
    """A bound on every vertex's length ``|x|`` of V (n, 3), widened by `ROUNDING_PAD`."""
    vmax = 0.0
    for i in range(V.shape[0]):
        vmax = max(vmax, V[i, 0] ** 2 + V[i, 1] ** 2 + V[i, 2] ** 2)
    return np.sqrt(vmax) * ROUNDING_PAD


@inner(nogil=True, error_model="numpy")
def _moment_rows(n_rows, k):
    """`tables.MomentRows` of ``n_rows`` rows, all zero and untouched, and the first arrays
    `emit_rows` fills for ``k`` poses (rows, moments)."""
    first = k * min(n_rows, ROWS_PER_POSE)
    G = MomentRows(
        np.zeros((n_rows, MOMENT_COLUMNS)),
        np.full(n_rows, -1, np.int64),
        np.zeros(n_rows + 1, np.int64),
        np.zeros(2, np.int64),
    )
    return G, np.empty(first, np.int64), np.empty((first, MOMENT_COLUMNS))


@inner(nogil=True, error_model="numpy")
def emit_rows(G, rows_out, values_out, n, done, poses):
    """The rows a pose touched (`tables.MomentRows` ``G``), in the order first touched, copied
    to ``rows_out`` (row numbers) and ``values_out`` (moments) from entry ``n`` on and cleared
    in ``G``. Returns both arrays and the entries now in them: new ones where they were full,
    long enough for all ``poses`` at 5/4 of the rate of the ``done`` so far (this one
    included), and at least twice as long."""
    values, touched, state = G.values, G.touched, G.state
    count = state[0]
    if n + count > rows_out.shape[0]:
        size = max(2 * rows_out.shape[0], (n + count) * poses * 5 // (4 * done) + count)
        grown_rows, grown_values = np.empty(size, np.int64), np.empty((size, MOMENT_COLUMNS))
        grown_rows[:n] = rows_out[:n]
        grown_values[:n] = values_out[:n]
        rows_out, values_out = grown_rows, grown_values
    for i in range(count):
        r = touched[i]
        rows_out[n] = r
        for d in range(MOMENT_COLUMNS):
            values_out[n, d] = values[r, d]
            values[r, d] = 0.0
        n += 1
    state[0] = 0
    return rows_out, values_out, n


@inner(nogil=True, error_model="numpy")
def pose_moments(R, t, hand_mesh, hand, object_mesh, mom, scratch, ncross, G):
    """Stage "moments" of pose ``x -> R x + t``, after its volume: the moments of each link's
    boundary inside the object (`moment_sums.hand_moments`) and, where ``mom.object_from[0]``
    is not -1, of each object face's part inside the hand from that row on, in the object's
    frame (`object_moments.object_moments`), added to ``G``'s rows (`tables.MomentRows`, each
    row touched listed there)."""
    W = scratch.work
    hand_moments(
        hand_mesh, hand, mom, scratch.hand_status, scratch.uniform, W.hand_count, W.hand_rec.edge,
        W.hand_rec.lam, W.nrec[0], scratch.multi, W.segments, ncross, G,
    )  # fmt: skip
    if mom.object_from[0] >= 0:
        object_moments(
            object_mesh, mom, R, t, scratch.object_status, W.object_count, W.object_rec.edge,
            W.object_rec.lam, W.nrec[1], scratch.multi, W.segments, ncross, G,
        )  # fmt: skip


@kernel(nogil=True, error_model="numpy")
def pose_volumes(
    poses, hand_mesh, hand, hand_grid, object_mesh, obj, object_grid, tiny, cap,
    out, bounds, codes, stats, mom, moment_start,
):  # fmt: skip
    """Volume of hand ∩ (pose · object) for each pose; the hand is fixed, the object is in its
    own frame.

    Parameters
    ----------
    poses : numpy.ndarray, shape (k, 4, 4)
        Rigid motions of the object, in local coordinates.
    hand_mesh, object_mesh : tables.MeshTables
    hand : tables.HandTables
    hand_grid, object_grid : tables.CellGrid
    obj : tables.ObjectTables
    tiny : float
        Faces with ``|N|² <= tiny`` get ``D = 0`` (`sums.face_terms`).
    cap : int
        Edge crossings recorded per mesh and pose before the pose gives up (`OVERFLOW`).
    out, bounds : numpy.ndarray, shape (k,), float64
        Filled with the volumes and their error bounds (terms' rounding, crossing points'
        errors, the faces' rounded ``D`` and the sums' rounding; see docs/exact-backend.md).
        A volume within its bound of zero is exactly 0; one below minus it is inconsistent and
        reported DEGENERATE, so no negative volume is returned. Left alone where the pose is
        not `OK`.
    codes : numpy.ndarray, shape (k,), int64
        `OK`, `DEGENERATE` or `OVERFLOW` (the caller recomputes those with a boolean).
    stats : numpy.ndarray, shape (k, N_STATS), int64
        Face pairs evaluated, crossing pairs, and the hand's parts classified vertex by vertex
        / whole inside / whole outside (columns ``STAT_*``).
    mom : tables.MomentTables
        The hand's moment tables, or empty ones (volumes only: ``mom.row_count[0]`` is 0).
    moment_start : numpy.ndarray, shape (k + 1,), int64
        Filled with where each pose's moment rows start in the returned arrays (pose ``i``'s
        are entries ``moment_start[i]`` to ``moment_start[i + 1] - 1``).

    Returns
    -------
    rows : numpy.ndarray, shape (t,), int64
        The rows (of ``mom.row_count[0]``) each `OK` pose with a non-zero volume touched, pose
        by pose, in the order first touched: of each link's boundary inside the object
        (`moment_sums.hand_moments`), from row ``mom.object_from[0]`` where that is not -1 of
        each object face's part inside the hand, in the object's frame
        (`object_moments.object_moments`), and from row ``mom.part_from[0]`` where that is not
        -1 the markers of the parts classified whole and inside. Empty for volumes only.
    values : numpy.ndarray, shape (t, 6), float64
        Their moments (`MOMENT_COLUMNS`), local coordinates (a marker's zeros). A row not
        listed for a pose holds zeros.

    A pose whose pair table or seed buffer fills up (`GROW`) is computed again with both
    doubled: results do not depend on their sizes.
    """
    AV = hand_mesh.vertices
    BV0, BF = object_mesh.vertices, object_mesh.faces
    pairs, rows = PAIR_TABLE, SEED_ROWS
    segs = mom.row_count[0] > 0
    G, rows_out, values_out = _moment_rows(mom.row_count[0], poses.shape[0])
    n_out = moment_start[0] = 0
    work = _workspace(hand_mesh, hand, hand_grid, object_mesh, object_grid, cap, pairs, rows, segs)
    scratch = _scratch(hand_mesh, hand, hand_grid, object_mesh, obj, object_grid, cap, work)
    W = scratch.work
    token = -1
    attempt = 0
    hcell = hand_grid.cell
    # Bounds on every vertex's length (hand; object in its frame): the error bounds'
    # coordinate scale. The coordinates are local (about the hand's centre), so it measures
    # the geometry's size, not its position.
    amax = max(_vertex_bound(AV), LENGTH_FLOOR)
    bmax = _vertex_bound(BV0)
    for ip in range(poses.shape[0]):
        R = poses[ip, :3, :3]
        t = poses[ip, :3, 3]
        gb = move_object(
            R, t, BV0, BF, tiny, bmax, scratch.object_V, scratch.object_D, scratch.object_N
        )
        gscale = max(amax, gb)
        ferr = near_pass(R, t, gscale, hand, hand_grid, obj, object_grid, scratch)
        while True:
            attempt += 1
            if attempt >= 2**30:
                # The pair table's tags would overflow: start them again.
                W.pair_tags[:] = 0
                attempt = 1
            _clear_records(W)
            nseeds = object_edge_seeds(
                object_mesh, obj, hand, hand_grid, scratch.object_V, scratch.near, gscale, W, 0
            )
            if nseeds >= 0:
                nseeds = cotree_seeds(
                    hand_mesh, hand, obj, object_grid, R, t, scratch.near_cotree, gscale, ferr,
                    hcell, W, nseeds,
                )  # fmt: skip
            if nseeds < 0:
                rows *= 2
            else:
                seg, segerr, ncross, npairs, code = trace_pairs(
                    hand_mesh, hand, object_mesh, obj, scratch.object_V, scratch.object_D,
                    scratch.object_N, W, nseeds, gscale, gb, hcell, attempt,
                )  # fmt: skip
                if code != GROW:
                    break
                pairs *= 2
            # A table was too small: the pose starts again with larger ones.
            _clear_records(W)
            W = _workspace(
                hand_mesh, hand, hand_grid, object_mesh, object_grid, cap, pairs, rows, segs
            )
            # The same per-pose arrays around the new search scratch (`work`, the last field).
            scratch = PoseScratch(*scratch[:-1], W)
        # After the pairs: the parts whose own edges nothing crosses are classified whole.
        code, token = classify_vertices(
            R, t, hand_mesh, hand, object_mesh, obj, hand_grid, object_grid, scratch, code,
            token, ferr,
        )  # fmt: skip
        if code == OK:
            vol, bound, code = volume_sum(
                hand_mesh, hand, object_mesh, obj, scratch, seg, segerr, gscale, gb
            )
            out[ip] = vol
            bounds[ip] = bound
            if code == OK and vol > 0.0 and segs:
                G.state[1] = ip
                pose_moments(R, t, hand_mesh, hand, object_mesh, mom, scratch, ncross, G)
                rows_out, values_out, n_out = emit_rows(
                    G, rows_out, values_out, n_out, ip + 1, poses.shape[0]
                )
        moment_start[ip + 1] = n_out
        codes[ip] = code
        stats[ip, STAT_PAIRS] = npairs
        stats[ip, STAT_CROSSING] = ncross
        _cell_stats(stats, ip, hand.parts, scratch.uniform, scratch.hand_status)
    return rows_out[:n_out], values_out[:n_out]
