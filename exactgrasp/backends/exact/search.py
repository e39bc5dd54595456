"""Stages "search" and "pairs" of the exact kernel (numba): which hand faces each object face
may cross, found through the hand's cell grid, and the crossing pairs' segment terms.

See "Method", steps 2 and 3, and "Why it is exact" in ``docs/exact-backend.md``. Imports
numba, `cells`, `pairs`, `predicates`, `tables` and `tolerances`.

Long because `object_faces` is one kernel whose nested loops share some 40 locals: a call per
face or cell would pass them (and update array reference counts) in the hottest loop.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from exactgrasp.backends.exact.cells import surface_cells_in, tri_cell_range
from exactgrasp.backends.exact.pairs import corner_crossing, pair, segment_term
from exactgrasp.backends.exact.predicates import CROSS, sign, tri_box_xyz
from exactgrasp.backends.exact.tables import CHUNK, DEGENERATE, OK, OVERFLOW
from exactgrasp.backends.exact.tolerances import (
    GRID_MARGIN,
    KAPPA_MAX,
    LINE_ROUNDING,
    LINE_SLACK,
    PARAM_ROUNDING,
    PLANE_ERR,
    PLANE_ERR_NONE,
    PLANE_TOL,
    WALK_SLACK,
    U,
)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def plane_err_coef(kappa):
    """Bound on the error of a plane distance with a face's unit normal, divided by the
    coordinate bound G (`PLANE_ERR`); `PLANE_ERR_NONE` beyond `KAPPA_MAX` (or no normal)."""
    if kappa <= KAPPA_MAX:
        return PLANE_ERR * U * (1.0 + kappa)
    return PLANE_ERR_NONE


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _box_meets_face(
    x0, y0, z0, x1, y1, z1, smin0, smin1, smin2, smax0, smax1, smax2, hx, hy, hz, sd, tol
):
    """Whether the box [x0, x1] × [y0, y1] × [z0, z1] may meet an object face: its box
    (smin*, smax*, already grown by the margin) and its plane (unit normal 2 (hx, hy, hz),
    offset sd; tolerance tol) are no separating axes. Evaluated in full, without branches (the
    outcome is hard to predict, see `object_faces`)."""
    return (
        (x0 <= smax0)
        & (x1 >= smin0)
        & (y0 <= smax1)
        & (y1 >= smin1)
        & (z0 <= smax2)
        & (z1 >= smin2)
        & (
            abs(hx * (x0 + x1) + hy * (y0 + y1) + hz * (z0 + z1) - sd)
            <= abs(hx) * (x1 - x0) + abs(hy) * (y1 - y0) + abs(hz) * (z1 - z0) + tol
        )
    )


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _lone(d0, d1, d2):
    """Index of the vertex alone on its side of a plane (signed distances d*, none zero,
    not all of one sign): the two edges from it are the ones that cross the plane."""
    if (d0 > 0) == (d1 > 0):
        return 2
    if (d0 > 0) == (d2 > 0):
        return 1
    return 0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _on_line(x0, x1, x2, d0, d1, d2, k, span, err, rho):
    """Where a triangle's two crossing edges meet a plane, projected on a direction (that of
    the plane's line with another plane, as computed): (a, b, error bound), a on the edge from
    the lone vertex k to corner k + 1 (face corner k's edge), b on the edge from k to corner
    k + 2 (corner k + 2's edge). x* are the vertices' projections on that direction, d* their
    signed distances to the plane, all farther than twice their error bound ``err``; ``span``
    bounds every projected difference of the corners, ``rho`` the projections' rounding."""
    if k == 0:
        xk, xi, xj, dk, di, dj = x0, x1, x2, d0, d1, d2
    elif k == 1:
        xk, xi, xj, dk, di, dj = x1, x2, x0, d1, d2, d0
    else:
        xk, xi, xj, dk, di, dj = x2, x0, x1, d2, d0, d1
    ri = 1.0 / (abs(dk) + abs(di))
    rj = 1.0 / (abs(dk) + abs(dj))
    a = xk + (xi - xk) * (abs(dk) * ri)
    b = xk + (xj - xk) * (abs(dk) * rj)
    # The exact point's projection is xk + lam* (xi - xk) with |lam - lam*| <= 4 err ri
    # (`param_err`), so a errs by span times that, plus the rounding of the projections.
    return a, b, span * (4.0 * err * max(ri, rj) + PARAM_ROUNDING) + rho


@njit(cache=True, nogil=True, error_model="numpy")
def object_faces(
    hand_mesh, hand, hand_grid, object_mesh, obj, BV, BD, BN, W, gscale, gb, stamp0, near
):  # fmt: skip
    """Stages "search" and "pairs" of a pose (``docs/exact-backend.md``, "Method", steps 2
    and 3): all segment terms of the object's faces against the hand. Finds, through the hand's
    cell grid, the hand faces each object face may cross and evaluates each pair: on the
    planes' common line where floating point certainly decides, else with `pairs.pair`.
    Returns (segment sum, its error bound, crossings, pairs tried, code); stops at the first
    degenerate pair or overflow (code `DEGENERATE` / `OVERFLOW`, else `OK`).

    Parameters
    ----------
    hand_mesh, object_mesh : tables.MeshTables
    hand : tables.HandTables
    hand_grid : tables.CellGrid
    obj : tables.ObjectTables
    BV, BD, BN : numpy.ndarray, shape (object n, 3), (object m, 3), (object m, 3)
        The moved object's vertices, face ``D`` and normals (`sums.face_terms`).
    W : tables.Workspace
        Records the crossings and marks the hand cells reached (``W.cell_reached``).
    gscale, gb : float
        Bounds on every coordinate of the pose, and on the moved object's.
    stamp0 : int
        Unique per pose: hand faces are stamped ``stamp0 + s`` once paired with object face s.
    near : numpy.ndarray of bool
        The object's face runs that may come near the hand's surface (`near_chunks`).

    Every floating-point decision has a tolerance at least twice its error bound: a plane
    test of a face with the face's own bound (`plane_err_coef` of its conditioning, times the
    coordinate bound ``gscale``; hand faces' coefficients in ``hand.planes[:, 4]``), at least
    `PLANE_TOL` of a cell; the box and walk filters likewise. ``obj.d_cost`` (object faces, over
    the coordinate bound ``gb``) and ``hand.planes[:, 5]`` (hand faces, absolute) are what each
    face's rounded ``D`` costs its terms (`prepare.face_d_coefs`).

    The loop over faces lives here, not in the caller, so that the tables are unpacked once
    per pose: unpacking them per face cost more than the whole search."""
    AV, AF = hand_mesh.vertices, hand_mesh.faces
    ATE, ATO = hand_mesh.face_edges, hand_mesh.face_owns
    BF, BTE, BTO = object_mesh.faces, object_mesh.face_edges, object_mesh.face_owns
    AD, CBB, AP = hand.D, hand.cell_boxes, hand.planes
    nxt, PT, Bdc = hand.next_listed, hand.cell_bounds, obj.d_cost
    alo, ah, an = hand_grid.corner, hand_grid.cell, hand_grid.shape
    acs, act, atable = hand_grid.cell_start, hand_grid.cell_faces, hand_grid.surface_table
    iah = 1.0 / ah
    margin = GRID_MARGIN * ah
    # Plane distances below this may be sign-uncertain in floating point; far above rounding.
    ptol = PLANE_TOL * ah
    acnt, bcnt, nrec, stamp = W.hand_count, W.object_count, W.nrec, W.stamp
    P, sg, dt, rng = W.points, W.signs, W.dists, W.cell_range
    cellmark, buf = W.cell_reached, W.survivors
    arec, brec = W.hand_rec, W.object_rec
    arec_e, arec_l, arec_d = arec.edge, arec.lam, arec.err
    brec_e, brec_l, brec_d = brec.edge, brec.lam, brec.err
    cap = arec_e.shape[0]
    seg = 0.0
    segerr = 0.0
    run = 0.0
    ncross = 0
    npairs = 0
    for s in range(BF.shape[0]):
        if not near[s // CHUNK]:
            continue
        if not tri_cell_range(BV, BF, s, alo, ah, an, margin, rng):
            continue
        if surface_cells_in(atable, an, rng) == 0:
            continue
        # Corners as scalars: array views in these loops would cost atomic reference counts.
        i0, i1, i2 = BF[s, 0], BF[s, 1], BF[s, 2]
        sa0, sa1, sa2 = BV[i0, 0], BV[i0, 1], BV[i0, 2]
        sb0, sb1, sb2 = BV[i1, 0], BV[i1, 1], BV[i1, 2]
        sc0, sc1, sc2 = BV[i2, 0], BV[i2, 1], BV[i2, 2]
        smax0 = max(sa0, sb0, sc0) + margin
        smax1 = max(sa1, sb1, sc1) + margin
        smax2 = max(sa2, sb2, sc2) + margin
        smin0 = min(sa0, sb0, sc0) - margin
        smin1 = min(sa1, sb1, sc1) - margin
        smin2 = min(sa2, sb2, sc2) - margin
        nrm = np.sqrt(BN[s, 0] ** 2 + BN[s, 1] ** 2 + BN[s, 2] ** 2)
        inv = 1.0 / nrm if nrm > 0 else 0.0
        # The face's conditioning |b - a| |c - a| / |N| widens its tolerances (slivers).
        l1 = (sb0 - sa0) ** 2 + (sb1 - sa1) ** 2 + (sb2 - sa2) ** 2
        l2 = (sc0 - sa0) ** 2 + (sc1 - sa1) ** 2 + (sc2 - sa2) ** 2
        eps_s = plane_err_coef(np.sqrt(l1 * l2) * inv if nrm > 0 else np.inf) * gscale
        tol_e = max(ptol, 2.0 * eps_s)
        beta_s = Bdc[s] * gb
        nx, ny, nz = BN[s, 0] * inv, BN[s, 1] * inv, BN[s, 2] * inv
        hx, hy, hz = 0.5 * nx, 0.5 * ny, 0.5 * nz
        sd = nx * sa0 + ny * sa1 + nz * sa2
        # Walk the columns along the normal's dominant axis d and visit only the cells the face's
        # plane passes through (with a margin); the separating-axis test then decides.
        d = 0
        if abs(ny) > abs(nx):
            d = 1
        if abs(nz) > max(abs(nx), abs(ny)):
            d = 2
        a = (d + 1) % 3
        b = (d + 2) % 3
        nd = nx if d == 0 else (ny if d == 1 else nz)
        na_ = nx if a == 0 else (ny if a == 1 else nz)
        nb_ = nx if b == 0 else (ny if b == 1 else nz)
        stride_a = an[1] * an[2] if a == 0 else (an[2] if a == 1 else 1)
        stride_b = an[1] * an[2] if b == 0 else (an[2] if b == 1 else 1)
        stride_d = an[1] * an[2] if d == 0 else (an[2] if d == 1 else 1)
        # Over a column's cross-section (grown by the margin) the plane's coordinate along d
        # spans its value at the centre plus or minus `spread`.
        inv_nd = 1.0 / nd if nrm > 0 else 0.0
        spread = (abs(na_) + abs(nb_)) * abs(inv_nd) * (0.5 * ah + margin)
        slack = max(WALK_SLACK * ah, 4.0 * eps_s)
        for ia in range(rng[a, 0], rng[a, 1] + 1):
            za = sd - na_ * (alo[a] + (ia + 0.5) * ah)
            for ib in range(rng[b, 0], rng[b, 1] + 1):
                d0, d1 = rng[d, 0], rng[d, 1]
                if nrm > 0:
                    z = (za - nb_ * (alo[b] + (ib + 0.5) * ah)) * inv_nd
                    d0 = max(d0, int(np.floor((z - spread - slack - alo[d]) * iah)))
                    d1 = min(d1, int(np.floor((z + spread + slack - alo[d]) * iah)))
                base = ia * stride_a + ib * stride_b
                # Only the cells holding hand faces: `nxt` jumps to the next one along d.
                cur = nxt[d, base + d0 * stride_d] if d0 <= d1 else an[d]
                while cur <= d1:
                    c = base + cur * stride_d
                    cur = nxt[d, c + stride_d] if cur + 1 < an[d] else an[d]
                    # Separating axes between the face and what the cell holds of the faces it
                    # lists (cheapest first): the coordinate axes against the listed faces'
                    # common bounding box clipped to the cell, the listed faces' mean normal (a
                    # thin slab where the hand's surface is nearly flat), the face's own normal
                    # against that box, all with one branch (each alone would often
                    # mispredict); last the face's edges against the box (`tri_box`). A crossing
                    # outside this cell is found in another cell that both faces touch.
                    x0, y0, z0 = PT[c, 5], PT[c, 6], PT[c, 7]
                    x1, y1, z1 = PT[c, 8], PT[c, 9], PT[c, 10]
                    pa0 = PT[c, 0] * sa0 + PT[c, 1] * sa1 + PT[c, 2] * sa2
                    pa1 = PT[c, 0] * sb0 + PT[c, 1] * sb1 + PT[c, 2] * sb2
                    pa2 = PT[c, 0] * sc0 + PT[c, 1] * sc1 + PT[c, 2] * sc2
                    ok = (
                        _box_meets_face(
                            x0, y0, z0, x1, y1, z1, smin0, smin1, smin2, smax0, smax1, smax2,
                            hx, hy, hz, sd, max(margin, 2.0 * eps_s),
                        )
                        & (min(pa0, pa1, pa2) <= PT[c, 4])
                        & (max(pa0, pa1, pa2) >= PT[c, 3])
                    )  # fmt: skip
                    if not ok:
                        continue
                    if not tri_box_xyz(
                        0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (z0 + z1),
                        0.5 * (x1 - x0) + margin, 0.5 * (y1 - y0) + margin,
                        0.5 * (z1 - z0) + margin,
                        sa0, sa1, sa2, sb0, sb1, sb2, sc0, sc1, sc2,
                    ):  # fmt: skip
                        continue
                    cellmark[c] = True
                    # The listed faces' boxes against the object face's box and plane, without
                    # branches (half of them pass: a branch per test would mispredict); the
                    # survivors are gathered in `buf`.
                    m = 0
                    for q in range(acs[c], acs[c + 1]):
                        x0, y0, z0 = CBB[q, 0], CBB[q, 1], CBB[q, 2]
                        x1, y1, z1 = CBB[q, 3], CBB[q, 4], CBB[q, 5]
                        ok = _box_meets_face(
                            x0, y0, z0, x1, y1, z1, smin0, smin1, smin2, smax0, smax1, smax2,
                            hx, hy, hz, sd, max(2.0 * ptol, 2.0 * eps_s),
                        )  # fmt: skip
                        buf[m] = q
                        m += 1 if ok else 0
                    for j in range(m):
                        q = buf[j]
                        ft = act[q]
                        if stamp[ft] == stamp0 + s:
                            continue
                        stamp[ft] = stamp0 + s
                        # Both faces against the other's plane in floating point, with a tolerance
                        # far above rounding; the exact tests follow in _pair.
                        v0, v1, v2 = AF[ft, 0], AF[ft, 1], AF[ft, 2]
                        e0 = AV[v0, 0] * nx + AV[v0, 1] * ny + AV[v0, 2] * nz - sd
                        e1 = AV[v1, 0] * nx + AV[v1, 1] * ny + AV[v1, 2] * nz - sd
                        e2 = AV[v2, 0] * nx + AV[v2, 1] * ny + AV[v2, 2] * nz - sd
                        if ((e0 > tol_e) & (e1 > tol_e) & (e2 > tol_e)) | (
                            (e0 < -tol_e) & (e1 < -tol_e) & (e2 < -tol_e)
                        ):
                            continue
                        f0 = sa0 * AP[ft, 0] + sa1 * AP[ft, 1] + sa2 * AP[ft, 2] - AP[ft, 3]
                        f1 = sb0 * AP[ft, 0] + sb1 * AP[ft, 1] + sb2 * AP[ft, 2] - AP[ft, 3]
                        f2 = sc0 * AP[ft, 0] + sc1 * AP[ft, 1] + sc2 * AP[ft, 2] - AP[ft, 3]
                        eps_t = AP[ft, 4] * gscale
                        tol_f = max(ptol, 2.0 * eps_t)
                        if ((f0 > tol_f) & (f1 > tol_f) & (f2 > tol_f)) | (
                            (f0 < -tol_f) & (f1 < -tol_f) & (f2 < -tol_f)
                        ):
                            continue
                        # Both planes straddled and every vertex clear of the other plane:
                        # the faces' crossing segments on the planes' common line decide in
                        # floating point where every end of one is far (beyond rounding) from
                        # both ends of the other. Anything closer goes to the exact `pair`.
                        # Scalars only in here: passing arrays to a function that is not
                        # inlined costs atomic reference counts on every call.
                        sided = (min(abs(e0), abs(e1), abs(e2)) > tol_e) & (
                            min(abs(f0), abs(f1), abs(f2)) > tol_f
                        )
                        if sided:
                            ux, uy, uz = AP[ft, 0], AP[ft, 1], AP[ft, 2]
                            Dx = uy * nz - uz * ny
                            Dy = uz * nx - ux * nz
                            Dz = ux * ny - uy * nx
                            t0x, t0y, t0z = AV[v0, 0], AV[v0, 1], AV[v0, 2]
                            t1x, t1y, t1z = AV[v1, 0], AV[v1, 1], AV[v1, 2]
                            t2x, t2y, t2z = AV[v2, 0], AV[v2, 1], AV[v2, 2]
                            # Extent of the six corners (the object face's by its box).
                            ext = max(
                                max(smax0, t0x, t1x, t2x) - min(smin0, t0x, t1x, t2x),
                                max(smax1, t0y, t1y, t2y) - min(smin1, t0y, t1y, t2y),
                                max(smax2, t0z, t1z, t2z) - min(smin2, t0z, t1z, t2z),
                            )
                            # Any direction serves: the four points lie on the common line,
                            # so their order along it is their order here (or reversed).
                            dnorm = abs(Dx) + abs(Dy) + abs(Dz)
                            span = ext * dnorm
                            rho = LINE_ROUNDING * U * dnorm * gscale
                            kt = _lone(e0, e1, e2)
                            at, bt, errt = _on_line(
                                Dx * t0x + Dy * t0y + Dz * t0z,
                                Dx * t1x + Dy * t1y + Dz * t1z,
                                Dx * t2x + Dy * t2y + Dz * t2z,
                                e0, e1, e2, kt, span, eps_s, rho,
                            )  # fmt: skip
                            ks = _lone(f0, f1, f2)
                            as_, bs, errs = _on_line(
                                Dx * sa0 + Dy * sa1 + Dz * sa2,
                                Dx * sb0 + Dy * sb1 + Dz * sb2,
                                Dx * sc0 + Dy * sc1 + Dz * sc2,
                                f0, f1, f2, ks, span, eps_t, rho,
                            )  # fmt: skip
                            lot, hit = min(at, bt), max(at, bt)
                            los, his = min(as_, bs), max(as_, bs)
                            tol = (errt + errs) * LINE_SLACK
                            if max(los - hit, lot - his) > tol:
                                continue
                            npairs += 1
                            if min(abs(at - as_), abs(at - bs), abs(bt - as_), abs(bt - bs)) > tol:
                                # The overlap's two ends, each where an edge of one face crosses
                                # the other face (`corner_crossing`, on scalars); the face owning
                                # that edge records it, in its own mesh's arrays (a routine
                                # taking them, even inlined, would update reference counts).
                                npt = 0
                                nstart = 0
                                px = py = pz = qx = qy = qz = 0.0
                                ep = eq = 0.0
                                for w in range(4):
                                    if w < 2:
                                        if not (los < (at if w == 0 else bt) < his):
                                            continue
                                        k0 = kt if w == 0 else (kt + 2) % 3
                                        lam, dl, first, cx_, cy_, cz_, perr = corner_crossing(
                                            0, k0, v0, v1, v2, t0x, t0y, t0z, t1x, t1y, t1z,
                                            t2x, t2y, t2z, e0, e1, e2, eps_s, gscale,
                                        )  # fmt: skip
                                        if ATO[ft, k0]:
                                            if nrec[0] >= cap:
                                                return seg, segerr, ncross, npairs, OVERFLOW
                                            ed = ATE[ft, k0]
                                            arec_e[nrec[0]] = ed
                                            arec_l[nrec[0]] = lam
                                            arec_d[nrec[0]] = dl
                                            nrec[0] += 1
                                            acnt[ed] += 1
                                    else:
                                        if not (lot < (as_ if w == 2 else bs) < hit):
                                            continue
                                        k0 = ks if w == 2 else (ks + 2) % 3
                                        lam, dl, first, cx_, cy_, cz_, perr = corner_crossing(
                                            1, k0, i0, i1, i2, sa0, sa1, sa2, sb0, sb1, sb2,
                                            sc0, sc1, sc2, f0, f1, f2, eps_t, gscale,
                                        )  # fmt: skip
                                        if BTO[s, k0]:
                                            if nrec[1] >= cap:
                                                return seg, segerr, ncross, npairs, OVERFLOW
                                            ed = BTE[s, k0]
                                            brec_e[nrec[1]] = ed
                                            brec_l[nrec[1]] = lam
                                            brec_d[nrec[1]] = dl
                                            nrec[1] += 1
                                            bcnt[ed] += 1
                                    # The segment runs from its start to its end along n_t x n_s.
                                    if first:
                                        px, py, pz, ep = cx_, cy_, cz_, perr
                                        nstart += 1
                                    else:
                                        qx, qy, qz, eq = cx_, cy_, cz_, perr
                                    npt += 1
                                if npt != 2 or nstart != 1:
                                    return seg, segerr, ncross, npairs, DEGENERATE
                                term, terr = segment_term(
                                    px, py, pz, qx, qy, qz, ep, eq, AD[ft, 0], AD[ft, 1],
                                    AD[ft, 2], BD[s, 0], BD[s, 1], BD[s, 2],
                                )  # fmt: skip
                                seg += term
                                run += abs(seg)
                                segerr += terr + AP[ft, 5] + beta_s
                                ncross += 1
                                continue
                            sg[0, 0], sg[0, 1], sg[0, 2] = sign(e0), sign(e1), sign(e2)
                            sg[1, 0], sg[1, 1], sg[1, 2] = sign(f0), sign(f1), sign(f2)
                            dt[0, 0], dt[0, 1], dt[0, 2], dt[0, 3] = e0, e1, e2, eps_s
                            dt[1, 0], dt[1, 1], dt[1, 2], dt[1, 3] = f0, f1, f2, eps_t
                        else:
                            npairs += 1
                        term, terr, pc = pair(
                            ft, s, AF, ATE, ATO, AV, BF, BTE, BTO, BV, AD, BD, acnt, bcnt,
                            arec, brec, nrec, P, sg, dt, sided, gscale,
                        )  # fmt: skip
                        if pc >= DEGENERATE:
                            code = DEGENERATE if pc == DEGENERATE else OVERFLOW
                            return seg, segerr, ncross, npairs, code
                        if pc == CROSS:
                            seg += term
                            run += abs(seg)
                            segerr += terr + AP[ft, 5] + beta_s
                            ncross += 1
    return seg, segerr + U * run, ncross, npairs, OK


@njit(cache=True, nogil=True, error_model="numpy")
def near_chunks(chunks, R, t, hand_grid, rng, near):
    """Which runs of `CHUNK` object faces may come near the hand's surface (``near``, one per
    run): the bounding sphere of each run (``chunks`` (k, 4): centre in the object's frame,
    radius), moved by ``x -> R x + t``, must hold a surface cell of the hand grid in its
    bounding box (``rng``: scratch (3, 2))."""
    alo, ah, an = hand_grid.corner, hand_grid.cell, hand_grid.shape
    atable = hand_grid.surface_table
    iah = 1.0 / ah
    margin = GRID_MARGIN * ah
    for k in range(chunks.shape[0]):
        r = chunks[k, 3] + margin
        ok = True
        for d in range(3):
            m = R[d, 0] * chunks[k, 0] + R[d, 1] * chunks[k, 1] + R[d, 2] * chunks[k, 2] + t[d]
            i0 = int(np.floor((m - r - alo[d]) * iah))
            i1 = int(np.floor((m + r - alo[d]) * iah))
            if i1 < 0 or i0 >= an[d]:
                ok = False
                break
            rng[d, 0] = max(i0, 0)
            rng[d, 1] = min(i1, an[d] - 1)
        near[k] = ok and surface_cells_in(atable, an, rng) > 0
