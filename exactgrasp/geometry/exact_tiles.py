"""One triangle of an exact cut tiled by the points and segments that lie on it.

`tile_face` gathers what `exactgrasp.geometry.exact_cut` placed on a face (points on its edges
and inside it, segments where other faces meet it), splits every segment at the points on it,
and tiles the face by the constrained Delaunay triangulation of all that
(`exactgrasp.geometry.triangulation`) in the coordinate plane that keeps the face flat; a
zero-area face is fanned over the points on its edges. Orders along a line are exact.
"""

from __future__ import annotations

from itertools import pairwise
from typing import TYPE_CHECKING

from exactgrasp.geometry.triangulation import constrained_delaunay

if TYPE_CHECKING:
    from exactgrasp.geometry.exact_cut import Arrangement

__all__ = ["tile_face"]


def _edge_points(cut: Arrangement, a: int, b: int) -> list[int]:
    """The points on edge a-b, in order from a to b."""
    extra = cut.on_edge.get((min(a, b), max(a, b)))
    if not extra:
        return []
    return cut.sort_along(extra, a, b)


def tile_face(cut: Arrangement, f: int) -> list[tuple[int, int, int]] | None:
    """Face f's tiles, or None when nothing lies on it.

    Parameters
    ----------
    cut : Arrangement
        With every point and segment placed.
    f : int
        An input face.

    Returns
    -------
    list of (int, int, int) or None
        Triangles of point indices, oriented as face f.
    """
    face = cut.faces[f]
    rims = [_edge_points(cut, face[k], face[(k + 1) % 3]) for k in range(3)]
    inner = cut.inside.get(f, set())
    if not inner and not any(rims) and not cut.segments.get(f):
        return None
    if not any(cut.plane(f)[:3]):
        # Zero area: a fan over the points of its rim, as thin as it is.
        ring = [p for k in range(3) for p in (face[k], *rims[k])]
        return [(ring[0], ring[k], ring[k + 1]) for k in range(1, len(ring) - 1)]
    i, j, turn = cut.view(f)
    corners = list(face) if turn > 0 else [face[0], face[2], face[1]]
    order = corners + list(dict.fromkeys(p for rim in rims for p in rim)) + sorted(inner)
    local = {g: k for k, g in enumerate(order)}
    segments = []
    for p, q in cut.segments.get(f, ()):
        chain = _on_segment(cut, p, q, order, i, j)
        segments += [(local[a], local[b]) for a, b in pairwise(chain)]
    tris = constrained_delaunay(
        [cut.points[g] for g in order],
        [(cut.approx[g][i], cut.approx[g][j]) for g in order],
        order,
        segments,
        i,
        j,
    )
    out = [(order[a], order[b], order[c]) for a, b, c in tris]
    return out if turn > 0 else [(a, c, b) for a, b, c in out]


def _on_segment(cut: Arrangement, p: int, q: int, order, i: int, j: int) -> list[int]:
    """Segment p-q's points among ``order``, from p to q."""
    axis = cut.along(p, q, (i, j))
    ends = sorted((p, q), key=lambda g: cut.coordinate(g, axis))

    def between(g: int) -> bool:
        x, lo, hi = (cut.approx[k][axis] for k in (g, *ends))
        if lo < x < hi:
            return True  # rounding keeps order
        if x < lo or x > hi:
            return False
        c = cut.coordinate(g, axis)
        return cut.coordinate(ends[0], axis) < c < cut.coordinate(ends[1], axis)

    inner = [g for g in order if g not in (p, q) and cut.orient(p, q, g, i, j) == 0 and between(g)]
    return [p, *cut.sort_along(inner, p, q, (i, j)), q]
