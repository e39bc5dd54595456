"""The object's side of the volume's derivatives (numba): per object face, the moments
``(∫ n dA, ∫ x × n dA)`` of its part inside the hand, summed from what the volume's pass
leaves behind, in the object's own frame (local coordinates, unmoved).

They are the same sums as the hand's (`moment_sums`), made of the same pieces: an object
face's boundary inside the hand runs along the pieces of its edges inside the hand and along
the traced segments, which run ``q → p`` on the object face (``p → q`` on the hand face, see
`search.trace_pairs`). For a piece ``p → q`` of a face with unit normal ``n`` and
``c = n · (p × q)``: ``∫ n dA += n c / 2`` and ``∫ x × n dA += ((p + q) × n) c / 6``; an
edge's share inside the hand is, as the hand's, ``f`` times its whole share plus a
correction (`moment_sums._add_interval_share`). Taken in the object's frame, the whole shares
do not change with the pose: they are tabled (`tables.MomentTables.object_edge_moments`), and
only the traced segments are moved there, by the pose's inverse. One row per object face
gives the volume's derivative by every object vertex (`face_gradients`).
"""

from __future__ import annotations

from exactgrasp.backends.exact.moment_sums import (
    add_edge,
    add_piece,
    crossed_edge_moments,
    touch,
)
from exactgrasp.backends.exact.tables import (
    SEGMENT_OBJECT_FACE,
    SEGMENT_P,
    SEGMENT_Q,
)
from exactgrasp.compiling import inner

__all__ = ["object_moments"]


@inner(nogil=True, error_model="numpy")
def _segment_piece(values, r, unit, s, R, t, segs, k):
    """Add segment ``k`` (``segs``, local coordinates) to row ``r`` of ``values``: the piece
    ``q → p`` of object face ``s`` (unit normal ``unit[s]`` in the object's frame), both ends
    taken into the object's frame, ``x -> R^T (x - t)``."""
    nx, ny, nz = unit[s, 0], unit[s, 1], unit[s, 2]
    p, q = SEGMENT_Q, SEGMENT_P  # the object face runs q → p
    ax, ay, az = segs[k, p] - t[0], segs[k, p + 1] - t[1], segs[k, p + 2] - t[2]
    bx, by, bz = segs[k, q] - t[0], segs[k, q + 1] - t[1], segs[k, q + 2] - t[2]
    px = R[0, 0] * ax + R[1, 0] * ay + R[2, 0] * az
    py = R[0, 1] * ax + R[1, 1] * ay + R[2, 1] * az
    pz = R[0, 2] * ax + R[1, 2] * ay + R[2, 2] * az
    qx = R[0, 0] * bx + R[1, 0] * by + R[2, 0] * bz
    qy = R[0, 1] * bx + R[1, 1] * by + R[2, 1] * bz
    qz = R[0, 2] * bx + R[1, 2] * by + R[2, 2] * bz
    add_piece(values, r, nx, ny, nz, px, py, pz, qx, qy, qz)


@inner(nogil=True, error_model="numpy")
def object_moments(object_mesh, mom, R, t, S, cnt, rec_e, rec_l, nrec, multi, segs, ncross, G):
    """Moments ``(∫ n dA, ∫ x × n dA)`` of each object face's part inside the hand, in the
    object's frame, added to its row (``mom.object_edge_links``, from ``mom.object_from``) of
    ``G`` after a pose's volume pass: the traced segments, the whole edges from every inside
    vertex to higher-numbered ones, then the crossed edges' corrections
    (`moment_sums.crossed_edge_moments`, as the hand's).

    Parameters
    ----------
    object_mesh : tables.MeshTables
        The object's mesh (local coordinates, unmoved).
    mom : tables.MomentTables
        With the object's tables (`object_edge_links`, ...).
    R, t : numpy.ndarray, shapes (3, 3) and (3,)
        The pose, local coordinates (``x -> R x + t`` moves the object).
    S : numpy.ndarray, shape (object n,) int8
        The object's vertex statuses (1 inside the hand).
    cnt : numpy.ndarray, shape (object e,) int64
        Crossings recorded per object edge (`tables.Workspace.object_count`); written to, and
        put back.
    rec_e, rec_l, nrec : numpy.ndarray, numpy.ndarray, int
        The object records' edges and parameters along ``u → v``, and their number.
    multi : numpy.ndarray, shape (>= nrec,) int64
        Scratch.
    segs : numpy.ndarray, shape (>= ncross, `tables.SEGMENT_COLUMNS`)
        The pose's traced segments (`tables.Workspace.segments`).
    ncross : int
    G : tables.MomentRows
        The moments' rows, each row touched listed there.
    """
    V, E = object_mesh.vertices, object_mesh.edges
    adj_start, adj_vert = object_mesh.adj_start, object_mesh.adj_vertex
    adj_edge = object_mesh.adj_edge
    elink, emom, unit = mom.object_edge_links, mom.object_edge_moments, mom.object_normals
    row0 = mom.object_from[0]
    values, stamp, touched, state = G.values, G.stamp, G.touched, G.state
    listed, pose = state[0], state[1]
    for k in range(ncross):
        s = int(segs[k, SEGMENT_OBJECT_FACE])
        listed = touch(stamp, touched, listed, pose, row0 + s)
        _segment_piece(values, row0 + s, unit, s, R, t, segs, k)
    for u in range(V.shape[0]):
        if S[u] != 1:
            continue
        for j in range(adj_start[u], adj_start[u + 1]):
            if u >= adj_vert[j]:
                continue
            listed = add_edge(values, stamp, touched, listed, pose, elink, emom, adj_edge[j])
    state[0] = listed
    crossed_edge_moments(V, E, elink, emom, S, cnt, rec_e, rec_l, nrec, multi, G)
