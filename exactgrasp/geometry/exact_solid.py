"""The solid of a closed surface, decided exactly: winding numbers of its cut, and the boundary.

`solid_boundary` reads any closed surface (several shells that cross, overlap in a plane,
touch along edges or at corners, fold onto themselves) as the set of points of winding number
at least 1, and returns that set's boundary as an oriented 2-manifold:

1. **Cut** the surface along every contact (`exactgrasp.geometry.exact_cut`): exact points,
   triangles that meet only at corners and edges, or coincide.
2. **Merge coincident triangles.** Triangles on the same three points (coplanar overlaps)
   become one, counted with multiplicity (+1 per copy facing one way, -1 the other); a net
   count of 0 (a face and its reverse, two shells touching face to face) bounds nothing.
3. **Patches.** Triangles joined across edges of exactly two triangles; the winding number is
   the same along either side of a patch. Across a triangle of count c it drops by c from
   behind to in front.
4. **One winding number per patch, exactly.** From the centroid of one of its triangles (a
   rational point inside it, on no other triangle), a ray along the coordinate axis the
   triangle faces most counts the triangles above it with their signs and counts. Ties where
   the ray grazes an edge are broken by a symbolic perturbation evaluated the same way for
   every triangle sharing the edge, so the count is that of a ray in general position.
5. **Keep** every patch with winding number >= 1 on one side only, facing out of it;
   coordinates are rounded to float64 once, here, and the faces separated into a 2-manifold
   by `exactgrasp.geometry.topology.split_nonmanifold` where the solid touches itself.
"""

from __future__ import annotations

from collections import defaultdict
from fractions import Fraction
from functools import cmp_to_key

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exactgrasp.errors import MeshError
from exactgrasp.geometry.exact_cut import Arrangement, cut_exactly
from exactgrasp.geometry.rational import centroid, orient2d, plane_of, side, triple
from exactgrasp.geometry.topology import edge_defects, format_point
from exactgrasp.geometry.wedges import split_nonmanifold

__all__ = [
    "UNDECIDED",
    "Rays",
    "cut_faces",
    "face_levels",
    "patches",
    "solid_boundary",
    "winding_regions",
]

_AXES = ((1, 2), (2, 0), (0, 1))
#: The levels of a patch no ray asked (zero-area faces only): below and above every level,
#: so that it bounds no level set.
UNDECIDED = -(2**40)


def _merged(tiles) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Tiles on the same three points as one face with its net count: faces (k, 3) facing
    the way of a positive count, counts (k,) > 0, the input face of each one's first tile
    (k,), and whether every tile stood alone."""
    net: dict[tuple[int, int, int], int] = defaultdict(int)
    first: dict[tuple[int, int, int], int] = {}
    for a, b, c, f in tiles:
        key = tuple(sorted((a, b, c)))
        start = (a, b, c).index(key[0])
        even = (a, b, c)[(start + 1) % 3] == key[1]
        net[key] += 1 if even else -1
        first.setdefault(key, f)
    alone = len(net) == len(tiles) and all(abs(v) == 1 for v in net.values())
    faces = [k if v > 0 else (k[0], k[2], k[1]) for k, v in net.items() if v]
    counts = [abs(v) for v in net.values() if v]
    sources = [first[k] for k, v in net.items() if v]
    return (
        np.array(faces, np.int64).reshape(-1, 3),
        np.array(counts, np.int64),
        np.array(sources, np.int64),
        alone,
    )


def patches(
    faces: np.ndarray, n_points: int, joined: np.ndarray | None = None
) -> tuple[int, np.ndarray]:
    """Faces joined across edges of exactly two faces: the number of patches, and each
    face's (k,). With ``joined`` (k,) bool, only those faces join; the others stand alone."""
    tail = faces.reshape(-1)
    head = faces[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(tail, head) * np.int64(n_points) + np.maximum(tail, head)
    order = np.argsort(key)  # the pairs of an edge in either order: the same graph
    sk = key[order]
    bounds = np.flatnonzero(np.r_[True, sk[1:] != sk[:-1], True])
    pair = bounds[:-1][np.diff(bounds) == 2]
    fa, fb = order[pair] // 3, order[pair + 1] // 3
    if joined is not None:
        both = joined[fa] & joined[fb]
        fa, fb = fa[both], fb[both]
    m = len(faces)
    return connected_components(coo_matrix((np.ones(len(fa)), (fa, fb)), (m, m)), directed=False)


class Rays:
    """Exact winding numbers at points inside the faces of a cut surface."""

    def __init__(
        self, cut: Arrangement, faces: np.ndarray, counts: np.ndarray, boxes: tuple = ()
    ) -> None:
        """``faces`` (k, 3) into ``cut.points`` with their ``counts`` (k,); ``boxes``: the
        bounding boxes (lowest, highest corners, (j, 3) each) of the last j faces, where the
        caller has them."""
        self.cut = cut
        self.faces = faces
        self.counts = counts
        known = len(boxes[0]) if boxes else 0
        corners = cut.approx.array()[faces[: len(faces) - known]]
        self.lo, self.hi = corners.min(1), corners.max(1)
        if known:
            self.lo = np.concatenate([self.lo, boxes[0]])
            self.hi = np.concatenate([self.hi, boxes[1]])
        self.planes: dict[int, tuple] = {}

    def plane(self, f: int) -> tuple:
        pl = self.planes.get(f)
        if pl is None:
            a, b, c = self.faces[f]
            P = self.cut.points
            pl = self.planes[f] = plane_of(P[a], P[b], P[c])
        return pl

    def _edge_side(self, a: int, b: int, q: tuple, i: int, j: int) -> int:
        """Side (+1 left) of q, moved by (e, e^2) in (i, j), of the directed edge a -> b,
        evaluated in one fixed order of a and b so that both faces on it agree."""
        cut = self.cut
        ka = (cut.coordinate(a, i), cut.coordinate(a, j))
        kb = (cut.coordinate(b, i), cut.coordinate(b, j))
        flip = 1
        if ka > kb:
            a, b, ka, kb, flip = b, a, kb, ka, -1
        value = orient2d(cut.points[a], cut.points[b], q, i, j)
        if value:
            return flip if value > 0 else -flip
        dx, dy = kb[0] - ka[0], kb[1] - ka[1]
        if dy:
            return -flip if dy > 0 else flip
        if dx:
            return flip if dx > 0 else -flip
        return 0

    def centre(self, f: int) -> tuple[tuple, list[float]]:
        """Face f's centroid: exact (homogeneous integers), and correctly rounded (units)."""
        P = self.cut.points
        a, b, c = self.faces[f]
        q = centroid(P[a], P[b], P[c])
        return q, self.cut.ints.to_float(q)

    def above(self, f: int) -> int:
        """The winding number just past face f's centroid along the coordinate axis its
        normal leans to most (its front if the normal points that way, else its back)."""
        pl = self.plane(f)
        k = max(range(3), key=lambda a: abs(pl[a]))
        i, j = _AXES[k]
        q, x = self.centre(f)
        pad = 4e-16 * max(map(abs, x)) + 1e-300
        near = (
            (self.lo[:, i] <= x[i] + pad)
            & (self.hi[:, i] >= x[i] - pad)
            & (self.lo[:, j] <= x[j] + pad)
            & (self.hi[:, j] >= x[j] - pad)
            & (self.hi[:, k] >= x[k] - pad)
        )
        near[f] = False
        total = 0
        for g in np.flatnonzero(near).tolist():
            pg = self.plane(g)
            if pg[k] == 0:
                continue  # seen edge-on from the ray: crossed by no ray in general position
            u, v, w = self.faces[g]
            s = self._edge_side(u, v, q, i, j)
            if (
                s == 0
                or s != self._edge_side(v, w, q, i, j)
                or s != self._edge_side(w, u, q, i, j)
            ):
                continue
            if side(pg, q) * pg[k] < 0:  # g's plane above q along the axis
                total += int(self.counts[g]) * (1 if pg[k] > 0 else -1)
        return total


def face_levels(rays: Rays, f: int) -> tuple[int, int] | None:
    """The winding numbers (behind, in front) of face f of ``rays.faces``, from a ray at its
    centroid; None where it has no area (no ray can ask it)."""
    pl = rays.plane(f)
    if not any(pl[:3]):
        return None
    k = max(range(3), key=lambda a: abs(pl[a]))
    w, count = rays.above(f), int(rays.counts[f])
    behind = w if pl[k] < 0 else w + count
    return behind, behind - count


def _levels(cut, faces, counts, patch, n_patch) -> np.ndarray:
    """(n_patch, 2): the winding number behind and in front of each patch."""
    rays = Rays(cut, faces, counts)
    levels = np.full((n_patch, 2), UNDECIDED, np.int64)
    done = np.zeros(n_patch, bool)
    for f in range(len(faces)):
        p = patch[f]
        if done[p]:
            continue
        found = face_levels(rays, f)
        if found is not None:  # else another face of the patch is asked
            levels[p] = found
            done[p] = True
    return levels


def cut_faces(F: np.ndarray, tiles, tiled: np.ndarray):
    """The faces of a cut (`exact_cut.cut_exactly`'s ``tiles`` and ``tiled`` of faces F):
    the untiled faces, then the tiles, coincident ones merged; their counts and the face of
    F each lies in, and whether every tile stood alone."""
    G, counts, sources, alone = _merged(tiles)
    G = np.concatenate([F[~tiled], G])
    sources = np.concatenate([np.flatnonzero(~tiled), sources])
    counts = np.concatenate([np.ones(int((~tiled).sum()), np.int64), counts])
    return G, counts, sources, alone


def winding_regions(vertices: np.ndarray, faces: np.ndarray):
    """A closed surface cut along every contact, its faces with the winding numbers on their
    two sides, exactly.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
        A closed surface: every edge used as often in each direction.

    Returns
    -------
    cut : exact_cut.Arrangement
        The exact points.
    G : numpy.ndarray, shape (k, 3), int64
        The cut's faces, into ``cut.points`` (coincident tiles merged, facing the way most of
        them face).
    sources : numpy.ndarray, shape (k,), int64
        The input face each lies in (for merged tiles, the first one's).
    patch : numpy.ndarray, shape (k,), int64
        Each face's patch.
    levels : numpy.ndarray, shape (n_patch, 2), int64
        Each patch's winding numbers (behind, in front).
    alone : bool
        Whether every tile stood alone (no coincident tiles).
    n_cut : int
        Input faces split.
    """
    V = np.asarray(vertices, dtype=np.float64)
    welded, inverse = np.unique(V, axis=0, return_inverse=True)
    F = inverse.reshape(-1)[np.asarray(faces, dtype=np.int64)]
    cut, tiles, tiled, n_cut = cut_exactly(welded, F)
    G, counts, sources, alone = cut_faces(F, tiles, tiled)
    n_patch, patch = patches(G, len(cut.points))
    levels = _levels(cut, G, counts, patch, n_patch)
    return cut, G, sources, patch, levels, alone, n_cut


def solid_boundary(
    vertices: np.ndarray,
    faces: np.ndarray,
    around: int = 0,
    inside_out: bool = False,
    name: str = "mesh",
):
    """The boundary of the points of winding number >= 1 of a closed surface, exactly.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
        A closed surface: every edge used as often in each direction.
    around : int
        Winding number that other surfaces, which this one does not meet, add along it: the
        solid is where this surface's winding number is at least ``1 - around``.
    inside_out : bool
        When that solid is empty and ``around`` is 0, return instead the boundary of the
        points of winding number <= -1, facing out of them (an inside-out body, turned).
    name : str
        The mesh, in messages.

    Returns
    -------
    vertices : numpy.ndarray, shape (n', 3), float64
    faces : numpy.ndarray, shape (m', 3), int64
        The boundary, an oriented 2-manifold by its indices (empty when there is no solid);
        the input arrays themselves when the surface is that boundary already.
    report : dict
        ``cut`` (input faces split), ``changed`` (False when the input is returned),
        ``turned`` (the inside-out reading was used), ``levels`` (sorted distinct
        (behind, in front) winding numbers of the patches).

    Raises
    ------
    MeshError
        Patches made only of zero-area triangles, whose side no ray can decide, that the
        boundary cannot close without.
    """
    V_in, F_in = vertices, faces
    cut, G, _, patch, levels, alone, n_cut = winding_regions(vertices, faces)
    report = {
        "cut": n_cut,
        "changed": True,
        "turned": False,
        "levels": sorted({tuple(map(int, row)) for row in levels}),
    }
    inside = levels + around >= 1
    keep = inside[:, 0] != inside[:, 1]
    if not keep.any() and around == 0 and inside_out:
        inside = levels <= -1
        keep = inside[:, 0] != inside[:, 1]
        report["turned"] = bool(keep.any())
    if alone and np.all(keep) and np.all(inside[:, 0]) and not report["turned"]:
        report["changed"] = False
        return V_in, F_in, report
    kept = keep[patch]
    out = np.where(inside[patch][:, :1], G, G[:, ::-1])[kept]
    if not len(out):
        return np.empty((0, 3)), np.empty((0, 3), np.int64), report
    used, local = np.unique(out.reshape(-1), return_inverse=True)
    points = cut.approx.array()[used]
    out = local.reshape(-1, 3).astype(np.int64)
    defects = edge_defects(points, out)
    if not defects.is_cycle:
        # Only patches of zero-area triangles, which no ray can ask, are left undecided.
        raise MeshError(
            f"{name}: zero-area triangles lie where its surface meets itself (the cut leaves "
            f"{defects.open + defects.misoriented} edges unmatched, e.g. at "
            f"{format_point(defects.open_at if defects.open else defects.misoriented_at)}), "
            "so the exact cut cannot tell which side of the solid they are on; remove them "
            "(e.g. MeshLab's 'Remove Zero Area Faces') and load the mesh again."
        )
    W, H, _, _ = split_nonmanifold(points, out, _exact_order(cut, used))
    return W, H, report


def _exact_order(cut: Arrangement, used: np.ndarray):
    """For `split_nonmanifold`: the faces' third corners ordered counter-clockwise around an
    edge from the exact points (rounding may have made the edge too short to measure)."""

    def exact(g: int) -> tuple[Fraction, ...]:
        X, Y, Z, W = cut.points[int(used[g])]
        return Fraction(X, W), Fraction(Y, W), Fraction(Z, W)

    def around(V, third: np.ndarray, a: int, b: int) -> np.ndarray:
        A, B = exact(a), exact(b)
        d = [q - p for p, q in zip(A, B, strict=True)]
        u = [[q - p for p, q in zip(A, exact(g), strict=True)] for g in third.tolist()]
        dd = _dot(d, d)

        def half(v) -> tuple[int, int]:
            # 0: along the first corner, 1: the half-turn after it, 2: opposite, 3: the rest
            s = _sign(triple(u[0], v, d))
            if s:
                return (1, 0) if s > 0 else (3, 0)
            return (0, 0) if _dot(v, u[0]) * dd - _dot(v, d) * _dot(u[0], d) > 0 else (2, 0)

        def compare(i: int, j: int) -> int:
            hi, hj = half(u[i]), half(u[j])
            if hi != hj:
                return -1 if hi < hj else 1
            return -_sign(triple(u[i], u[j], d))

        return np.array(sorted(range(len(u)), key=cmp_to_key(compare)), np.int64)

    return around


def _dot(p, q):
    return p[0] * q[0] + p[1] * q[1] + p[2] * q[2]


def _sign(x) -> int:
    return (x > 0) - (x < 0)
