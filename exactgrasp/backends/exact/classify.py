"""Stage "classify" of the exact kernel (numba): the in/out status of every vertex of either
mesh against the other, from the grids' cell statuses, the crossings' parities along edges and,
for a shell with no classified vertex, one exact point test.

See "Method", steps 1, 4 and 5, and "Culling rules" in ``docs/exact-backend.md``.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.cells import cell_index, point_status
from exactgrasp.backends.exact.predicates import edge_triangle
from exactgrasp.backends.exact.tables import DEGENERATE, OK, PART_FIRST_VERTEX
from exactgrasp.backends.exact.tolerances import GRID_MARGIN, ROUNDING_PAD
from exactgrasp.compiling import inner, kernel
from exactgrasp.geometry.predicates import orient, orient_bound


@inner(nogil=True, error_model="numpy")
def spread(S, adj_start, adj_vert, adj_edge, cnt, queue, tail):
    """Breadth-first from the ``tail`` vertices in ``queue``: every unknown (-1) neighbour
    takes the status of the vertex it is reached from, flipped by the parity of the crossings
    on the edge between them."""
    head = 0
    while head < tail:
        u = queue[head]
        head += 1
        for k in range(adj_start[u], adj_start[u + 1]):
            w = adj_vert[k]
            if S[w] == -1:
                S[w] = S[u] ^ (cnt[adj_edge[k]] & 1)
                queue[tail] = w
                tail += 1


@inner(nogil=True, error_model="numpy")
def next_unknown(S, start, reps, uniform):
    """The first vertex at or after ``start`` whose status is unknown (-1), or -1. Parts
    classified whole (``uniform``, see `hand_statuses`) are known and skipped."""
    for k in range(reps.shape[0] - 1):
        if uniform[k] or reps[k + 1, PART_FIRST_VERTEX] <= start:
            continue
        for u in range(max(start, reps[k, PART_FIRST_VERTEX]), reps[k + 1, PART_FIRST_VERTEX]):
            if S[u] == -1:
                return u
    return -1


@inner(nogil=True, error_model="numpy")
def resolve(S, adj_start, adj_vert, adj_edge, cnt, queue, reps, uniform):
    """Give every vertex of unknown status (-1) the status of a neighbour, flipped by the
    parity of the crossings on the edge between them. Returns the first vertex still unknown
    (its component has no vertex of known status), or -1. Only the parts (``reps``, see
    `tables.HandTables.parts`) not classified whole (``uniform``) are searched."""
    tail = 0
    for p in range(reps.shape[0] - 1):
        if uniform[p]:
            continue
        for u in range(reps[p, PART_FIRST_VERTEX], reps[p + 1, PART_FIRST_VERTEX]):
            if S[u] != -1:
                continue
            for k in range(adj_start[u], adj_start[u + 1]):
                w = adj_vert[k]
                if S[w] >= 0:
                    S[u] = S[w] ^ (cnt[adj_edge[k]] & 1)
                    queue[tail] = u
                    tail += 1
                    break
    spread(S, adj_start, adj_vert, adj_edge, cnt, queue, tail)
    return next_unknown(S, 0, reps, uniform)


@inner(nogil=True, error_model="numpy")
def object_statuses(S, V, grid):
    """Status of every vertex of V in the other mesh's grid (1 inside, 0 outside, -1 in a cell
    the other surface touches), V being in that mesh's frame. One loop with scalar loads: a
    call per vertex with the grid's arrays would cost atomic reference counts (`point_status`
    does the same for one point)."""
    lo, ih, n, status = grid.corner, 1.0 / grid.cell, grid.shape, grid.status
    l0, l1, l2, n0, n1, n2 = lo[0], lo[1], lo[2], n[0], n[1], n[2]
    for i in range(V.shape[0]):
        c = cell_index(V[i, 0], V[i, 1], V[i, 2], l0, l1, l2, ih, n0, n1, n2)
        S[i] = 0 if c < 0 else status[c]


@inner(nogil=True, error_model="numpy")
def _off_centre(u, near):
    """Whether coordinate ``u`` (in cell units) lies within ``near`` of a cell boundary."""
    f = u - np.floor(u)
    return (f < near) | (f > 1.0 - near)


@inner(nogil=True, error_model="numpy")
def hand_statuses(S, V, R, t, grid, reps, crossed, whole, uniform, err):
    """`object_statuses` of the hand's vertices in the object's grid, part by part (``reps``,
    `tables.HandTables.parts`), the vertices moved by ``x -> R^T (x - t)``.

    A part none of whose own edges is crossed (``crossed[k]`` False; with ``whole``) has one
    status: its vertices are joined by those edges (`grids.part_order`). So the first vertex
    found in a cell of known status gives every vertex's status (``uniform[k]`` True). Other
    parts get a status per vertex (-1 where unknown).

    ``err`` bounds how far a moved vertex lies from where the pose's inverse puts it (R's
    departure from a rotation, `seeds.frame_defect`, and rounding). Where it exceeds the cells'
    margin (`GRID_MARGIN`), a vertex within ``err`` of its cell's boundary is unknown (-1): the
    true point may lie in the neighbouring cell, which the surface may touch."""
    lo, ih, n, status = grid.corner, 1.0 / grid.cell, grid.shape, grid.status
    # In cell units: a fraction of a cell this close to 0 or 1 is near the cell's boundary.
    near = err * ih if err > GRID_MARGIN * grid.cell else -1.0
    l0, l1, l2, n0, n1, n2 = lo[0], lo[1], lo[2], n[0], n[1], n[2]
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    t0, t1, t2 = t[0], t[1], t[2]
    for k in range(reps.shape[0] - 1):
        each = not (whole and not crossed[k])
        st = -1
        for i in range(reps[k, PART_FIRST_VERTEX], reps[k + 1, PART_FIRST_VERTEX]):
            d0, d1, d2 = V[i, 0] - t0, V[i, 1] - t1, V[i, 2] - t2
            x = r00 * d0 + r10 * d1 + r20 * d2
            y = r01 * d0 + r11 * d1 + r21 * d2
            z = r02 * d0 + r12 * d1 + r22 * d2
            c = cell_index(x, y, z, l0, l1, l2, ih, n0, n1, n2)
            si = 0 if c < 0 else status[c]
            if near > 0.0 and (
                _off_centre((x - l0) * ih, near)
                | _off_centre((y - l1) * ih, near)
                | _off_centre((z - l2) * ih, near)
            ):
                si = -1
            if each:
                S[i] = si
            elif si >= 0:
                st = si
                break
        uniform[k] = not each and st >= 0
        if not each:
            for i in range(reps[k, PART_FIRST_VERTEX], reps[k + 1, PART_FIRST_VERTEX]):
                S[i] = st


@inner(nogil=True, error_model="numpy")
def ray_status(x, V, F, grid, fstamp, token, xerr):
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
    grid : tables.CellGrid
        The mesh's grid (`grids.build_grid`).
    fstamp : numpy.ndarray, shape (m,), int64
        Scratch space marking faces already tested; entries equal to `token` are skipped.
    token : int
        A value not yet used in `fstamp`.
    xerr : float
        How far x may lie from the point meant (0 where x is exact up to rounding): every
        orientation's bound widens by what moving x that far can change it, and beyond the
        cells' margin (`GRID_MARGIN`, which keeps unlisted faces away from the walk) the test
        answers -1.
    """
    lo, h, n, status = grid.corner, grid.cell, grid.shape, grid.status
    cs, ct = grid.cell_start, grid.cell_faces
    if xerr >= GRID_MARGIN * h:
        return -1
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
            # An orientation with x as a corner moves by at most |(p - q) x (r - q)| <= 3 ext²
            # times x's displacement.
            bound = orient_bound(ext * ROUNDING_PAD) + 4.0 * ext * ext * xerr
            dp, okp = orient(a[0], a[1], a[2], b[0], b[1], b[2], d[0], d[1], d[2],
                             x[0], x[1], x[2], bound)  # fmt: skip
            dq, okq = orient(a[0], a[1], a[2], b[0], b[1], b[2], d[0], d[1], d[2],
                             yx, yy, yz, bound)  # fmt: skip
            sp = 0 if not okp else (1 if dp > 0 else -1)
            sq = 0 if not okq else (1 if dq > 0 else -1)
            code, _ = edge_triangle(x[0], x[1], x[2], yx, yy, yz, a[0], a[1], a[2],
                                    b[0], b[1], b[2], d[0], d[1], d[2], sp, dp, sq, dq,
                                    bound)  # fmt: skip
            if code == DEGENERATE:
                return -1
            parity ^= code
    return known ^ parity


@inner(nogil=True, error_model="numpy")
def _shell_straddles(V, comp, seen, R, t, inverse, grid):
    """Whether some shell of mesh V (vertex -> shell `comp`) has a vertex in a cell wholly
    inside the other mesh and one in a cell wholly outside it; the vertices move by x -> R x + t
    (or by the inverse transform) into the frame of the other mesh's `grid`."""
    lo, h, n, status = grid.corner, grid.cell, grid.shape, grid.status
    seen[:] = False
    x = np.empty(3)
    for i in range(V.shape[0]):
        for k in range(3):
            if inverse:
                x[k] = (
                    R[0, k] * (V[i, 0] - t[0])
                    + R[1, k] * (V[i, 1] - t[1])
                    + R[2, k] * (V[i, 2] - t[2])
                )
            else:
                x[k] = R[k, 0] * V[i, 0] + R[k, 1] * V[i, 1] + R[k, 2] * V[i, 2] + t[k]
        st = point_status(x, lo, h, n, status)
        if st < 0:
            continue
        seen[comp[i], st] = True
        if seen[comp[i], 0] and seen[comp[i], 1]:
            return True
    return False


@kernel(nogil=True, error_model="numpy")
def surfaces_cross(poses, AV, acomp, ancomp, agrid, BV0, bcomp, bncomp, bgrid):
    """Per pose, whether the moved object's surface certainly crosses the hand's: a connected
    shell of either mesh has one vertex in a cell wholly inside the other mesh and another in
    a cell wholly outside it. Such a pose can never be culled, so the broad phase is not asked
    about it (False means "not known", not "apart")."""
    out = np.zeros(poses.shape[0], np.bool_)
    aseen = np.zeros((ancomp, 2), np.bool_)
    bseen = np.zeros((bncomp, 2), np.bool_)
    for ip in range(poses.shape[0]):
        R = poses[ip, :3, :3]
        t = poses[ip, :3, 3]
        out[ip] = _shell_straddles(BV0, bcomp, bseen, R, t, False, agrid) or _shell_straddles(
            AV, acomp, aseen, R, t, True, bgrid
        )
    return out


@inner(nogil=True, error_model="numpy")
def classify_vertices(
    R, t, hand_mesh, hand, object_mesh, obj, hand_grid, object_grid, scratch, code, token, ferr
):  # fmt: skip
    """Stage "classify" of a pose (``docs/exact-backend.md``, "Method", steps 1, 4 and 5):
    every vertex's status against the other mesh, after the search (`search.trace_pairs`) has
    recorded the crossings.

    Object vertices (moved: ``scratch.object_V``) get their status in the hand's grid, hand
    vertices theirs in the object's grid (moved by ``x -> R^T (x - t)``), parts none of whose
    own edges is crossed as a whole; then unknown vertices take a neighbour's status across an
    edge, flipped by the edge's crossings, and a shell with none known gets `ray_status`.
    With ``code`` other than `OK` (the search stopped), only the statuses from the grids are
    set. ``token`` is the last stamp the point tests used; ``ferr`` bounds how far a hand vertex
    moved into the object's frame lies from where the pose's inverse puts it
    (`hand_statuses`). Returns (code, token): `DEGENERATE` where a point test is uncertain.
    """
    AV, AF = hand_mesh.vertices, hand_mesh.faces
    BV0, BF, BV = object_mesh.vertices, object_mesh.faces, scratch.object_V
    AS, BS, uniform = scratch.hand_status, scratch.object_status, scratch.uniform
    queue, xq = scratch.queue, scratch.point
    acnt, bcnt = scratch.work.hand_count, scratch.work.object_count
    cell_rep = hand.parts
    object_statuses(BS, BV, hand_grid)
    crossed, epart, arec = scratch.work.part_crossed, hand.edge_part, scratch.work.hand_rec
    for k in range(scratch.work.nrec[0]):
        if epart[arec.edge[k]] >= 0:
            crossed[epart[arec.edge[k]]] = True
    hand_statuses(AS, AV, R, t, object_grid, cell_rep, crossed, code == OK, uniform, ferr)
    crossed[:] = False
    if code == OK:
        u = resolve(
            AS, hand_mesh.adj_start, hand_mesh.adj_vertex, hand_mesh.adj_edge, acnt, queue,
            cell_rep, uniform,
        )  # fmt: skip
        while u >= 0 and code == OK:
            # A component with no vertex of known status (a small shell wholly in cells
            # the object's surface touches): one exact point test in the object's frame.
            for k in range(3):
                xq[k] = (
                    R[0, k] * (AV[u, 0] - t[0])
                    + R[1, k] * (AV[u, 1] - t[1])
                    + R[2, k] * (AV[u, 2] - t[2])
                )
            token += 1
            AS[u] = ray_status(xq, BV0, BF, object_grid, scratch.object_stamp, token, ferr)
            if AS[u] < 0:
                code = DEGENERATE
            else:
                queue[0] = u
                spread(
                    AS, hand_mesh.adj_start, hand_mesh.adj_vertex, hand_mesh.adj_edge, acnt,
                    queue, 1,
                )  # fmt: skip
                u = next_unknown(AS, u + 1, cell_rep, uniform)
    if code == OK:
        u = resolve(
            BS, object_mesh.adj_start, object_mesh.adj_vertex, object_mesh.adj_edge, bcnt,
            queue, obj.parts, obj.whole,
        )  # fmt: skip
        while u >= 0 and code == OK:
            token += 1
            BS[u] = ray_status(BV[u], AV, AF, hand_grid, scratch.hand_stamp, token, 0.0)
            if BS[u] < 0:
                code = DEGENERATE
            else:
                queue[0] = u
                spread(
                    BS, object_mesh.adj_start, object_mesh.adj_vertex, object_mesh.adj_edge,
                    bcnt, queue, 1,
                )  # fmt: skip
                u = next_unknown(BS, u + 1, obj.parts, obj.whole)
    return code, token
