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
segments of the volume's pass (see `moments` for what the moments give).
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.sums import _order_by_key
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


def _grouped(keys: np.ndarray, values: np.ndarray, n_links: int, n_groups: int):
    """Sums of ``values`` (k, 6) by ``keys`` = group * n_links + link: (CSR start per group
    (n_groups + 1,), link per entry, sums per entry)."""
    uniq, inv = np.unique(keys, return_inverse=True)
    sums = np.zeros((len(uniq), 6))
    np.add.at(sums, inv.reshape(-1), values)
    start = np.zeros(n_groups + 1, np.int64)
    np.cumsum(np.bincount(uniq // n_links, minlength=n_groups), out=start[1:])
    return start, np.ascontiguousarray(uniq % n_links, dtype=np.int64), sums


def moment_tables(mesh, hand, face_link: np.ndarray, n_links: int) -> MomentTables:
    """The hand's `tables.MomentTables`; also writes each face's link into
    ``hand.face_records[:, 18]`` (what the traced segments carry).

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
    # Each edge's shares, on its lower vertex (E holds u < v) and that vertex's part.
    low = np.concatenate([E[:, 0], E[:, 0]])
    link = np.concatenate([links[:, 0], links[:, 1]])
    vals = np.concatenate([shares[:, :6], shares[:, 6:]])
    n = len(V)
    vstart, vlink, vsums = _grouped(low * n_links + link, vals, n_links, n)
    single = (vstart[1:] - vstart[:-1]) == 1
    vertex_link = np.full(n, -1, np.int64)
    vertex_moments = np.zeros((n, 6))
    none = vstart[1:] == vstart[:-1]
    vertex_link[none] = 0  # no edge to a higher-numbered vertex: adds zeros
    vertex_link[single] = vlink[vstart[:-1][single]]
    vertex_moments[single] = vsums[vstart[:-1][single]]
    nparts = len(hand.parts) - 1
    part_of = np.searchsorted(hand.parts[:, 1], low, side="right") - 1
    pstart, plink, psums = _grouped(part_of * n_links + link, vals, n_links, nparts)
    hand.face_records[:, 18] = face_link
    return MomentTables(
        np.ascontiguousarray(face_link, dtype=np.int64),
        links.astype(np.int64),
        np.ascontiguousarray(shares),
        vertex_link,
        vertex_moments,
        pstart,
        plink,
        np.ascontiguousarray(psums),
    )


def empty_moment_tables() -> MomentTables:
    """`tables.MomentTables` with no rows: volumes only."""
    return MomentTables(
        np.zeros(0, np.int64),
        np.zeros((0, 2), np.int64),
        np.zeros((0, 12)),
        np.zeros(0, np.int64),
        np.zeros((0, 6)),
        np.zeros(1, np.int64),
        np.zeros(0, np.int64),
        np.zeros((0, 6)),
    )


@inner(nogil=True, error_model="numpy")
def _share(ux, uy, uz, vx, vy, vz, nx, ny, nz, f, h):
    """The moments (6 scalars) of the inside share (fractions f, h) of edge u -> v on a face
    with unit normal n that runs u -> v (negate them for the face that runs v -> u).
    Scalars only: a routine taking arrays would update reference counts per edge."""
    wx, wy, wz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    sx = 2.0 * f * ux + h * (vx - ux)
    sy = 2.0 * f * uy + h * (vy - uy)
    sz = 2.0 * f * uz + h * (vz - uz)
    c = nx * wx + ny * wy + nz * wz
    a = c * f / 2.0
    b = c / 6.0
    return (
        nx * a,
        ny * a,
        nz * a,
        (sy * nz - sz * ny) * b,
        (sz * nx - sx * nz) * b,
        (sx * ny - sy * nx) * b,
    )


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
def hand_moments(
    hand_mesh, hand, mom, S, uniform, cnt, rec_e, rec_l, nrec, multi, segs, ncross, G
):  # fmt: skip
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
    multi : numpy.ndarray, shape (>= nrec,) int64
        Scratch.
    segs : numpy.ndarray, shape (>= ncross, 7)
        The pose's crossing segments (hand face, p, q), `tables.Workspace.segments`.
    ncross : int
    G : numpy.ndarray, shape (L, 6)
    """
    V, E, ET = hand_mesh.vertices, hand_mesh.edges, hand_mesh.edge_faces
    adj_start, adj_vert, adj_edge = hand_mesh.adj_start, hand_mesh.adj_vertex, hand_mesh.adj_edge
    reps, planes = hand.parts, hand.planes
    elink, emom = mom.edge_links, mom.edge_moments
    vlink, vmom = mom.vertex_link, mom.vertex_moments
    pstart, plink, pmom = mom.part_start, mom.part_link, mom.part_moments
    # The segments: hand face t's boundary runs p -> q (its normal and link came with them).
    for k in range(ncross):
        px, py, pz = segs[k, 1], segs[k, 2], segs[k, 3]
        qx, qy, qz = segs[k, 4], segs[k, 5], segs[k, 6]
        nx, ny, nz = segs[k, 7], segs[k, 8], segs[k, 9]
        lk = int(segs[k, 10])
        c = nx * (py * qz - pz * qy) + ny * (pz * qx - px * qz) + nz * (px * qy - py * qx)
        sx, sy, sz = px + qx, py + qy, pz + qz
        G[lk, 0] += nx * c / 2.0
        G[lk, 1] += ny * c / 2.0
        G[lk, 2] += nz * c / 2.0
        G[lk, 3] += (sy * nz - sz * ny) * c / 6.0
        G[lk, 4] += (sz * nx - sx * nz) * c / 6.0
        G[lk, 5] += (sx * ny - sy * nx) * c / 6.0
    # Whole edges from every inside vertex to higher-numbered ones, crossed or not (the
    # crossed ones are corrected below; an uncrossed one from an inside vertex ends inside,
    # as `sums.edge_sum` checks): summed per part for parts classified whole, per vertex
    # (or edge by edge at a seam between links) for the others.
    for p in range(reps.shape[0] - 1):
        if uniform[p]:
            if S[reps[p, 1]] == 1:
                for j in range(pstart[p], pstart[p + 1]):
                    lk = plink[j]
                    for d in range(6):
                        G[lk, d] += pmom[j, d]
            continue
        for u in range(reps[p, 1], reps[p + 1, 1]):
            if S[u] != 1:
                continue
            lk = vlink[u]
            if lk >= 0:
                for d in range(6):
                    G[lk, d] += vmom[u, d]
                continue
            for k in range(adj_start[u], adj_start[u + 1]):
                if u >= adj_vert[k]:
                    continue
                e = adj_edge[k]
                l1, l2 = elink[e, 0], elink[e, 1]
                for d in range(6):
                    G[l1, d] += emom[e, d]
                    G[l2, d] += emom[e, 6 + d]
    # Crossed edges: their inside intervals (f, h per crossed edge, in ``fe``, ``ff``,
    # ``fh``), as `sums.crossed_sum` finds them: the records of edges crossed more than once
    # gathered in ``multi`` and sorted by edge.
    fe = np.empty(nrec, np.int64)
    ff = np.empty(nrec)
    fh = np.empty(nrec)
    ne = 0
    nm = 0
    for i in range(nrec):
        e = rec_e[i]
        if cnt[e] != 1:
            multi[nm] = i
            nm += 1
            continue
        lam = rec_l[i]
        fe[ne] = e
        # Inside from u: [0, lam], less the whole edge the walk above added.
        if S[E[e, 0]] == 1:
            ff[ne], fh[ne] = lam - 1.0, lam * lam - 1.0
        else:
            ff[ne], fh[ne] = 1.0 - lam, 1.0 - lam * lam
        ne += 1
    if nm > 0:
        key = np.empty(nm, np.int64)
        for i in range(nm):
            key[i] = rec_e[multi[i]]
        order = _order_by_key(key)
        lams = np.empty(nm)
        i = 0
        while i < nm:
            e = key[order[i]]
            j = i
            while j < nm and key[order[j]] == e:
                lams[j - i] = rec_l[multi[order[j]]]
                j += 1
            _sort_small(lams, j - i)
            inside = S[E[e, 0]] == 1
            f = 0.0
            h = 0.0
            last = 0.0
            for k in range(j - i):
                if inside:
                    f += lams[k] - last
                    h += lams[k] * lams[k] - last * last
                last = lams[k]
                inside = not inside
            if inside:
                f += 1.0 - last
                h += 1.0 - last * last
            if S[E[e, 0]] == 1:
                f -= 1.0
                h -= 1.0
            fe[ne], ff[ne], fh[ne] = e, f, h
            ne += 1
            i = j
    for k in range(ne):
        e = fe[k]
        u, v = E[e, 0], E[e, 1]
        ux, uy, uz, vx, vy, vz = V[u, 0], V[u, 1], V[u, 2], V[v, 0], V[v, 1], V[v, 2]
        t = ET[e, 0]
        lk = elink[e, 0]
        a0, a1, a2, a3, a4, a5 = _share(
            ux, uy, uz, vx, vy, vz, planes[t, 0], planes[t, 1], planes[t, 2], ff[k], fh[k]
        )
        G[lk, 0] += a0
        G[lk, 1] += a1
        G[lk, 2] += a2
        G[lk, 3] += a3
        G[lk, 4] += a4
        G[lk, 5] += a5
        t = ET[e, 1]
        lk = elink[e, 1]
        a0, a1, a2, a3, a4, a5 = _share(
            ux, uy, uz, vx, vy, vz, planes[t, 0], planes[t, 1], planes[t, 2], ff[k], fh[k]
        )
        G[lk, 0] -= a0
        G[lk, 1] -= a1
        G[lk, 2] -= a2
        G[lk, 3] -= a3
        G[lk, 4] -= a4
        G[lk, 5] -= a5
