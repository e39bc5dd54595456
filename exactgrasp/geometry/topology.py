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
* turns a cycle into an oriented 2-manifold without moving a vertex (`split_nonmanifold`,
  from `exactgrasp.geometry.wedges`): around an edge of more than two faces, each face is
  paired with the neighbour that bounds the same solid wedge, and a vertex whose faces then
  form several fans becomes one vertex per fan. The solid is unchanged; its surface may
  touch itself where it did before.

"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exactgrasp.geometry.wedges import edge_keys as _edge_keys
from exactgrasp.geometry.wedges import split_nonmanifold

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
