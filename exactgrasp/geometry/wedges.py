"""Edges of more than two faces untangled: the same solid as an oriented 2-manifold.

`split_nonmanifold` turns a closed cycle (every edge used as often in each direction) into an
oriented 2-manifold without moving a vertex: around an edge of more than two faces, each face
is paired with the neighbour that bounds the same solid wedge, and a vertex whose faces then
form several fans becomes one vertex per fan. The solid is unchanged; its surface may touch
itself where it did before. The faces around an edge are ordered by angle in floating point,
or by an order the caller gives (`exactgrasp.geometry.exact_solid` gives an exact one, for
edges its rounding has made too short to measure). Re-exported by
`exactgrasp.geometry.topology`.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

__all__ = ["edge_keys", "half_edges", "split_nonmanifold"]


def half_edges(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tail and head vertex of each face's three edges, in order (3 m,): half-edge 3f+i runs
    from corner i to corner i+1 of face f."""
    tail = F.reshape(-1)
    head = F[:, [1, 2, 0]].reshape(-1)
    return tail, head


def edge_keys(F: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Undirected key of each half-edge and +1/-1 for its direction (low to high vertex)."""
    tail, head = half_edges(F)
    lo = np.minimum(tail, head)
    hi = np.maximum(tail, head)
    return lo * np.int64(n_vertices) + hi, np.where(tail < head, 1, -1)


def _by_angle(V: np.ndarray, third: np.ndarray, a: int, b: int) -> np.ndarray:
    """Order of the points ``third`` counter-clockwise around the edge a -> b (float)."""
    d = V[b] - V[a]
    d = d / np.linalg.norm(d)
    x = np.cross(d, np.eye(3)[np.argmin(np.abs(d))])
    x /= np.linalg.norm(x)
    y = np.cross(d, x)
    u = V[third] - V[a]
    return np.argsort(np.arctan2(u @ y, u @ x), kind="stable")


def _wedge_pairs(
    V: np.ndarray,
    F: np.ndarray,
    halves: np.ndarray,
    a: int,
    b: int,
    solid_wedges: bool,
    around=None,
) -> list[tuple[int, int]]:
    """Pair the half-edges of one non-manifold edge (a < b) so that each pair bounds one wedge
    between faces next to each other around the edge: counter-clockwise around a -> b, from a
    face using b -> a to the next face using a -> b (the pairs hold the solid's wedges), or,
    with ``solid_wedges`` False, from a face using a -> b to the next using b -> a (the pairs
    hold the wedges outside). Either way the sheets meet only along the edge and the winding
    number is unchanged everywhere. Returns (forward, backward) half-edge pairs. ``around``
    orders the faces' third corners around the edge as `_by_angle` does (default)."""
    tail, _ = half_edges(F)
    face = halves // 3
    third = F[face, (halves % 3 + 2) % 3]
    forward = tail[halves] == a
    opening = ~forward if solid_wedges else forward
    order = (around or _by_angle)(V, third, a, b)
    # Opening and closing faces matched like brackets around the circle, starting just after
    # the lowest running balance so that no closing face comes first.
    step = np.where(opening[order], 1, -1)
    start = (int(np.argmin(np.cumsum(step))) + 1) % len(order)
    stack: list[int] = []
    pairs = []
    for h in np.roll(order, -start):
        if opening[h]:
            stack.append(int(halves[h]))
        elif stack:
            other = stack.pop()
            pairs.append((int(halves[h]), other) if forward[h] else (other, int(halves[h])))
    return pairs


def _fans(F: np.ndarray, ha: np.ndarray, hb: np.ndarray) -> tuple[int, np.ndarray]:
    """Corners joined into fans across twin half-edges ``ha[i]``, ``hb[i]``: the number of
    fans and each corner's fan (corner 3f+i is corner i of face f)."""
    m = len(F)
    # Corner 3f+i sits at the tail of half-edge 3f+i. Twins run opposite ways, so each twin's
    # tail corner joins the other's head corner.
    head_a = (ha // 3) * 3 + (ha % 3 + 1) % 3
    head_b = (hb // 3) * 3 + (hb % 3 + 1) % 3
    rows = np.concatenate([ha, hb])
    cols = np.concatenate([head_b, head_a])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), (3 * m, 3 * m))
    return connected_components(graph, directed=False)


def _still_crowded(fan: np.ndarray, groups: list[np.ndarray]) -> np.ndarray:
    """Which groups of half-edges (one non-manifold edge each) still hold an edge of more
    than two faces once every corner is its fan's vertex."""
    tail = fan
    head = fan.reshape(-1, 3)[:, [1, 2, 0]].reshape(-1)
    out = np.zeros(len(groups), bool)
    for i, halves in enumerate(groups):
        lo = np.minimum(tail[halves], head[halves])
        hi = np.maximum(tail[halves], head[halves])
        _, uses = np.unique(np.stack([lo, hi], 1), axis=0, return_counts=True)
        out[i] = bool((uses > 2).any())
    return out


def _split_at_midpoints(V: np.ndarray, F: np.ndarray, edges: np.ndarray):
    """Each face on one of ``edges`` ((k, 2) vertex pairs) cut in two at the edge's midpoint,
    a new vertex (on the edge to the rounding of its coordinates)."""
    mid = np.arange(len(V), len(V) + len(edges))
    W = np.concatenate([V, 0.5 * (V[edges[:, 0]] + V[edges[:, 1]])])
    lookup = {(int(a), int(b)): int(k) for (a, b), k in zip(edges, mid, strict=True)}
    kept, added = [], []
    for f, (p, q, r) in enumerate(F):
        cut = [
            (i, lookup.get((min(s, t), max(s, t))))
            for i, (s, t) in enumerate(((p, q), (q, r), (r, p)))
        ]
        cut = [(i, k) for i, k in cut if k is not None]
        if not cut:
            kept.append(f)
            continue
        i, k = cut[0]
        c = np.roll(F[f], -i)  # edge c0 -> c1 holds the midpoint k
        added += [(c[0], k, c[2]), (k, c[1], c[2])]
    G = np.concatenate([F[kept], np.array(added, np.int64).reshape(-1, 3)])
    return W, G


def split_nonmanifold(
    vertices: np.ndarray, faces: np.ndarray, around=None
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The same solid as an oriented 2-manifold: non-manifold edges and vertices untangled.

    Around each edge of more than two faces the faces are paired so that each pair bounds one
    wedge (`_wedge_pairs`), and a vertex whose faces then form several fans becomes one vertex
    per fan. Pairing the solid's wedges leaves some edges shared where two sheets of one fan
    pass through the same edge twice (a vertex whose fan cannot be cut in two): those edges
    pair the wedges outside instead, and an edge that neither pairing frees (an edge of six or
    more faces tied up that way) is cut at its midpoint first. The result is a 2-manifold by
    its indices: every edge of exactly two faces, every vertex one fan.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
        A closed cycle (`edge_defects(...).is_cycle`).

    Returns
    -------
    vertices : numpy.ndarray, shape (n', 3), float64
        The input's, with copies of the vertices that were split (unused ones dropped), and
        the midpoints of edges that were cut.
    faces : numpy.ndarray, shape (m', 3), int64
        The same faces, in order, on the new vertex indices (m' = m), unless an edge was cut:
        then the faces on it are replaced by their halves, at the end.
    nonmanifold_edges : int
        Edges of more than two faces that were paired up.
    split_vertices : int
        Vertices that became several.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    key, sign = edge_keys(F, len(V))
    order = np.lexsort((-sign, key))  # per edge: forward halves first
    sorted_key = key[order]
    bounds = np.flatnonzero(np.r_[True, sorted_key[1:] != sorted_key[:-1], True])
    uses = np.diff(bounds)
    first = bounds[:-1][uses == 2]
    crowded = np.flatnonzero(uses > 2)
    groups = [order[bounds[e] : bounds[e + 1]] for e in crowded]
    ends = [divmod(int(sorted_key[bounds[e]]), len(V)) for e in crowded]
    solid_wedges = np.ones(len(crowded), bool)
    while True:
        pairs = [(order[first], order[first + 1])]
        for halves, (a, b), solid in zip(groups, ends, solid_wedges, strict=True):
            p = _wedge_pairs(V, F, halves, a, b, bool(solid), around)
            p = np.array(p, np.int64).reshape(-1, 2)
            pairs.append((p[:, 0], p[:, 1]))
        n_fans, fan = _fans(
            F, np.concatenate([p[0] for p in pairs]), np.concatenate([p[1] for p in pairs])
        )
        stuck = _still_crowded(fan, groups)
        flip = stuck & solid_wedges
        if not flip.any():
            break
        solid_wedges[flip] = False
    if stuck.any():
        W, G = _split_at_midpoints(V, F, np.array(ends, np.int64)[stuck])
        W, G, _, n_split = split_nonmanifold(W, G)
        return W, G, len(crowded), n_split
    vertex_of_fan = np.empty(n_fans, np.int64)
    vertex_of_fan[fan] = F.reshape(-1)
    if not len(crowded) and n_fans == len(np.unique(F)):
        return V, F, 0, 0
    counts = np.bincount(vertex_of_fan, minlength=len(V))
    split_vertices = int((counts > 1).sum())
    new_faces = fan.reshape(-1, 3).astype(np.int64)
    return np.ascontiguousarray(V[vertex_of_fan]), new_faces, len(crowded), split_vertices
