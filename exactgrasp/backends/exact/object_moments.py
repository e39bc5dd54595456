"""The object's side of the volume's derivatives (numba): per object face, the moments
``(∫ n dA, ∫ x × n dA)`` of its part inside the hand, summed from what the volume's pass
leaves behind, in local coordinates (the object moved by the pose).

They are the same sums as the hand's (`moment_sums`), made of the same pieces: an object
face's boundary inside the hand runs along the pieces of its edges inside the hand and along
the traced segments, which run ``q → p`` on the object face (``p → q`` on the hand face, see
`search.trace_pairs`). For a piece ``p → q`` of a face with unit normal ``n`` and
``c = n · (p × q)``: ``∫ n dA += n c / 2`` and ``∫ x × n dA += ((p + q) × n) c / 6``; along an
edge ``u → v`` inside on parameter intervals ``[a, b]``, with ``f = Σ (b − a)`` and
``h = Σ (b² − a²)``: ``n (n · w) f / 2`` and ``((2 f u + h (v − u)) × n)(n · w) / 6``,
``w = u × v``, on the face holding ``u → v``, the opposite on the other. The object moves with
each pose, so the shares are computed from its moved vertices and normals, not tabled. One row
per object face gives the volume's derivative by every object vertex (`vertex_gradients`).
"""

from __future__ import annotations

import numpy as np

from exactgrasp.backends.exact.sums import _order_by_key
from exactgrasp.backends.exact.tables import SEGMENT_OBJECT_FACE, SEGMENT_P, SEGMENT_Q
from exactgrasp.compiling import inner

__all__ = ["object_moments"]


@inner(nogil=True, error_model="numpy")
def _unit(N, s):
    """The unit normal of face ``s`` from its unnormalised normal ``N[s]`` (0 for a face of no
    area: it adds nothing)."""
    nx, ny, nz = N[s, 0], N[s, 1], N[s, 2]
    r = np.sqrt(nx * nx + ny * ny + nz * nz)
    if r == 0.0:
        return 0.0, 0.0, 0.0
    return nx / r, ny / r, nz / r


@inner(nogil=True, error_model="numpy")
def _add(G, r, nx, ny, nz, sx, sy, sz, a, b):
    """Add ``n a`` to ``∫ n dA`` and ``(s × n) b`` to ``∫ x × n dA`` in row ``r`` of ``G``."""
    G[r, 0] += nx * a
    G[r, 1] += ny * a
    G[r, 2] += nz * a
    G[r, 3] += (sy * nz - sz * ny) * b
    G[r, 4] += (sz * nx - sx * nz) * b
    G[r, 5] += (sx * ny - sy * nx) * b


@inner(nogil=True, error_model="numpy")
def _piece(G, r, nx, ny, nz, px, py, pz, qx, qy, qz):
    """Add the piece ``p → q`` of a face with unit normal ``n`` to row ``r`` of ``G``."""
    c = nx * (py * qz - pz * qy) + ny * (pz * qx - px * qz) + nz * (px * qy - py * qx)
    _add(G, r, nx, ny, nz, px + qx, py + qy, pz + qz, c / 2.0, c / 6.0)


@inner(nogil=True, error_model="numpy")
def _edge_share(V, N, E, ET, e, f, h, G, row0):
    """Add to both faces of edge ``e = u → v`` (rows ``row0 + face``) its share inside the
    hand, from ``f = Σ (b − a)`` and ``h = Σ (b² − a²)`` over its inside intervals."""
    u, v = E[e, 0], E[e, 1]
    ux, uy, uz = V[u, 0], V[u, 1], V[u, 2]
    dx, dy, dz = V[v, 0] - ux, V[v, 1] - uy, V[v, 2] - uz
    wx = uy * V[v, 2] - uz * V[v, 1]
    wy = uz * V[v, 0] - ux * V[v, 2]
    wz = ux * V[v, 1] - uy * V[v, 0]
    sx, sy, sz = 2.0 * f * ux + h * dx, 2.0 * f * uy + h * dy, 2.0 * f * uz + h * dz
    for side in range(2):
        t = ET[e, side]
        nx, ny, nz = _unit(N, t)
        c = nx * wx + ny * wy + nz * wz
        if side == 1:
            c = -c
        _add(G, row0 + t, nx, ny, nz, sx, sy, sz, c * f / 2.0, c / 6.0)


@inner(nogil=True, error_model="numpy")
def _multi_crossed(V, N, E, ET, S, rec_e, rec_l, multi, nm, G, row0):
    """The edges crossed more than once (records ``multi[:nm]``): each edge's parameters
    sorted, its inside intervals from its lower vertex's status."""
    key = np.empty(nm, np.int64)
    for i in range(nm):
        key[i] = rec_e[multi[i]]
    order = _order_by_key(key)
    lam = np.empty(nm)
    i = 0
    while i < nm:
        e = key[order[i]]
        j = i
        while j < nm and key[order[j]] == e:
            x = rec_l[multi[order[j]]]
            m = j - i
            while m > 0 and lam[m - 1] > x:
                lam[m] = lam[m - 1]
                m -= 1
            lam[m] = x
            j += 1
        inside = S[E[e, 0]] == 1
        f = 0.0
        h = 0.0
        last = 0.0
        for m in range(j - i):
            if inside:
                f += lam[m] - last
                h += lam[m] * lam[m] - last * last
            last = lam[m]
            inside = not inside
        if inside:
            f += 1.0 - last
            h += 1.0 - last * last
        _edge_share(V, N, E, ET, e, f, h, G, row0)
        i = j


@inner(nogil=True, error_model="numpy")
def object_moments(object_mesh, V, N, S, cnt, rec_e, rec_l, nrec, multi, segs, ncross, G, row0):
    """Moments ``(∫ n dA, ∫ x × n dA)`` of each object face's part inside the hand, added to
    rows ``row0 + face`` of ``G``, after a pose's volume pass (local coordinates).

    Parameters
    ----------
    object_mesh : tables.MeshTables
        The object's edges and their faces (its vertices unmoved: not read).
    V : numpy.ndarray, shape (object n, 3)
        The moved object's vertices (`tables.PoseScratch.object_V`); length units.
    N : numpy.ndarray, shape (object m, 3)
        The moved faces' unnormalised normals (`tables.PoseScratch.object_N`).
    S : numpy.ndarray, shape (object n,) int8
        The object's vertex statuses (1 inside the hand).
    cnt : numpy.ndarray, shape (object e,) int64
        Crossings recorded per object edge (`tables.Workspace.object_count`).
    rec_e, rec_l, nrec : numpy.ndarray, numpy.ndarray, int
        The object records' edges and parameters along ``u → v``, and their number.
    multi : numpy.ndarray, shape (>= nrec,) int64
        Scratch.
    segs : numpy.ndarray, shape (>= ncross, `tables.SEGMENT_COLUMNS`)
        The pose's traced segments (`tables.Workspace.segments`).
    ncross : int
    G : numpy.ndarray, shape (>= row0 + object m, 6)
    row0 : int
    """
    E, ET = object_mesh.edges, object_mesh.edge_faces
    for k in range(ncross):
        s = int(segs[k, SEGMENT_OBJECT_FACE])
        nx, ny, nz = _unit(N, s)
        p, q = SEGMENT_P, SEGMENT_Q
        _piece(
            G, row0 + s, nx, ny, nz, segs[k, q], segs[k, q + 1], segs[k, q + 2],
            segs[k, p], segs[k, p + 1], segs[k, p + 2],
        )  # fmt: skip
    for e in range(E.shape[0]):
        if cnt[e] == 0 and S[E[e, 0]] == 1:
            _edge_share(V, N, E, ET, e, 1.0, 1.0, G, row0)
    nm = 0
    for i in range(nrec):
        e = rec_e[i]
        if cnt[e] != 1:
            multi[nm] = i
            nm += 1
            continue
        lam = rec_l[i]
        if S[E[e, 0]] == 1:
            _edge_share(V, N, E, ET, e, lam, lam * lam, G, row0)
        else:
            _edge_share(V, N, E, ET, e, 1.0 - lam, 1.0 - lam * lam, G, row0)
    if nm > 0:
        _multi_crossed(V, N, E, ET, S, rec_e, rec_l, multi, nm, G, row0)
