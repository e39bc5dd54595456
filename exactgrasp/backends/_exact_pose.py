"""Numba kernel computing hand ∩ moved object for a batch of poses (see `_exact_kernels`).

Meshes travel as tuples (built by `_exact_geometry.prepare_mesh`)::

    mesh = (V, F, E, ET, TE, TO, adj_start, adj_vert, adj_edge)
    grid = (lo, h, n, status, cell_start, cell_tris)

``E`` (e, 2) are the undirected edges ``u < v``; ``ET`` (e, 2) their faces ``t1`` (holding the
directed edge ``u → v``) and ``t2``; ``TE`` (m, 3) the edge of each face corner ``k → k+1`` and
``TO`` (m, 3) whether that face is the edge's ``t1``. The grid's ``status`` is 1 (inside),
0 (outside) or -1 (a cell touched by the surface), ``cell_start``/``cell_tris`` list the
faces touching each cell.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from exactgrasp.backends._exact_kernels import (
    edge_weight,
    face_terms,
    point_status,
    tri_box,
    tri_cell_range,
    winding_number,
)
from exactgrasp.backends._exact_pairs import pair

#: Per-pose result codes.
OK, CULLED, DEGENERATE, OVERFLOW = 0, 1, 2, 3
#: Columns of the per-pose statistics array.
STAT_PAIRS, STAT_CROSSING, STAT_CELLS_TOUCHED, STAT_CELLS_INSIDE, STAT_CELLS_OUTSIDE = range(5)
N_STATS = 5


@njit(cache=True, nogil=True)
def _resolve(S, adj_start, adj_vert, adj_edge, cnt, queue):
    """Give every vertex of unknown status (-1) the status of a neighbour, flipped by the
    parity of the crossings on the edge between them. Returns the first vertex still unknown
    (its component has no vertex of known status), or -1."""
    tail = 0
    for u in range(S.shape[0]):
        if S[u] != -1:
            continue
        for k in range(adj_start[u], adj_start[u + 1]):
            w = adj_vert[k]
            if S[w] >= 0:
                S[u] = S[w] ^ (cnt[adj_edge[k]] & 1)
                queue[tail] = u
                tail += 1
                break
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
    for u in range(S.shape[0]):
        if S[u] == -1:
            return u
    return -1


@njit(cache=True, nogil=True)
def _edge_sum(V, D, E, ET, S, cnt, rec_e, rec_l, nrec, Wpre):
    """Σ_e W_e f_e over the edges of one mesh; returns (sum, consistent).

    ``Wpre`` holds precomputed weights (fixed mesh) or is empty (weights computed here).
    Consistency: each edge's end statuses must differ by the parity of its crossings.
    """
    have = Wpre.shape[0] > 0
    total = 0.0
    for e in range(E.shape[0]):
        su = S[E[e, 0]]
        c = cnt[e]
        if S[E[e, 1]] != su ^ (c & 1):
            return 0.0, False
        if c == 0 and su == 1:
            total += Wpre[e] if have else edge_weight(V, D, E, ET, e)
    if nrec == 0:
        return total, True
    order = np.argsort(rec_e[:nrec])
    lam = np.empty(nrec)
    i = 0
    while i < nrec:
        e = rec_e[order[i]]
        j = i
        while j < nrec and rec_e[order[j]] == e:
            # Insertion sort: an edge rarely crosses the other surface more than twice.
            x = rec_l[order[j]]
            m = j - i
            while m > 0 and lam[m - 1] > x:
                lam[m] = lam[m - 1]
                m -= 1
            lam[m] = x
            j += 1
        inside = S[E[e, 0]] == 1
        frac = 0.0
        last = 0.0
        for m in range(j - i):
            if inside:
                frac += lam[m] - last
            last = lam[m]
            inside = not inside
        if inside:
            frac += 1.0 - last
        total += frac * (Wpre[e] if have else edge_weight(V, D, E, ET, e))
        i = j
    return total, True


@njit(cache=True, nogil=True, inline="always")
def _object_face(s, A, X, agrid, B, BV, BD, BN, W, margin, ptol):
    """All terms of object face s against the hand: finds the hand faces it may cross through
    the hand's cell grid and evaluates each pair. Returns (segment sum, crossings, pairs tried,
    code)."""
    AV, AF = A[0], A[1]
    AD, AN, ABB, AP = X[0], X[1], X[2], X[3]
    alo, ah, an, acs, act = agrid[0], agrid[1], agrid[2], agrid[4], agrid[5]
    acnt, bcnt, arec, brec, nrec, stamp, P, sg, dt, rng, cellmark = W
    BF = B[1]
    seg = 0.0
    ncross = 0
    npairs = 0
    if not tri_cell_range(BV, BF, s, alo, ah, an, margin, rng):
        return seg, ncross, npairs, OK
    sa, sb, sc = BV[BF[s, 0]], BV[BF[s, 1]], BV[BF[s, 2]]
    smax0 = max(sa[0], sb[0], sc[0]) + margin
    smax1 = max(sa[1], sb[1], sc[1]) + margin
    smax2 = max(sa[2], sb[2], sc[2]) + margin
    smin0 = min(sa[0], sb[0], sc[0]) - margin
    smin1 = min(sa[1], sb[1], sc[1]) - margin
    smin2 = min(sa[2], sb[2], sc[2]) - margin
    nrm = np.sqrt(BN[s, 0] ** 2 + BN[s, 1] ** 2 + BN[s, 2] ** 2)
    inv = 1.0 / nrm if nrm > 0 else 0.0
    nx, ny, nz = BN[s, 0] * inv, BN[s, 1] * inv, BN[s, 2] * inv
    sd = nx * sa[0] + ny * sa[1] + nz * sa[2]
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
    hh = 0.5 * ah + margin
    for ia in range(rng[a, 0], rng[a, 1] + 1):
        xa0 = alo[a] + ia * ah - margin
        xa1 = xa0 + ah + 2 * margin
        for ib in range(rng[b, 0], rng[b, 1] + 1):
            d0, d1 = rng[d, 0], rng[d, 1]
            if nrm > 0:
                xb0 = alo[b] + ib * ah - margin
                xb1 = xb0 + ah + 2 * margin
                lo_ = 1e300
                hi_ = -1e300
                for xa in (xa0, xa1):
                    for xb in (xb0, xb1):
                        z = (sd - na_ * xa - nb_ * xb) / nd
                        lo_ = min(lo_, z)
                        hi_ = max(hi_, z)
                slack = 1e-6 * ah
                d0 = max(d0, int(np.floor((lo_ - slack - alo[d]) / ah)))
                d1 = min(d1, int(np.floor((hi_ + slack - alo[d]) / ah)))
            for id_ in range(d0, d1 + 1):
                if d == 0:
                    i0, i1, i2 = id_, ia, ib
                elif d == 1:
                    i0, i1, i2 = ib, id_, ia
                else:
                    i0, i1, i2 = ia, ib, id_
                c = (i0 * an[1] + i1) * an[2] + i2
                if acs[c] == acs[c + 1]:
                    continue
                if not tri_box(
                    alo[0] + (i0 + 0.5) * ah,
                    alo[1] + (i1 + 0.5) * ah,
                    alo[2] + (i2 + 0.5) * ah,
                    hh,
                    sa,
                    sb,
                    sc,
                ):
                    continue
                cellmark[c] = True
                for q in range(acs[c], acs[c + 1]):
                    ft = act[q]
                    if stamp[ft] == s:
                        continue
                    stamp[ft] = s
                    if (
                        ABB[ft, 0] > smax0
                        or ABB[ft, 3] < smin0
                        or ABB[ft, 1] > smax1
                        or ABB[ft, 4] < smin1
                        or ABB[ft, 2] > smax2
                        or ABB[ft, 5] < smin2
                    ):
                        continue
                    # Both faces against the other's plane in floating point, with a tolerance
                    # far above rounding; the exact tests follow in _pair.
                    v0, v1, v2 = AF[ft, 0], AF[ft, 1], AF[ft, 2]
                    e0 = AV[v0, 0] * nx + AV[v0, 1] * ny + AV[v0, 2] * nz - sd
                    e1 = AV[v1, 0] * nx + AV[v1, 1] * ny + AV[v1, 2] * nz - sd
                    e2 = AV[v2, 0] * nx + AV[v2, 1] * ny + AV[v2, 2] * nz - sd
                    if (e0 > ptol and e1 > ptol and e2 > ptol) or (
                        e0 < -ptol and e1 < -ptol and e2 < -ptol
                    ):
                        continue
                    e0 = sa[0] * AP[ft, 0] + sa[1] * AP[ft, 1] + sa[2] * AP[ft, 2] - AP[ft, 3]
                    e1 = sb[0] * AP[ft, 0] + sb[1] * AP[ft, 1] + sb[2] * AP[ft, 2] - AP[ft, 3]
                    e2 = sc[0] * AP[ft, 0] + sc[1] * AP[ft, 1] + sc[2] * AP[ft, 2] - AP[ft, 3]
                    if (e0 > ptol and e1 > ptol and e2 > ptol) or (
                        e0 < -ptol and e1 < -ptol and e2 < -ptol
                    ):
                        continue
                    npairs += 1
                    term, pc = pair(
                        ft,
                        s,
                        A,
                        AV,
                        B,
                        BV,
                        AD,
                        AN,
                        BD,
                        BN,
                        acnt,
                        bcnt,
                        arec,
                        brec,
                        nrec,
                        P,
                        sg,
                        dt,
                    )
                    if pc >= 2:
                        return seg, ncross, npairs, (DEGENERATE if pc == 2 else OVERFLOW)
                    seg += term
                    ncross += pc
    return seg, ncross, npairs, OK


@njit(cache=True, nogil=True)
def _hand_status(AS, AV, R, t, bgrid, BV0, BF, u_only):
    """Status of hand vertices against the object (in its own frame); u_only >= 0 does one
    vertex with the winding number instead. Returns False when that number is uncertain."""
    blo, bh, bn, bstat = bgrid[0], bgrid[1], bgrid[2], bgrid[3]
    xb = np.empty(3)
    lo_, hi_ = (0, AV.shape[0]) if u_only < 0 else (u_only, u_only + 1)
    for i in range(lo_, hi_):
        for k in range(3):
            xb[k] = (
                R[0, k] * (AV[i, 0] - t[0])
                + R[1, k] * (AV[i, 1] - t[1])
                + R[2, k] * (AV[i, 2] - t[2])
            )
        if u_only < 0:
            AS[i] = point_status(xb, blo, bh, bn, bstat)
        else:
            w = winding_number(xb, BV0, BF)
            if abs(w - np.round(w)) > 0.1:
                return False
            AS[i] = int(np.round(w)) & 1
    return True


@njit(cache=True, nogil=True)
def pose_volumes(poses, A, X, agrid, B, bgrid, tiny, cap, out, codes, stats):
    """Volume of A ∩ (pose · B) for each pose; A (the hand) is fixed, B is in its own frame.

    ``X = (AD, AN, ABB, AP, cell_rep, AW)`` holds per-face data of A (`face_terms`, bounding
    boxes, unit plane), one vertex per surface cell of its grid and A's edge weights.
    ``codes[i]`` is OK, DEGENERATE or OVERFLOW (the caller recomputes those with a boolean);
    ``stats[i]`` counts pairs tried, crossing pairs, and A's surface cells touched /
    untouched inside / untouched outside.
    """
    AV, AF, AE, AET = A[0], A[1], A[2], A[3]
    BV0, BF, BE, BET = B[0], B[1], B[2], B[3]
    AD = X[0]
    cell_rep = X[4]
    alo, ah, an, astat, acs = agrid[0], agrid[1], agrid[2], agrid[3], agrid[4]
    na, nb = AV.shape[0], BV0.shape[0]
    mb = BF.shape[0]
    BV = np.empty_like(BV0)
    BD = np.empty((mb, 3))
    BN = np.empty((mb, 3))
    AS = np.empty(na, np.int64)
    BS = np.empty(nb, np.int64)
    acnt = np.zeros(AE.shape[0], np.int64)
    bcnt = np.zeros(BE.shape[0], np.int64)
    arec = (np.empty(cap, np.int64), np.empty(cap))
    brec = (np.empty(cap, np.int64), np.empty(cap))
    nrec = np.zeros(2, np.int64)
    stamp = np.full(AF.shape[0], -1, np.int64)
    cellmark = np.zeros(acs.shape[0] - 1, np.bool_)
    queue = np.empty(max(na, nb), np.int64)
    W = (
        acnt,
        bcnt,
        arec,
        brec,
        nrec,
        stamp,
        np.empty((2, 3)),
        np.empty((2, 3), np.int64),
        np.empty((2, 3)),
        np.empty((3, 2), np.int64),
        cellmark,
    )
    noW = np.empty(0)
    margin = 1e-9 * ah
    # Plane distances below this may be sign-uncertain in floating point; far above rounding.
    ptol = 1e-9 * ah
    for ip in range(poses.shape[0]):
        R = poses[ip, :3, :3]
        t = poses[ip, :3, 3]
        for i in range(nb):
            for k in range(3):
                BV[i, k] = R[k, 0] * BV0[i, 0] + R[k, 1] * BV0[i, 1] + R[k, 2] * BV0[i, 2] + t[k]
        face_terms(BV, BF, tiny, BD, BN)
        _hand_status(AS, AV, R, t, bgrid, BV0, BF, -1)
        for i in range(nb):
            BS[i] = point_status(BV[i], alo, ah, an, astat)
        acnt[:] = 0
        bcnt[:] = 0
        nrec[:] = 0
        stamp[:] = -1
        cellmark[:] = False
        seg = 0.0
        code = OK
        npairs = 0
        ncross = 0
        for s in range(mb):
            term, nc, npr, code = _object_face(s, A, X, agrid, B, BV, BD, BN, W, margin, ptol)
            seg += term
            ncross += nc
            npairs += npr
            if code != OK:
                break
        if code == OK:
            u = _resolve(AS, A[6], A[7], A[8], acnt, queue)
            while u >= 0 and code == OK:
                if not _hand_status(AS, AV, R, t, bgrid, BV0, BF, u):
                    code = DEGENERATE
                u = _resolve(AS, A[6], A[7], A[8], acnt, queue)
        if code == OK:
            u = _resolve(BS, B[6], B[7], B[8], bcnt, queue)
            while u >= 0 and code == OK:
                w = winding_number(BV[u], AV, AF)
                if abs(w - np.round(w)) > 0.1:
                    code = DEGENERATE
                BS[u] = int(np.round(w)) & 1
                u = _resolve(BS, B[6], B[7], B[8], bcnt, queue)
        if code == OK:
            sa_, oka = _edge_sum(AV, AD, AE, AET, AS, acnt, arec[0], arec[1], nrec[0], X[5])
            sb_, okb = _edge_sum(BV, BD, BE, BET, BS, bcnt, brec[0], brec[1], nrec[1], noW)
            if not (oka and okb):
                code = DEGENERATE
            out[ip] = sa_ + sb_ + seg
        codes[ip] = code
        stats[ip, STAT_PAIRS] = npairs
        stats[ip, STAT_CROSSING] = ncross
        touched = 0
        inside = 0
        for c in range(cell_rep.shape[0]):
            if cell_rep[c] < 0:
                continue
            if cellmark[c]:
                touched += 1
            elif AS[cell_rep[c]] == 1:
                inside += 1
        stats[ip, STAT_CELLS_TOUCHED] = touched
        stats[ip, STAT_CELLS_INSIDE] = inside
        stats[ip, STAT_CELLS_OUTSIDE] = (cell_rep >= 0).sum() - touched - inside
