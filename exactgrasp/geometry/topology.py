"""Edges of a triangle mesh: whether it bounds a solid, and its non-manifold edges untangled.

A triangle mesh bounds a solid (its winding number is an integer off the surface) exactly when
every edge is used as often in one direction as in the other: a *closed cycle*. That admits
edges shared by four or more faces (two parts of a link touching along an edge), which a
2-manifold check refuses. This module

* counts and locates what keeps a mesh from being a cycle (`edge_defects`): edges of one face
  (holes) and edges used twice in one direction (neighbours that disagree on the outside);
* drops faces that bound nothing: a face and its reverse cancel, a stray copy of a face is
  kept once, coincident faces of closed shells are kept (`drop_repeated_faces`,
  `bounding_faces`);
* splits a mesh into shells (`split_shells`), drops unused vertices (`compact`) and joins
  meshes into one (`join_meshes`);
* turns a cycle into an oriented 2-manifold without moving a vertex (`split_nonmanifold`):
  around an edge of more than two faces, each face is paired with the neighbour that bounds
  the same solid wedge, and a vertex whose faces then form several fans becomes one vertex
  per fan. The solid is unchanged; its surface may touch itself where it did before.

"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

__all__ = [
    "EdgeDefects",
    "bounding_faces",
    "compact",
    "drop_repeated_faces",
    "edge_defects",
    "format_point",
    "join_meshes",
    "split_nonmanifold",
    "split_shells",
]


@dataclass(frozen=True)
class EdgeDefects:
    """What keeps a mesh from being a closed cycle, and where.

    Attributes
    ----------
    open : int
        Edges used an odd number of times (an edge of one face: a hole's rim).
    misoriented : int
        Edges used an even number of times but not as often in each direction (two
        neighbouring faces disagree on which side is outside).
    nonmanifold : int
        Edges shared by more than two faces (accepted: they still bound a solid).
    open_at, misoriented_at, nonmanifold_at : numpy.ndarray, shape (3,), or None
        The midpoint of the first such edge, in vertex units.
    """

    open: int
    misoriented: int
    nonmanifold: int
    open_at: np.ndarray | None
    misoriented_at: np.ndarray | None
    nonmanifold_at: np.ndarray | None

    @property
    def is_cycle(self) -> bool:
        """Every edge used as often in each direction: the mesh bounds a solid."""
        return self.open == 0 and self.misoriented == 0

    def describe(self) -> str:
        """The defects in words, with a location each (for messages)."""
        parts = []
        for count, where, what in (
            (self.open, self.open_at, "belong to an odd number of faces (holes)"),
            (
                self.misoriented,
                self.misoriented_at,
                "are used twice in the same direction (neighbouring faces disagree on "
                "which side is outside)",
            ),
        ):
            if count:
                parts.append(f"{count} edges {what}, e.g. at {format_point(where)}")
        return "; ".join(parts)


def format_point(x: np.ndarray | None) -> str:
    """A point for messages: ``(x, y, z)`` to 6 significant digits (``?`` for None)."""
    return "?" if x is None else f"({x[0]:.6g}, {x[1]:.6g}, {x[2]:.6g})"


def _half_edges(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tail and head vertex of each face's three edges, in order (3 m,): half-edge 3f+i runs
    from corner i to corner i+1 of face f."""
    tail = F.reshape(-1)
    head = F[:, [1, 2, 0]].reshape(-1)
    return tail, head


def _edge_keys(F: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Undirected key of each half-edge and +1/-1 for its direction (low to high vertex)."""
    tail, head = _half_edges(F)
    lo = np.minimum(tail, head)
    hi = np.maximum(tail, head)
    return lo * np.int64(n_vertices) + hi, np.where(tail < head, 1, -1)


def edge_defects(vertices: np.ndarray, faces: np.ndarray) -> EdgeDefects:
    """Count and locate the edges that keep a mesh from bounding a solid.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
        With duplicates already merged (an STL's separate corners would all look open).
    faces : numpy.ndarray, shape (m, 3), int64

    Returns
    -------
    EdgeDefects
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    key, sign = _edge_keys(F, len(V))
    uniq, inverse, uses = np.unique(key, return_inverse=True, return_counts=True)
    balance = np.bincount(inverse, sign, minlength=len(uniq))
    odd = uses % 2 == 1
    skew = ~odd & (balance != 0)
    many = uses > 2

    def at(mask: np.ndarray) -> np.ndarray | None:
        if not mask.any():
            return None
        k = int(uniq[np.argmax(mask)])
        return 0.5 * (V[k // len(V)] + V[k % len(V)])

    return EdgeDefects(
        open=int(odd.sum()),
        misoriented=int(skew.sum()),
        nonmanifold=int(many.sum()),
        open_at=at(odd),
        misoriented_at=at(skew),
        nonmanifold_at=at(many),
    )


def drop_repeated_faces(faces: np.ndarray, repeats: bool = True) -> tuple[np.ndarray, int, int]:
    """Faces that bound something: repeats kept once, a face and its reverse cancelled.

    Parameters
    ----------
    faces : numpy.ndarray, shape (m, 3), int64
    repeats : bool
        Drop a face repeated with the same orientation down to one copy (a stray copy); with
        False keep as many as do not cancel (coincident faces of closed shells).

    Returns
    -------
    faces : numpy.ndarray, shape (m', 3), int64
        In input order (the input itself when nothing was dropped).
    repeated : int
        Faces dropped as repeats of a face of the same orientation.
    cancelled : int
        Faces dropped in pairs with their reverse.
    """
    F = np.asarray(faces, dtype=np.int64)
    if len(F) == 0:
        return F, 0, 0
    # A face's corners rotated to start at its smallest index keep its orientation.
    start = np.argmin(F, axis=1)
    rows = np.arange(len(F))[:, None]
    rotated = F[rows, (start[:, None] + np.arange(3)) % 3]
    even = rotated[:, 1] < rotated[:, 2]
    canon = np.where(even[:, None], rotated, rotated[:, [0, 2, 1]])
    _, group, counts = np.unique(canon, axis=0, return_inverse=True, return_counts=True)
    group = group.reshape(-1)
    if counts.max() == 1:
        return F, 0, 0
    up = np.bincount(group, even.astype(np.int64), minlength=len(counts))
    down = counts - up
    net = up - down
    keep = np.zeros(len(F), bool)
    # One face per group whose orientations do not cancel (or |net| of them), of the winning
    # orientation.
    winner = np.where(net > 0, True, False)
    candidate = (even == winner[group]) & (net[group] != 0)
    if repeats:
        first = np.full(len(counts), len(F))
        np.minimum.at(first, group[candidate], np.flatnonzero(candidate))
        keep[first[first < len(F)]] = True
    else:
        order = np.flatnonzero(candidate)
        order = order[np.argsort(group[order], kind="stable")]
        g = group[order]
        start = np.searchsorted(g, g)  # first of each group in the sorted run
        keep[order[np.arange(len(order)) - start < np.abs(net[g])]] = True
    cancelled = int(2 * np.minimum(up, down).sum())
    repeated = int(len(F) - keep.sum() - cancelled)
    return F[keep], repeated, cancelled


def bounding_faces(
    vertices: np.ndarray, faces: np.ndarray
) -> tuple[np.ndarray, int, int, EdgeDefects]:
    """The faces that bound the solid, and what keeps them from closing.

    A face and its reverse cancel. A face repeated with the same orientation is kept as often
    as it is when the surface closes with the copies (coincident faces of closed shells, such
    as two boxes sharing a face: each copy counts in the winding number), else once (a stray
    copy that leaves the surface open).

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64

    Returns
    -------
    faces : numpy.ndarray, shape (m', 3), int64
        The input itself when nothing was dropped.
    repeated, cancelled : int
        As `drop_repeated_faces`.
    defects : EdgeDefects
        Of the faces returned.
    """
    G, _, cancelled = drop_repeated_faces(faces, repeats=False)
    defects = edge_defects(vertices, G)
    if defects.is_cycle:
        return G, 0, cancelled, defects
    H, repeated, cancelled = drop_repeated_faces(faces)
    if not repeated:
        return G, 0, cancelled, defects
    return H, repeated, cancelled, edge_defects(vertices, H)


def _wedge_pairs(
    V: np.ndarray, F: np.ndarray, halves: np.ndarray, a: int, b: int, solid_wedges: bool
) -> list[tuple[int, int]]:
    """Pair the half-edges of one non-manifold edge (a < b) so that each pair bounds one wedge
    between faces next to each other around the edge: counter-clockwise around a -> b, from a
    face using b -> a to the next face using a -> b (the pairs hold the solid's wedges), or,
    with ``solid_wedges`` False, from a face using a -> b to the next using b -> a (the pairs
    hold the wedges outside). Either way the sheets meet only along the edge and the winding
    number is unchanged everywhere. Returns (forward, backward) half-edge pairs."""
    tail, _ = _half_edges(F)
    d = V[b] - V[a]
    d = d / np.linalg.norm(d)
    x = np.cross(d, np.eye(3)[np.argmin(np.abs(d))])
    x /= np.linalg.norm(x)
    y = np.cross(d, x)
    face = halves // 3
    third = F[face, (halves % 3 + 2) % 3]
    u = V[third] - V[a]
    angle = np.arctan2(u @ y, u @ x)
    forward = tail[halves] == a
    opening = ~forward if solid_wedges else forward
    order = np.argsort(angle, kind="stable")
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
    vertices: np.ndarray, faces: np.ndarray
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
    key, sign = _edge_keys(F, len(V))
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
            p = np.array(_wedge_pairs(V, F, halves, a, b, bool(solid)), np.int64).reshape(-1, 2)
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


def split_shells(faces: np.ndarray, n_vertices: int) -> tuple[int, np.ndarray]:
    """Shells of a closed mesh: faces connected through shared edges.

    Parameters
    ----------
    faces : numpy.ndarray, shape (m, 3), int64
    n_vertices : int

    Returns
    -------
    n_shells : int
    label : numpy.ndarray, shape (m,), int64
        Shell of every face, numbered in order of their first face.
    """
    m = len(faces)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), 1)
    key = edges[:, 0] * np.int64(n_vertices) + edges[:, 1]
    order = np.argsort(key, kind="stable")
    face = np.tile(np.arange(m), 3)[order]
    same = key[order][1:] == key[order][:-1]
    graph = coo_matrix((np.ones(int(same.sum())), (face[:-1][same], face[1:][same])), (m, m))
    n, label = connected_components(graph, directed=False)
    # Renumber in order of first face, so that shell 0 holds face 0.
    _, first = np.unique(label, return_index=True)
    rank = np.empty(n, np.int64)
    rank[np.argsort(first)] = np.arange(n)
    return int(n), rank[label]


def compact(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Only the vertices the faces use, renumbered in order."""
    used, inverse = np.unique(F.reshape(-1), return_inverse=True)
    return np.ascontiguousarray(V[used]), inverse.reshape(-1, 3).astype(np.int64)


def join_meshes(parts) -> tuple[np.ndarray, np.ndarray]:
    """Meshes ``[(V (n_i, 3), F (m_i, 3)), ...]`` as one pair of arrays, faces renumbered."""
    offsets = np.cumsum([0] + [len(p[0]) for p in parts])
    V = np.concatenate([p[0] for p in parts])
    F = np.concatenate([p[1] + o for p, o in zip(parts, offsets, strict=False)])
    return V, F
