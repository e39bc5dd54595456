"""Stage "pairs" of the exact kernel (numba): the crossing face pairs, traced along the curves
where the surfaces cross from the seeds' candidates, and their segment terms.

See "Method", steps 2 and 3, and "Why it is exact" in ``docs/exact-backend.md``.

Long because `trace_pairs` is one kernel whose loops share some 40 locals: a call per pair
would pass them (and update array reference counts) in the hottest loop.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.pairs import corner_crossing, pair, segment_term
from exactgrasp.backends.exact.predicates import CROSS, sign
from exactgrasp.backends.exact.tables import (
    DEGENERATE,
    DIST_ERR,
    FACE_ACROSS,
    FACE_CORNERS,
    FACE_D,
    FACE_D_COST,
    FACE_EDGES,
    FACE_ERR_COEF,
    FACE_LINK,
    FACE_NORMAL,
    FACE_OFFSET,
    FACE_OWNS,
    FACE_VERTICES,
    GROW,
    OK,
    OVERFLOW,
    POINT_CORNER,
    POINT_MESH,
    POINT_STARTS,
    POINT_XYZ,
    SEGMENT_FACE,
    SEGMENT_LINK,
    SEGMENT_NORMAL,
    SEGMENT_OBJECT_FACE,
    SEGMENT_P,
    SEGMENT_Q,
)
from exactgrasp.backends.exact.tolerances import (
    GRID_MARGIN,
    KAPPA_MAX,
    LINE_ROUNDING,
    LINE_SLACK,
    PARAM_ROUNDING,
    PLANE_ERR,
    PLANE_ERR_NONE,
    PLANE_TOL,
    U,
)
from exactgrasp.compiling import inner

#: Multiplier of the pair table's hash (Fibonacci hashing; int64 products wrap).
HASH_MULTIPLIER = -7046029254386353131
#: The pair table's hash takes the product's bits from this one up.
HASH_SHIFT = 24


@inner(nogil=True, error_model="numpy")
def plane_err_coef(kappa):
    """Bound on the error of a plane distance with a face's unit normal, divided by the
    coordinate bound G (`PLANE_ERR`); `PLANE_ERR_NONE` beyond `KAPPA_MAX` (or no normal)."""
    if kappa <= KAPPA_MAX:
        return PLANE_ERR * U * (1.0 + kappa)
    return PLANE_ERR_NONE


@inner(nogil=True, error_model="numpy")
def _lone(d0, d1, d2):
    """Index of the vertex alone on its side of a plane (signed distances d*, none zero,
    not all of one sign): the two edges from it are the ones that cross the plane."""
    if (d0 > 0) == (d1 > 0):
        return 2
    if (d0 > 0) == (d2 > 0):
        return 1
    return 0


@inner(nogil=True, error_model="numpy")
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


@inner(nogil=True, error_model="numpy")
def _line_ends(corners, d, direction, span, err, rho):
    """Where a face (corners (3, each (x, y, z)), signed distances ``d`` (3) to the other
    plane, erring by up to ``err``) crosses that plane, projected on ``direction``: its lone
    vertex k (`_lone`), then `_on_line`'s a, b and error bound. Scalars only."""
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = corners
    Dx, Dy, Dz = direction
    k = _lone(d[0], d[1], d[2])
    a, b, e = _on_line(
        Dx * ax + Dy * ay + Dz * az,
        Dx * bx + Dy * by + Dz * bz,
        Dx * cx + Dy * cy + Dz * cz,
        d[0], d[1], d[2], k, span, err, rho,
    )  # fmt: skip
    return k, a, b, e


@inner(nogil=True, error_model="numpy")
def trace_pairs(
    hand_mesh, hand, object_mesh, obj, BV, BD, BN, W, nseeds, gscale, gb, hcell, token
):  # fmt: skip
    """Stage "pairs" of a pose (``docs/exact-backend.md``, "Method", steps 2 and 3): every
    crossing face pair and its segment term, by tracing the curves where the surfaces cross
    from the candidate pairs ``W.seeds[:nseeds]`` (`seeds`).

    A crossing pair's segment ends where an edge of one face crosses the other face; the next
    pair along the curve shares that crossing: the face across that edge with the other face
    (its segment starts there). So from each candidate that crosses, the curve is followed
    pair by pair until it closes; every pair is evaluated once (``W.pair_keys``: an
    open-addressing table tagged with ``token``, unique per call). Each pair is evaluated on
    the planes' common line where floating point certainly decides, else with `pairs.pair`.
    A pair reached along a curve must cross; one that does not is an inconsistency.

    Returns (segment sum, its error bound, crossings, pairs evaluated, code), code `OK`,
    `DEGENERATE` (an uncertain sign or an inconsistency), `OVERFLOW` (records full) or `GROW`
    (the pair table is half full: the caller enlarges it and computes the pose again).

    Parameters
    ----------
    hand_mesh, object_mesh : tables.MeshTables
    hand : tables.HandTables
    obj : tables.ObjectTables
    BV, BD, BN : numpy.ndarray, shape (object n, 3), (object m, 3), (object m, 3)
        The moved object's vertices, face ``D`` and normals (`sums.face_terms`).
    W : tables.Workspace
        Records the crossings.
    nseeds : int
        Candidate pairs in ``W.seeds``.
    gscale, gb : float
        Bounds on every coordinate of the pose, and on the moved object's.
    hcell : float
        The hand grid's cell edge (the plane tests' least tolerance is `PLANE_TOL` of it).
    token : int
        Unique per call (positive, below 2**30): the pair table's tag.

    Every floating-point decision has a tolerance at least twice its error bound: a plane
    test of a face with the face's own bound (`plane_err_coef` of its conditioning, times the
    coordinate bound ``gscale``; hand faces' coefficients in their records), at least
    `PLANE_TOL` of a hand cell. ``obj.d_cost`` (object faces, over the coordinate bound
    ``gb``) and the hand face records' ``dcost`` (absolute) are what each face's rounded ``D``
    costs its terms (`prepare.face_d_coefs`).

    Long because it is one loop: numba does not inline stage functions that read the
    tables' arrays, and as calls they cost reference counting on every face pair (measured
    slower; see docs/exact-backend.md, "Code layout")."""
    AV, AF = hand_mesh.vertices, hand_mesh.faces
    ATE, ATO = hand_mesh.face_edges, hand_mesh.face_owns
    BF, BTE, BTO = object_mesh.faces, object_mesh.face_edges, object_mesh.face_owns
    BET = object_mesh.edge_faces
    AD, Bdc = hand.D, obj.d_cost
    HF, HI = hand.face_records, hand.face_links
    margin = GRID_MARGIN * hcell
    # Plane distances below this may be sign-uncertain in floating point; far above rounding.
    ptol = PLANE_TOL * hcell
    acnt, bcnt, nrec = W.hand_count, W.object_count, W.nrec
    P, sg, dt = W.points, W.signs, W.dists
    keys, tags, seeds = W.pair_keys, W.pair_tags, W.seeds
    # A slot of this call holds 2 token (no crossing) or 2 token + 1 (a crossing).
    tag = 2 * token
    mask = keys.shape[0] - 1
    arec, brec = W.hand_rec, W.object_rec
    arec_e, arec_l, arec_d = arec.edge, arec.lam, arec.err
    brec_e, brec_l, brec_d = brec.edge, brec.lam, brec.err
    cap = arec_e.shape[0]
    mb = BF.shape[0]
    seg = 0.0
    segerr = 0.0
    run = 0.0
    ncross = 0
    npairs = 0
    s_cur = -1
    i0 = i1 = i2 = 0
    sa0 = sa1 = sa2 = sb0 = sb1 = sb2 = sc0 = sc1 = sc2 = 0.0
    smin0 = smin1 = smin2 = smax0 = smax1 = smax2 = 0.0
    nx = ny = nz = sd = eps_s = tol_e = beta_s = 0.0
    px = py = pz = qx = qy = qz = 0.0
    s_corners = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    segs = W.segments
    keep = segs.shape[0] > 0
    # What the exact `pair` reads, in tuples of exactly those arrays.
    hand_side = (AF, ATE, ATO, AV, AD, acnt, arec)
    object_side = (BF, BTE, BTO, BV, BD, bcnt, brec)
    scratch = (nrec, P, sg, dt)
    for k in range(nseeds):
        ft, s = seeds[k, 0], seeds[k, 1]
        chained = False
        while True:
            key = ft * mb + s
            h = ((key * HASH_MULTIPLIER) >> HASH_SHIFT) & mask
            while (tags[h] >> 1) == token and keys[h] != key:
                h = (h + 1) & mask
            if (tags[h] >> 1) == token:
                # Evaluated already: the rest of its curve is traced (or being traced).
                if chained and tags[h] == tag:
                    return seg, segerr, ncross, npairs, DEGENERATE
                break
            if 2 * (npairs + 1) > mask + 1:
                return seg, segerr, ncross, npairs, GROW
            tags[h] = tag
            keys[h] = key
            npairs += 1
            if s != s_cur:
                s_cur = s
                # Corners as scalars: array views in these loops would cost atomic reference
                # counts.
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
                # The face's conditioning |b - a| |c - a| / |N| widens its tolerances.
                l1 = (sb0 - sa0) ** 2 + (sb1 - sa1) ** 2 + (sb2 - sa2) ** 2
                l2 = (sc0 - sa0) ** 2 + (sc1 - sa1) ** 2 + (sc2 - sa2) ** 2
                eps_s = plane_err_coef(np.sqrt(l1 * l2) * inv if nrm > 0 else np.inf) * gscale
                tol_e = max(ptol, 2.0 * eps_s)
                beta_s = Bdc[s] * gb
                nx, ny, nz = BN[s, 0] * inv, BN[s, 1] * inv, BN[s, 2] * inv
                sd = nx * sa0 + ny * sa1 + nz * sa2
                s_corners = ((sa0, sa1, sa2), (sb0, sb1, sb2), (sc0, sc1, sc2))
            # Both faces against the other's plane in floating point, with a tolerance far
            # above rounding; the exact tests follow in `pair`.
            # The hand face's record (`HandTables.face_records`, ``face_links``): a few cache
            # lines instead of one per array and vertex.
            v0, v1, v2 = (
                HI[ft, FACE_VERTICES],
                HI[ft, FACE_VERTICES + 1],
                HI[ft, FACE_VERTICES + 2],
            )
            t0x, t0y, t0z = (
                HF[ft, FACE_CORNERS],
                HF[ft, FACE_CORNERS + 1],
                HF[ft, FACE_CORNERS + 2],
            )
            t1x, t1y, t1z = (
                HF[ft, FACE_CORNERS + 3],
                HF[ft, FACE_CORNERS + 4],
                HF[ft, FACE_CORNERS + 5],
            )
            t2x, t2y, t2z = (
                HF[ft, FACE_CORNERS + 6],
                HF[ft, FACE_CORNERS + 7],
                HF[ft, FACE_CORNERS + 8],
            )
            t_corners = ((t0x, t0y, t0z), (t1x, t1y, t1z), (t2x, t2y, t2z))
            e0 = t0x * nx + t0y * ny + t0z * nz - sd
            e1 = t1x * nx + t1y * ny + t1z * nz - sd
            e2 = t2x * nx + t2y * ny + t2z * nz - sd
            crossing = False
            exit_row = exit_k = 0
            term = terr = 0.0
            f0 = f1 = f2 = eps_t = tol_f = 0.0
            sided = False
            apart = ((e0 > tol_e) & (e1 > tol_e) & (e2 > tol_e)) | (
                (e0 < -tol_e) & (e1 < -tol_e) & (e2 < -tol_e)
            )
            if not apart:
                f0 = (
                    sa0 * HF[ft, FACE_NORMAL]
                    + sa1 * HF[ft, FACE_NORMAL + 1]
                    + sa2 * HF[ft, FACE_NORMAL + 2]
                    - HF[ft, FACE_OFFSET]
                )
                f1 = (
                    sb0 * HF[ft, FACE_NORMAL]
                    + sb1 * HF[ft, FACE_NORMAL + 1]
                    + sb2 * HF[ft, FACE_NORMAL + 2]
                    - HF[ft, FACE_OFFSET]
                )
                f2 = (
                    sc0 * HF[ft, FACE_NORMAL]
                    + sc1 * HF[ft, FACE_NORMAL + 1]
                    + sc2 * HF[ft, FACE_NORMAL + 2]
                    - HF[ft, FACE_OFFSET]
                )
                eps_t = HF[ft, FACE_ERR_COEF] * gscale
                tol_f = max(ptol, 2.0 * eps_t)
                apart = ((f0 > tol_f) & (f1 > tol_f) & (f2 > tol_f)) | (
                    (f0 < -tol_f) & (f1 < -tol_f) & (f2 < -tol_f)
                )
            decided = apart
            if not apart:
                # Both planes straddled and every vertex clear of the other plane: the faces'
                # crossing segments on the planes' common line decide in floating point where
                # every end of one is far (beyond rounding) from both ends of the other.
                # Anything closer goes to the exact `pair`. Scalars only in here: passing
                # arrays to a function that is not inlined costs atomic reference counts.
                sided = (min(abs(e0), abs(e1), abs(e2)) > tol_e) & (
                    min(abs(f0), abs(f1), abs(f2)) > tol_f
                )
                if sided:
                    ux, uy, uz = (
                        HF[ft, FACE_NORMAL],
                        HF[ft, FACE_NORMAL + 1],
                        HF[ft, FACE_NORMAL + 2],
                    )
                    Dx = uy * nz - uz * ny
                    Dy = uz * nx - ux * nz
                    Dz = ux * ny - uy * nx
                    # Extent of the six corners (the object face's by its box).
                    ext = max(
                        max(smax0, t0x, t1x, t2x) - min(smin0, t0x, t1x, t2x),
                        max(smax1, t0y, t1y, t2y) - min(smin1, t0y, t1y, t2y),
                        max(smax2, t0z, t1z, t2z) - min(smin2, t0z, t1z, t2z),
                    )
                    # Any direction serves: the four points lie on the common line, so their
                    # order along it is their order here (or reversed).
                    dnorm = abs(Dx) + abs(Dy) + abs(Dz)
                    span = ext * dnorm
                    rho = LINE_ROUNDING * U * dnorm * gscale
                    D = (Dx, Dy, Dz)
                    kt, at, bt, errt = _line_ends(t_corners, (e0, e1, e2), D, span, eps_s, rho)
                    ks, as_, bs, errs = _line_ends(s_corners, (f0, f1, f2), D, span, eps_t, rho)
                    lot, hit = min(at, bt), max(at, bt)
                    los, his = min(as_, bs), max(as_, bs)
                    tol = (errt + errs) * LINE_SLACK
                    if max(los - hit, lot - his) > tol:
                        decided = True
                    elif min(abs(at - as_), abs(at - bs), abs(bt - as_), abs(bt - bs)) > tol:
                        # The overlap's two ends, each where an edge of one face crosses the
                        # other face (`corner_crossing`, on scalars); the face owning that edge
                        # records it, in its own mesh's arrays (a routine taking them, even
                        # inlined, would update reference counts).
                        npt = 0
                        nstart = 0
                        px = py = pz = qx = qy = qz = 0.0
                        ep = eq = 0.0
                        for w in range(4):
                            if w < 2:
                                if not (los < (at if w == 0 else bt) < his):
                                    continue
                                k0 = kt if w == 0 else (kt + 2) % 3
                                t_face = ((v0, v1, v2), t_corners, (e0, e1, e2), eps_s)
                                lam, dl, first, point, perr = corner_crossing(
                                    0, k0, t_face, gscale
                                )
                                if HI[ft, FACE_OWNS + k0]:
                                    if nrec[0] >= cap:
                                        return seg, segerr, ncross, npairs, OVERFLOW
                                    ed = HI[ft, FACE_EDGES + k0]
                                    arec_e[nrec[0]] = ed
                                    arec_l[nrec[0]] = lam
                                    arec_d[nrec[0]] = dl
                                    nrec[0] += 1
                                    acnt[ed] += 1
                            else:
                                if not (lot < (as_ if w == 2 else bs) < hit):
                                    continue
                                k0 = ks if w == 2 else (ks + 2) % 3
                                s_face = ((i0, i1, i2), s_corners, (f0, f1, f2), eps_t)
                                lam, dl, first, point, perr = corner_crossing(
                                    1, k0, s_face, gscale
                                )
                                if BTO[s, k0]:
                                    if nrec[1] >= cap:
                                        return seg, segerr, ncross, npairs, OVERFLOW
                                    ed = BTE[s, k0]
                                    brec_e[nrec[1]] = ed
                                    brec_l[nrec[1]] = lam
                                    brec_d[nrec[1]] = dl
                                    nrec[1] += 1
                                    bcnt[ed] += 1
                            # The segment runs from its start to its end along n_t x n_s; the
                            # curve goes on across the end's edge.
                            if first:
                                (px, py, pz), ep = point, perr
                                nstart += 1
                            else:
                                (qx, qy, qz), eq = point, perr
                                exit_row = 0 if w < 2 else 1
                                exit_k = k0
                            npt += 1
                        if npt != 2 or nstart != 1:
                            return seg, segerr, ncross, npairs, DEGENERATE
                        D_t = (HF[ft, FACE_D], HF[ft, FACE_D + 1], HF[ft, FACE_D + 2])
                        D_s = (BD[s, 0], BD[s, 1], BD[s, 2])
                        term, terr = segment_term((px, py, pz), (qx, qy, qz), ep, eq, D_t, D_s)
                        crossing = True
                        decided = True
                    else:
                        sg[0, 0], sg[0, 1], sg[0, 2] = sign(e0), sign(e1), sign(e2)
                        sg[1, 0], sg[1, 1], sg[1, 2] = sign(f0), sign(f1), sign(f2)
                        dt[0, 0], dt[0, 1], dt[0, 2], dt[0, DIST_ERR] = e0, e1, e2, eps_s
                        dt[1, 0], dt[1, 1], dt[1, 2], dt[1, DIST_ERR] = f0, f1, f2, eps_t
                if not decided:
                    term, terr, pc = pair(ft, s, hand_side, object_side, scratch, sided, gscale)
                    if pc >= DEGENERATE:
                        code = DEGENERATE if pc == DEGENERATE else OVERFLOW
                        return seg, segerr, ncross, npairs, code
                    if pc == CROSS:
                        crossing = True
                        j = 0 if P[0, POINT_STARTS] == 0.0 else 1
                        exit_row = int(P[j, POINT_MESH])
                        exit_k = int(P[j, POINT_CORNER])
                        px, py, pz = (
                            P[1 - j, POINT_XYZ],
                            P[1 - j, POINT_XYZ + 1],
                            P[1 - j, POINT_XYZ + 2],
                        )
                        qx, qy, qz = P[j, POINT_XYZ], P[j, POINT_XYZ + 1], P[j, POINT_XYZ + 2]
            if not crossing:
                if chained:
                    return seg, segerr, ncross, npairs, DEGENERATE
                break
            tags[h] = tag + 1
            if keep:
                # The segment, for the derivatives (fewer crossings than pairs in the table).
                segs[ncross, SEGMENT_FACE] = ft
                (
                    segs[ncross, SEGMENT_P],
                    segs[ncross, SEGMENT_P + 1],
                    segs[ncross, SEGMENT_P + 2],
                ) = px, py, pz
                (
                    segs[ncross, SEGMENT_Q],
                    segs[ncross, SEGMENT_Q + 1],
                    segs[ncross, SEGMENT_Q + 2],
                ) = qx, qy, qz
                segs[ncross, SEGMENT_NORMAL], segs[ncross, SEGMENT_NORMAL + 1] = (
                    HF[ft, FACE_NORMAL],
                    HF[ft, FACE_NORMAL + 1],
                )
                segs[ncross, SEGMENT_NORMAL + 2], segs[ncross, SEGMENT_LINK] = (
                    HF[ft, FACE_NORMAL + 2],
                    HF[ft, FACE_LINK],
                )
                segs[ncross, SEGMENT_OBJECT_FACE] = s
            seg += term
            run += abs(seg)
            segerr += terr + HF[ft, FACE_D_COST] + beta_s
            ncross += 1
            chained = True
            # The next pair along the curve: across the end's edge.
            if exit_row == 0:
                ft = HI[ft, FACE_ACROSS + exit_k]
            else:
                ed = BTE[s, exit_k]
                s = BET[ed, 1] if BET[ed, 0] == s else BET[ed, 0]
    return seg, segerr + U * run, ncross, npairs, OK
