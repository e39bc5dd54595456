"""Stage "seeds" of the exact kernel (numba): candidate face pairs from which `search` traces
the curves where the two surfaces cross.

Every such curve is closed. Either it crosses an edge of the object, or it lies in one object
face; then it is a plane's section of the hand, visits each hand face once (a plane cuts a
triangle in one segment) and moves from face to face across hand edges: a cycle of the hand's
dual graph, so it crosses a co-tree edge of the hand (`prepare.cotree_edges`). Two searches
therefore find a pair on every curve: each object edge near the hand's surface against the
hand faces listed in the hand-grid cells it passes (`object_edge_seeds`, in the hand's frame),
and each co-tree edge near the object's surface against the object faces listed in the
object-grid cells it touches (`cotree_seeds`, in the object's frame); runs of edges far from
the other surface are skipped first (`near_runs`). Both searches pass what they meet through
the seeds' filters (`filters`), whose tolerances exceed their rounding (and, in the object's
frame, the pose's departure from a rotation): they may keep a pair that does not cross, which
its evaluation rejects, and never drop one that does. See "Method", step 2, in
``docs/exact-backend.md``.

Long because each search is one kernel whose loops over edges, cells and listed faces share
their locals: a call per cell would pass arrays and update their reference counts.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.cells import surface_cells_in
from exactgrasp.backends.exact.filters import (
    cell_row,
    cell_survivors,
    filter_row,
    may_cross,
    piece_box,
    piece_meets_cell,
    sphere_meets_cell,
)
from exactgrasp.backends.exact.tables import (
    BOX_MAX,
    BOX_MIN,
    CHUNK,
    COTREE_CHUNK,
    SPHERE_CENTRE,
    SPHERE_RADIUS,
)
from exactgrasp.backends.exact.tolerances import FILTER_ERR, GRID_MARGIN, PLANE_TOL
from exactgrasp.compiling import inner

#: `near_runs` scans the cells of a run's box only up to this many (long edges make big runs).
SCAN_CELLS = 27


@inner(nogil=True, error_model="numpy")
def frame_defect(R):
    """How far R (3, 3) is from a rotation: the largest entry of ``|R^T R - I|``. Moving a
    point back by ``R^T`` instead of the inverse errs by at most about this times its length."""
    worst = 0.0
    for i in range(3):
        for j in range(3):
            dot = R[0, i] * R[0, j] + R[1, i] * R[1, j] + R[2, i] * R[2, j]
            worst = max(worst, abs(dot - (1.0 if i == j else 0.0)))
    return worst


@inner(nogil=True, error_model="numpy")
def near_runs(runs, R, t, inverse, stretch, grow, scan, grid, rng, parent, per, near):
    """Which runs of segments may come near a grid's surface (``near``, one per run):
    the bounding sphere of each run (``runs`` (k, 4): centre, radius), moved by ``x -> R x + t``
    (or by ``x -> R^T (x - t)`` with ``inverse``) into the grid's frame, its radius times
    ``stretch`` (at least 1: R may stretch lengths a little) and grown by ``stretch - 1`` times
    the centre's distance and by ``grow``, must hold a surface cell in its bounding box and, with
    ``scan``,
    meet the box and the slab of what one of them holds (`tables.CellGrid.bounds`; worth it
    where runs are small against the cells, and done where the box spans at most `SCAN_CELLS`
    cells). Where ``parent`` is not empty, run k is tested only
    if ``parent[k // per]`` (its block is near). ``rng``: scratch (3, 2)."""
    lo, h, n, table, PT = grid.corner, grid.cell, grid.shape, grid.surface_table, grid.bounds
    cs = grid.cell_start
    ih = 1.0 / h
    margin = GRID_MARGIN * h
    n1, n2 = n[1], n[2]
    levels = parent.shape[0] > 0
    for k in range(runs.shape[0]):
        if levels and not parent[k // per]:
            near[k] = False
            continue
        c0, c1, c2 = runs[k, SPHERE_CENTRE], runs[k, SPHERE_CENTRE + 1], runs[k, SPHERE_CENTRE + 2]
        if inverse:
            c0, c1, c2 = c0 - t[0], c1 - t[1], c2 - t[2]
        r = (
            runs[k, SPHERE_RADIUS] * stretch
            + margin
            + grow
            + (stretch - 1.0) * (abs(c0) + abs(c1) + abs(c2))
        )
        ok = True
        m0 = m1 = m2 = 0.0
        for d in range(3):
            if inverse:
                m = R[0, d] * c0 + R[1, d] * c1 + R[2, d] * c2
            else:
                m = R[d, 0] * c0 + R[d, 1] * c1 + R[d, 2] * c2 + t[d]
            if d == 0:
                m0 = m
            elif d == 1:
                m1 = m
            else:
                m2 = m
            i0 = int(np.floor((m - r - lo[d]) * ih))
            i1 = int(np.floor((m + r - lo[d]) * ih))
            if i1 < 0 or i0 >= n[d]:
                ok = False
                break
            rng[d, 0] = max(i0, 0)
            rng[d, 1] = min(i1, n[d] - 1)
        ok = ok and surface_cells_in(table, n, rng) > 0
        cells = (
            (rng[0, 1] - rng[0, 0] + 1) * (rng[1, 1] - rng[1, 0] + 1) * (rng[2, 1] - rng[2, 0] + 1)
        )
        if ok and scan and cells <= SCAN_CELLS:
            # The sphere against what each surface cell in its box holds.
            ok = False
            for i in range(rng[0, 0], rng[0, 1] + 1):
                for j in range(rng[1, 0], rng[1, 1] + 1):
                    for kk in range(rng[2, 0], rng[2, 1] + 1):
                        c = (i * n1 + j) * n2 + kk
                        if cs[c + 1] == cs[c]:
                            continue
                        row = cell_row(PT, c)
                        ok = ok | sphere_meets_cell(row, (m0, m1, m2), r, margin)
        near[k] = ok


@inner(nogil=True, error_model="numpy")
def _append_seed(seeds, n, t, s):
    """Pair (hand face t, object face s) as row n of ``seeds`` unless row n - 1 holds it: the new
    count, or -1 when the buffer is full."""
    if n > 0 and seeds[n - 1, 0] == t and seeds[n - 1, 1] == s:
        return n
    if n >= seeds.shape[0]:
        return -1
    seeds[n, 0] = t
    seeds[n, 1] = s
    return n + 1


@inner(nogil=True, error_model="numpy")
def object_edge_seeds(object_mesh, obj, hand, hand_grid, BV, near, gscale, work, n):
    """Candidate pairs of the object's edges near the hand's surface (runs ``near``, see
    `near_runs`): each edge walks the hand-grid cells it passes (a 3-D line walk, moved
    vertices ``BV``), and the hand faces listed there whose cell-clipped box meets the edge's
    piece in the cell and that pass the plane and edge tests give the pair (hand face, the
    edge's first face).
    Appended to ``work.seeds`` from row ``n``; returns the new count, or -1 when the buffer is
    full. ``gscale`` bounds every coordinate of the pose.

    A crossing point lies in some cell the edge passes, and the face holding it is listed
    there with its box clipped to that cell (both grown by `GRID_MARGIN`, far above the walk's
    rounding).

    Long because it is one loop: numba does not inline stage functions that read the
    tables' arrays, and as calls they cost reference counting on every candidate (measured
    slower; see docs/exact-backend.md, "Code layout")."""
    BE, BET, order = object_mesh.edges, object_mesh.edge_faces, obj.edge_order
    FL, FE, CBB, PT = hand.filters, hand.filter_err, hand_grid.boxes, hand_grid.bounds
    lo, h, dims = hand_grid.corner, hand_grid.cell, hand_grid.shape
    cs, ct, table = hand_grid.cell_start, hand_grid.cell_faces, hand_grid.surface_table
    gs, GB = hand_grid.group_start, hand_grid.groups
    seeds, rng, buf = work.seeds, work.cell_range, work.survivors
    ih = 1.0 / h
    margin = GRID_MARGIN * h
    ptol = PLANE_TOL * h
    n0, n1, n2 = dims[0], dims[1], dims[2]
    for r in range(near.shape[0]):
        if not near[r]:
            continue
        for kk in range(r * CHUNK, min(r * CHUNK + CHUNK, order.shape[0])):
            f = order[kk]
            u, v = BE[f, 0], BE[f, 1]
            px, py, pz = BV[u, 0], BV[u, 1], BV[u, 2]
            qx, qy, qz = BV[v, 0], BV[v, 1], BV[v, 2]
            start, end = (px, py, pz), (qx, qy, qz)
            # The edge's box of cells must hold a surface cell.
            inside = True
            for d in range(3):
                a = px if d == 0 else (py if d == 1 else pz)
                b = qx if d == 0 else (qy if d == 1 else qz)
                i0 = int(np.floor((min(a, b) - margin - lo[d]) * ih))
                i1 = int(np.floor((max(a, b) + margin - lo[d]) * ih))
                if i1 < 0 or i0 >= dims[d]:
                    inside = False
                    break
                rng[d, 0] = max(i0, 0)
                rng[d, 1] = min(i1, dims[d] - 1)
            if not inside or surface_cells_in(table, dims, rng) == 0:
                continue
            s1 = BET[f, 0]
            dx, dy, dz = qx - px, qy - py, qz - pz
            # The parameter range [l0, l1] of the edge inside the grid's box.
            l0, l1 = 0.0, 1.0
            for d in range(3):
                o = (px if d == 0 else (py if d == 1 else pz)) - lo[d]
                dd = dx if d == 0 else (dy if d == 1 else dz)
                size = dims[d] * h
                if dd == 0.0:
                    if o < 0.0 or o > size:
                        l0 = 2.0
                    continue
                ta, tb = -o / dd, (size - o) / dd
                l0 = max(l0, min(ta, tb))
                l1 = min(l1, max(ta, tb))
            if l0 > l1:
                continue
            # Line walk (Amanatides and Woo): the cells in order, each with its piece
            # [lam_a, lam_b] of the edge; consecutive pieces share their ends.
            ix = min(max(int(np.floor((px + l0 * dx - lo[0]) * ih)), 0), n0 - 1)
            iy = min(max(int(np.floor((py + l0 * dy - lo[1]) * ih)), 0), n1 - 1)
            iz = min(max(int(np.floor((pz + l0 * dz - lo[2]) * ih)), 0), n2 - 1)
            sx = 1 if dx > 0 else -1
            sy = 1 if dy > 0 else -1
            sz = 1 if dz > 0 else -1
            tx = (lo[0] + (ix + (1 if dx > 0 else 0)) * h - px) / dx if dx != 0 else np.inf
            ty = (lo[1] + (iy + (1 if dy > 0 else 0)) * h - py) / dy if dy != 0 else np.inf
            tz = (lo[2] + (iz + (1 if dz > 0 else 0)) * h - pz) / dz if dz != 0 else np.inf
            gx = h / abs(dx) if dx != 0 else np.inf
            gy = h / abs(dy) if dy != 0 else np.inf
            gz = h / abs(dz) if dz != 0 else np.inf
            lam_a = l0
            while True:
                lam_b = min(tx, ty, tz, l1)
                c = (ix * n1 + iy) * n2 + iz
                if cs[c + 1] > cs[c]:
                    ax_, ay_, az_ = px + lam_a * dx, py + lam_a * dy, pz + lam_a * dz
                    bx_, by_, bz_ = px + lam_b * dx, py + lam_b * dy, pz + lam_b * dz
                    a, b = (ax_, ay_, az_), (bx_, by_, bz_)
                    box = piece_box(a, b, margin)
                    if piece_meets_cell(cell_row(PT, c), a, b, box, margin):
                        m = cell_survivors(cs, gs, GB, CBB, c, box, buf)
                        # The survivors against the piece itself (not its box): the three axes
                        # d × e_k separating a segment from a box, with one branch each.
                        dx_, dy_, dz_ = bx_ - ax_, by_ - ay_, bz_ - az_
                        adx, ady, adz = abs(dx_), abs(dy_), abs(dz_)
                        slack = 4.0 * margin * (adx + ady + adz)
                        kept = 0
                        for j in range(m):
                            q = buf[j]
                            hx = 0.5 * (CBB[q, BOX_MAX] - CBB[q, BOX_MIN])
                            hy = 0.5 * (CBB[q, BOX_MAX + 1] - CBB[q, BOX_MIN + 1])
                            hz = 0.5 * (CBB[q, BOX_MAX + 2] - CBB[q, BOX_MIN + 2])
                            cx = 0.5 * (CBB[q, BOX_MAX] + CBB[q, BOX_MIN]) - ax_
                            cy = 0.5 * (CBB[q, BOX_MAX + 1] + CBB[q, BOX_MIN + 1]) - ay_
                            cz = 0.5 * (CBB[q, BOX_MAX + 2] + CBB[q, BOX_MIN + 2]) - az_
                            apart = (
                                (abs(dz_ * cy - dy_ * cz) > adz * hy + ady * hz + slack)
                                | (abs(dx_ * cz - dz_ * cx) > adz * hx + adx * hz + slack)
                                | (abs(dy_ * cx - dx_ * cy) > ady * hx + adx * hy + slack)
                            )
                            buf[kept] = q
                            kept += 0 if apart else 1
                        for j in range(kept):
                            ft = ct[buf[j]]
                            # Both ends beyond the tolerance on one side: no crossing. Else the
                            # crossing point must not lie beyond it outside an edge of the face.
                            eps = (FE[ft] + FILTER_ERR) * gscale
                            if not may_cross(filter_row(FL, ft), start, end, eps, ptol, gscale):
                                continue
                            n = _append_seed(seeds, n, ft, s1)
                            if n < 0:
                                return -1
                if lam_b >= l1:
                    break
                lam_a = lam_b
                if tx <= ty and tx <= tz:
                    ix += sx
                    tx += gx
                    if ix < 0 or ix >= n0:
                        break
                elif ty <= tz:
                    iy += sy
                    ty += gy
                    if iy < 0 or iy >= n1:
                        break
                else:
                    iz += sz
                    tz += gz
                    if iz < 0 or iz >= n2:
                        break
    return n


@inner(nogil=True, error_model="numpy")
def cotree_seeds(hand_mesh, hand, obj, object_grid, R, t, near, gscale, ferr, hcell, work, n):
    """Candidate pairs of the hand's co-tree edges near the object's surface (runs ``near``,
    see `near_runs`): each edge, moved into the object's frame by ``x -> R^T (x - t)``, against
    the object faces listed in the object-grid cells its box touches, those that `_keeps`
    giving the pair (the edge's first face, object face). Appended to ``work.seeds`` from row
    ``n``; returns the new count, or -1 when the buffer is full.

    ``ferr`` bounds how far a point moved back differs from where the pose's inverse puts it
    (rounding and `frame_defect`): it widens the box and every plane tolerance. ``gscale``
    bounds every coordinate, ``hcell`` is the hand grid's cell (the least plane tolerance is
    the kernel's, `PLANE_TOL` of it)."""
    AV, AE, AET, cot = hand_mesh.vertices, hand_mesh.edges, hand_mesh.edge_faces, hand.cotree
    FL, FE, PT, CBB = obj.filters, obj.filter_err, object_grid.bounds, object_grid.boxes
    lo, h, dims = object_grid.corner, object_grid.cell, object_grid.shape
    cs, ct = object_grid.cell_start, object_grid.cell_faces
    gs, GB = object_grid.group_start, object_grid.groups
    seeds, buf = work.seeds, work.survivors
    ih = 1.0 / h
    grow = GRID_MARGIN * h + ferr
    ptol = PLANE_TOL * max(h, hcell) + 2.0 * ferr
    n1, n2 = dims[1], dims[2]
    r00, r01, r02 = R[0, 0], R[0, 1], R[0, 2]
    r10, r11, r12 = R[1, 0], R[1, 1], R[1, 2]
    r20, r21, r22 = R[2, 0], R[2, 1], R[2, 2]
    t0, t1, t2 = t[0], t[1], t[2]
    for r in range(near.shape[0]):
        if not near[r]:
            continue
        for kk in range(r * COTREE_CHUNK, min(r * COTREE_CHUNK + COTREE_CHUNK, cot.shape[0])):
            e = cot[kk]
            u, v = AE[e, 0], AE[e, 1]
            a0, a1, a2 = AV[u, 0] - t0, AV[u, 1] - t1, AV[u, 2] - t2
            b0, b1, b2 = AV[v, 0] - t0, AV[v, 1] - t1, AV[v, 2] - t2
            px = r00 * a0 + r10 * a1 + r20 * a2
            py = r01 * a0 + r11 * a1 + r21 * a2
            pz = r02 * a0 + r12 * a1 + r22 * a2
            qx = r00 * b0 + r10 * b1 + r20 * b2
            qy = r01 * b0 + r11 * b1 + r21 * b2
            qz = r02 * b0 + r12 * b1 + r22 * b2
            start, end = (px, py, pz), (qx, qy, qz)
            t1f = AET[e, 0]
            # Pieces of at most a cell along every axis, each with its box of cells (tested with
            # the piece: a cell two pieces share is tested twice): a long edge visits few cells,
            # not its whole box.
            pieces = max(1, int(max(abs(qx - px), abs(qy - py), abs(qz - pz)) * ih))
            for w in range(pieces):
                la, lb = w / pieces, (w + 1) / pieces
                ax_, ay_, az_ = px + la * (qx - px), py + la * (qy - py), pz + la * (qz - pz)
                bx_, by_, bz_ = px + lb * (qx - px), py + lb * (qy - py), pz + lb * (qz - pz)
                a, b = (ax_, ay_, az_), (bx_, by_, bz_)
                box = piece_box(a, b, grow)
                (x0, y0, z0), (x1, y1, z1) = box
                i0 = max(int(np.floor((x0 - lo[0]) * ih)), 0)
                i1 = min(int(np.floor((x1 - lo[0]) * ih)), dims[0] - 1)
                j0 = max(int(np.floor((y0 - lo[1]) * ih)), 0)
                j1 = min(int(np.floor((y1 - lo[1]) * ih)), n1 - 1)
                k0 = max(int(np.floor((z0 - lo[2]) * ih)), 0)
                k1 = min(int(np.floor((z1 - lo[2]) * ih)), n2 - 1)
                for i in range(i0, i1 + 1):
                    for j in range(j0, j1 + 1):
                        for k in range(k0, k1 + 1):
                            c = (i * n1 + j) * n2 + k
                            if cs[c + 1] == cs[c]:
                                continue
                            # The piece against what the cell holds, then the listed faces'
                            # clipped boxes, each with one branch.
                            if not piece_meets_cell(cell_row(PT, c), a, b, box, grow):
                                continue
                            m = cell_survivors(cs, gs, GB, CBB, c, box, buf)
                            for jj in range(m):
                                s = ct[buf[jj]]
                                eps = (FE[s] + FILTER_ERR) * gscale + ferr
                                row = filter_row(FL, s)
                                keep = may_cross(row, start, end, eps, ptol, gscale)
                                if not keep:
                                    continue
                                n = _append_seed(seeds, n, t1f, s)
                                if n < 0:
                                    return -1
    return n
