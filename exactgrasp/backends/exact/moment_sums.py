"""The volume's derivatives in the kernel (numba): the moments ``(∫ n dA, ∫ x × n dA)`` of each
link's boundary inside the moved object, summed from what the volume's pass leaves behind.

The hand's boundary inside the object is, face by face, a polygon bounded by pieces of the
face's edges inside the object and by the segments where it crosses the object's surface: the
same pieces the volume's terms are made of (`sums`). For a planar piece boundary with unit
normal ``n``, the fan from the point of the plane nearest the origin gives per directed piece
``p → q``, with ``c = n · (p × q)``:

``∫ n dA += n c / 2`` and ``∫ x × n dA += ((p + q) × n) c / 6``.

Along an edge ``u → v`` the pieces inside are parameter intervals ``[a, b]``; with
``f = Σ (b - a)`` and ``h = Σ (b² - a²)`` the edge's share of face ``t1`` (which runs
``u → v``) is ``n1 (n1 · w) f / 2`` and ``((2 f u + h (v - u)) × n1)(n1 · w) / 6``,
``w = u × v``, and face ``t2`` (which runs ``v → u``) takes the same with ``n2`` and the
opposite sign. So the derivatives need only the statuses, the crossings and the traced
segments of the volume's pass (see `moments` for what the moments give). Imports numba,
numpy and `tables`.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.tables import MomentTables
from exactgrasp.compiling import inner

__all__ = ["hand_moments", "moment_tables"]


def _edge_shares(V, E, ET, unit, f, h):
    """The moments (e, 12) of each edge's inside share (fractions ``f``, ``h``; see the
    module) on its faces t1 (6) and t2 (6)."""
    u, v = V[E[:, 0]], V[E[:, 1]]
    w = np.cross(u, v)
    s = 2.0 * f[:, None] * u + h[:, None] * (v - u)
    out = np.empty((len(E), 12))
    for side, sign in ((0, 1.0), (1, -1.0)):
        n = unit[ET[:, side]]
        c = sign * np.einsum("ij,ij->i", n, w)
        out[:, 6 * side : 6 * side + 3] = n * (c * f / 2.0)[:, None]
        out[:, 6 * side + 3 : 6 * side + 6] = np.cross(s, n) * (c / 6.0)[:, None]
    return out


def moment_tables(mesh, hand, face_link: np.ndarray, n_links: int) -> MomentTables:
    """The hand's `tables.MomentTables`.

    Parameters
    ----------
    mesh : tables.MeshTables
        The hand's mesh as the kernel numbers it.
    hand : tables.HandTables
    face_link : numpy.ndarray, shape (m,) int64
        The link of each face of ``mesh``.
    n_links : int
    """
    V, E, ET = mesh.vertices, mesh.edges, mesh.edge_faces
    unit = hand.planes[:, :3]
    ones = np.ones(len(E))
    shares = _edge_shares(V, E, ET, unit, ones, ones)
    links = np.ascontiguousarray(face_link[ET])
    nparts = len(hand.parts) - 1
    own = np.flatnonzero(hand.edge_part >= 0)
    part = hand.edge_part[own] * n_links
    keys = np.concatenate([part + links[own, 0], part + links[own, 1]])
    vals = np.concatenate([shares[own, :6], shares[own, 6:]])
    uniq, inv = np.unique(keys, return_inverse=True)
    sums = np.zeros((len(uniq), 6))
    np.add.at(sums, inv, vals)
    start = np.zeros(nparts + 1, np.int64)
    np.cumsum(np.bincount(uniq // n_links, minlength=nparts), out=start[1:])
    return MomentTables(
        np.ascontiguousarray(face_link, dtype=np.int64),
        links.astype(np.int64),
        np.ascontiguousarray(shares),
        start,
        np.ascontiguousarray(uniq % n_links, dtype=np.int64),
        np.ascontiguousarray(sums),
    )


def empty_moment_tables() -> MomentTables:
    """`tables.MomentTables` with no rows: volumes only."""
    return MomentTables(
        np.zeros(0, np.int64),
        np.zeros((0, 2), np.int64),
        np.zeros((0, 12)),
        np.zeros(1, np.int64),
        np.zeros(0, np.int64),
        np.zeros((0, 6)),
    )


@inner(nogil=True, error_model="numpy")
def _add_share(G, l1, l2, V, u, v, n1x, n1y, n1z, n2x, n2y, n2z, f, h):
    """Add an edge's inside share (fractions f, h) to links l1 (face t1) and l2 (face t2)."""
    ux, uy, uz = V[u, 0], V[u, 1], V[u, 2]
    vx, vy, vz = V[v, 0], V[v, 1], V[v, 2]
    wx, wy, wz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    sx = 2.0 * f * ux + h * (vx - ux)
    sy = 2.0 * f * uy + h * (vy - uy)
    sz = 2.0 * f * uz + h * (vz - uz)
    c = n1x * wx + n1y * wy + n1z * wz
    G[l1, 0] += n1x * c * f / 2.0
    G[l1, 1] += n1y * c * f / 2.0
    G[l1, 2] += n1z * c * f / 2.0
    G[l1, 3] += (sy * n1z - sz * n1y) * c / 6.0
    G[l1, 4] += (sz * n1x - sx * n1z) * c / 6.0
    G[l1, 5] += (sx * n1y - sy * n1x) * c / 6.0
    c = -(n2x * wx + n2y * wy + n2z * wz)
    G[l2, 0] += n2x * c * f / 2.0
    G[l2, 1] += n2y * c * f / 2.0
    G[l2, 2] += n2z * c * f / 2.0
    G[l2, 3] += (sy * n2z - sz * n2y) * c / 6.0
    G[l2, 4] += (sz * n2x - sx * n2z) * c / 6.0
    G[l2, 5] += (sx * n2y - sy * n2x) * c / 6.0


@inner(nogil=True, error_model="numpy")
def _sort_small(x, n):
    """Insertion sort of x[:n] in place (an edge rarely crosses a surface more than twice)."""
    for i in range(1, n):
        y = x[i]
        j = i
        while j > 0 and x[j - 1] > y:
            x[j] = x[j - 1]
            j -= 1
        x[j] = y


@inner(nogil=True, error_model="numpy")
def hand_moments(hand_mesh, hand, mom, S, uniform, cnt, rec_e, rec_l, nrec, segs, ncross, G):
    """Moments ``(∫ n dA, ∫ x × n dA)`` of each link's boundary inside the object, added to
    ``G`` (L, 6), local coordinates, after a pose's volume pass.

    Parameters
    ----------
    hand_mesh : tables.MeshTables
    hand : tables.HandTables
    mom : tables.MomentTables
    S : numpy.ndarray, shape (hand n,) int8
        The hand's vertex statuses (1 inside the object).
    uniform : numpy.ndarray, shape (parts,) bool
        The parts classified whole.
    cnt, rec_e, rec_l, nrec : numpy.ndarray, int
        The hand edges' crossing counts and records (edge, parameter) and their number.
    segs : numpy.ndarray, shape (>= ncross, 7)
        The pose's crossing segments (hand face, p, q), `tables.Workspace.segments`.
    ncross : int
    G : numpy.ndarray, shape (L, 6)
    """
    V, E, ET = hand_mesh.vertices, hand_mesh.edges, hand_mesh.edge_faces
    adj_start, adj_vert, adj_edge = hand_mesh.adj_start, hand_mesh.adj_vertex, hand_mesh.adj_edge
    adj_split, reps, planes = hand.adj_split, hand.parts, hand.planes
    flink, elink, emom = mom.face_link, mom.edge_links, mom.edge_moments
    pstart, plink, pmom = mom.part_start, mom.part_link, mom.part_moments
    # The segments: hand face t's boundary runs p -> q.
    for k in range(ncross):
        t = int(segs[k, 0])
        lk = flink[t]
        nx, ny, nz = planes[t, 0], planes[t, 1], planes[t, 2]
        px, py, pz = segs[k, 1], segs[k, 2], segs[k, 3]
        qx, qy, qz = segs[k, 4], segs[k, 5], segs[k, 6]
        c = nx * (py * qz - pz * qy) + ny * (pz * qx - px * qz) + nz * (px * qy - py * qx)
        sx, sy, sz = px + qx, py + qy, pz + qz
        G[lk, 0] += nx * c / 2.0
        G[lk, 1] += ny * c / 2.0
        G[lk, 2] += nz * c / 2.0
        G[lk, 3] += (sy * nz - sz * ny) * c / 6.0
        G[lk, 4] += (sz * nx - sx * nz) * c / 6.0
        G[lk, 5] += (sx * ny - sy * nx) * c / 6.0
    # Whole edges inside, visited as `sums.edge_sum` visits them.
    for p in range(reps.shape[0] - 1):
        whole = uniform[p]
        if whole:
            if S[reps[p, 1]] != 1:
                continue
            for j in range(pstart[p], pstart[p + 1]):
                lk = plink[j]
                for d in range(6):
                    G[lk, d] += pmom[j, d]
        for u in range(reps[p, 1], reps[p + 1, 1]):
            if S[u] != 1:
                continue
            for k in range(adj_start[u], adj_split[u] if whole else adj_start[u + 1]):
                e = adj_edge[k]
                if cnt[e] != 0 or u >= adj_vert[k]:
                    continue
                l1, l2 = elink[e, 0], elink[e, 1]
                for d in range(6):
                    G[l1, d] += emom[e, d]
                    G[l2, d] += emom[e, 6 + d]
    # Crossed edges: their inside intervals, as `sums.crossed_sum` finds them.
    lam = np.empty(8)
    for i in range(nrec):
        e = rec_e[i]
        n = cnt[e]
        if n > 1:
            # Gathered once, at the edge's first record.
            first = True
            for j in range(i):
                if rec_e[j] == e:
                    first = False
                    break
            if not first:
                continue
            if n > lam.shape[0]:
                lam = np.empty(2 * n)
            m = 0
            for j in range(i, nrec):
                if rec_e[j] == e:
                    lam[m] = rec_l[j]
                    m += 1
            _sort_small(lam, m)
        else:
            lam[0] = rec_l[i]
            m = 1
        inside = S[E[e, 0]] == 1
        f = 0.0
        h = 0.0
        last = 0.0
        for j in range(m):
            if inside:
                f += lam[j] - last
                h += lam[j] * lam[j] - last * last
            last = lam[j]
            inside = not inside
        if inside:
            f += 1.0 - last
            h += 1.0 - last * last
        t1, t2 = ET[e, 0], ET[e, 1]
        _add_share(
            G, elink[e, 0], elink[e, 1], V, E[e, 0], E[e, 1],
            planes[t1, 0], planes[t1, 1], planes[t1, 2],
            planes[t2, 0], planes[t2, 1], planes[t2, 2], f, h,
        )  # fmt: skip
