"""A shell that crosses itself, cut along its own crossings and regrouped by winding number.

A closed surface that passes through itself still bounds a well-defined solid: the points of
winding number >= 1. `winding_layers` finds that solid's boundary without approximation:

1. **Cut.** Each pair of crossing triangles meets in a segment whose ends are where an edge of
   one pierces the other (or a corner the two share). Each end is computed once, from the edge
   and the face it pierces, so every triangle that holds it uses the same vertex; where two
   such segments cross inside a third triangle the three planes' common point is a vertex of
   all three. Every crossed triangle is split into the faces of its planar arrangement
   (boundary, segments and their crossings), triangulated by manifold3d without new points.
   The only new coordinates are these intersection points, rounded once.
2. **Regroup.** The cut surface falls into patches that meet only along the crossing curves.
   Crossing a patch against its normal raises the winding number by one, so a patch lies
   between regions of winding number k (behind it) and k - 1 (in front); k comes from the
   generalised winding number at one point of the patch, which lies half-way between the two.
   The patches with the same k bound the set {w >= k} (k >= 1) or {w <= k - 1} (k <= 0):
   closed surfaces that no longer cross one another, only touch along the former crossings.

The layers keep every face's orientation, so together they have the shell's winding number
everywhere: layer 1 is the boundary of the solid; the others (a region the surface encloses
twice, a part turned inside out) are left for `exactgrasp.geometry.shells`, which reads the
shells of a mesh together. A crossing too close to a corner or an edge of the other triangle
to be cut with certainty is reported as `exactgrasp.errors.UncertainCrossingError`.

"""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exactgrasp.errors import UncertainCrossingError
from exactgrasp.geometry.topology import split_nonmanifold
from exactgrasp.geometry.winding import winding_number

__all__ = ["winding_layers"]

# Relative size of an orientation determinant below which its sign is not trusted (the
# static bound of ``geometry/_predicates.pxd``, for coordinates spanning the pair).
_ORIENT_ERR = 1e-14


def _det(a, b, c, d) -> float:
    """Six times the signed volume of tetrahedron abcd (points as 3-lists of floats)."""
    ax, ay, az = a[0] - d[0], a[1] - d[1], a[2] - d[2]
    bx, by, bz = b[0] - d[0], b[1] - d[1], b[2] - d[2]
    cx, cy, cz = c[0] - d[0], c[1] - d[1], c[2] - d[2]
    return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)


class _Points:
    """The cut's vertices: the shell's own, then each intersection point once, by key."""

    def __init__(self, V: np.ndarray):
        self.base = V
        self.n = len(V)
        self.extra: list[np.ndarray] = []
        self.index: dict[tuple, int] = {}

    def __getitem__(self, i: int) -> np.ndarray:
        return self.base[i] if i < self.n else self.extra[i - self.n]

    def add(self, key: tuple, make) -> int:
        i = self.index.get(key)
        if i is None:
            i = self.n + len(self.extra)
            self.extra.append(np.asarray(make(), dtype=np.float64))
            self.index[key] = i
        return i

    def array(self) -> np.ndarray:
        if not self.extra:
            return self.base
        return np.concatenate([self.base, np.array(self.extra)])


def _pierce(V, p, q, tri, bound):
    """Where segment V[p] V[q] passes through the interior of triangle ``tri``: its parameter
    along the segment, None when it certainly does not; raises `UncertainCrossingError` when
    uncertain. ``V`` holds the points as lists of floats."""
    a, b, c = V[tri[0]], V[tri[1]], V[tri[2]]
    P, Q = V[p], V[q]
    dp, dq = _det(a, b, c, P), _det(a, b, c, Q)
    sp = 0 if abs(dp) <= bound else (1 if dp > 0 else -1)
    sq = 0 if abs(dq) <= bound else (1 if dq > 0 else -1)
    if sp != 0 and sp == sq:
        return None
    s = []
    for x, y in ((a, b), (b, c), (c, a)):
        d = _det(P, Q, x, y)
        s.append(0 if abs(d) <= bound else (1 if d > 0 else -1))
    if max(s) > 0 and min(s) < 0:
        return None
    if sp == 0 or sq == 0 or 0 in s:
        raise UncertainCrossingError(
            "an edge passes through or touches a corner or edge",
            0.5 * (np.asarray(P) + np.asarray(Q)),
        )
    return dp / (dp - dq)


def _segments(V, F, t, u, points):
    """For each crossing pair: the segment's two point indices, in both faces' lists."""
    per_face: dict[int, list[tuple[int, int, int]]] = {}
    on_edge: dict[tuple[int, int], set[int]] = {}
    Vl = V.tolist()
    Fl = F.tolist()
    for A, B in zip(t.tolist(), u.tolist(), strict=True):
        fa, fb = F[A], F[B]
        shared = set(fa.tolist()) & set(fb.tolist())
        corners = np.concatenate([V[fa], V[fb]])
        span = float(np.ptp(corners, axis=0).max())
        bound = _ORIENT_ERR * span**3
        ends: list[int] = []
        for X, Y in ((fa, B), (fb, A)):
            for i in range(3):
                p, q = int(X[i]), int(X[(i + 1) % 3])
                if p in shared or q in shared:
                    continue
                lam = _pierce(Vl, p, q, Fl[Y], bound)
                if lam is None:
                    continue
                edge = (min(p, q), max(p, q))
                lo = V[edge[0]]
                lam_lo = lam if p == edge[0] else 1.0 - lam
                key = ("e", edge, Y)
                ends.append(
                    points.add(key, lambda lo=lo, e=edge, s=lam_lo: lo + s * (V[e[1]] - lo))
                )
                on_edge.setdefault(edge, set()).add(ends[-1])
        if len(shared) == 1:
            ends.append(next(iter(shared)))
        ends = list(dict.fromkeys(ends))
        if len(ends) != 2:
            raise UncertainCrossingError(
                f"two triangles meet in {len(ends)} edge crossings, not a segment",
                corners.mean(0),
            )
        per_face.setdefault(A, []).append((ends[0], ends[1], B))
        per_face.setdefault(B, []).append((ends[0], ends[1], A))
    return per_face, on_edge


def _plane_point(V, F, faces) -> np.ndarray:
    """The common point of three triangles' planes."""
    N = np.empty((3, 3))
    d = np.empty(3)
    for r, f in enumerate(faces):
        a, b, c = V[F[f]]
        N[r] = np.cross(b - a, c - a)
        d[r] = N[r] @ a
    return np.linalg.solve(N, d)


def _seg_cross(p1, p2, q1, q2) -> bool:
    """Do 2D segments p1p2 and q1q2 cross at a point inside both?"""

    def side(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    d1, d2 = side(q1, q2, p1), side(q1, q2, p2)
    d3, d4 = side(p1, p2, q1), side(p1, p2, q2)
    return d1 * d2 < 0 and d3 * d4 < 0


def _faces_of_graph(xy: np.ndarray, edges: set[tuple[int, int]]) -> list[list[int]]:
    """Bounded faces of a planar straight-line graph, each as its CCW boundary loop plus the
    CW loops of the components it holds (for `manifold3d.triangulate`)."""
    nbrs: dict[int, list[int]] = {}
    for a, b in edges:
        nbrs.setdefault(a, []).append(b)
        nbrs.setdefault(b, []).append(a)
    ccw = {}
    for v, ns in nbrs.items():
        ang = [np.arctan2(xy[w, 1] - xy[v, 1], xy[w, 0] - xy[v, 0]) for w in ns]
        ccw[v] = [ns[i] for i in np.argsort(ang)]
    seen: set[tuple[int, int]] = set()
    loops = []
    for a, b in list(edges) + [(b, a) for a, b in edges]:
        if (a, b) in seen:
            continue
        loop = []
        u, v = a, b
        while (u, v) not in seen:
            seen.add((u, v))
            loop.append(u)
            ring = ccw[v]
            w = ring[(ring.index(u) - 1) % len(ring)]
            u, v = v, w
        loops.append(loop)

    def area(loop):
        p = xy[loop]
        return 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))

    # Components: the outer one holds the triangle's corners (nodes 0, 1, 2).
    nodes = sorted(nbrs)
    pos = {v: i for i, v in enumerate(nodes)}
    rows = [pos[a] for a, _ in edges]
    cols = [pos[b] for _, b in edges]
    _, comp = connected_components(
        coo_matrix((np.ones(len(rows)), (rows, cols)), (len(nodes),) * 2), directed=False
    )
    areas = [area(loop) for loop in loops]
    bounded = [i for i, s in enumerate(areas) if s > 0]
    holes = [i for i, s in enumerate(areas) if s < 0 and comp[pos[loops[i][0]]] != comp[pos[0]]]
    faces = {i: [loops[i]] for i in bounded}
    for h in holes:
        x = xy[loops[h][0]]
        best = None
        for i in bounded:
            if comp[pos[loops[i][0]]] == comp[pos[loops[h][0]]]:
                continue
            if _inside(xy[loops[i]], x) and (best is None or areas[i] < areas[best]):
                best = i
        if best is not None:
            faces[best].append(loops[h])
    return list(faces.values())


def _inside(poly: np.ndarray, x: np.ndarray) -> bool:
    inside = False
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        if (a[1] > x[1]) != (b[1] > x[1]):
            t = (x[1] - a[1]) / (b[1] - a[1])
            if a[0] + t * (b[0] - a[0]) > x[0]:
                inside = not inside
    return inside


def _split_face(V, F, f, segs, on_edge, points) -> np.ndarray:
    """Triangles (k, 3) of global point indices that tile face ``f`` cut by its segments."""
    import manifold3d

    corners = [int(c) for c in F[f]]
    a, b, c = (points[i] for i in corners)
    normal = np.cross(b - a, c - a)
    drop = int(np.argmax(np.abs(normal)))
    keep = [ax for ax in range(3) if ax != drop]

    def flat(i):
        return points[i][keep]

    # Segments crossing inside this face: the three planes' point, a vertex of all three.
    pieces = [[s0, s1] for s0, s1, _ in segs]
    for i in range(len(segs)):
        for j in range(i + 1, len(segs)):
            (p0, p1, g), (q0, q1, h) = segs[i], segs[j]
            if g == h or len({p0, p1, q0, q1}) < 4:
                continue
            if _seg_cross(flat(p0), flat(p1), flat(q0), flat(q1)):
                key = ("t", *sorted((f, g, h)))
                x = points.add(key, lambda g=g, h=h: _plane_point(V, F, (f, g, h)))
                pieces[i].append(x)
                pieces[j].append(x)
    edges: set[tuple[int, int]] = set()

    def chain(ids, start, end):
        s, d = flat(start), flat(end) - flat(start)
        ordered = sorted(set(ids), key=lambda i: float((flat(i) - s) @ d))
        for p, q in pairwise(ordered):
            if p != q:
                edges.add((min(p, q), max(p, q)))

    for k in range(3):
        p, q = corners[k], corners[(k + 1) % 3]
        chain([p, q, *on_edge.get((min(p, q), max(p, q)), ())], p, q)
    for piece in pieces:
        chain(piece, piece[0], piece[1])
    used = sorted({i for e in edges for i in e} | set(corners))
    # Corners first, so that the outer component holds node 0.
    order = corners + [g for g in used if g not in corners]
    local = {g: i for i, g in enumerate(order)}
    xy = np.array([flat(g) for g in order])
    sign = 1.0 if normal[drop] > 0 else -1.0
    if drop == 1:
        sign = -sign  # (z, x) would be the right-handed order for the y axis
    xy[:, 0] *= sign
    graph_edges = {(local[p], local[q]) for p, q in edges}
    out = []
    for loops in _faces_of_graph(xy, graph_edges):
        tris = manifold3d.triangulate([xy[loop] for loop in loops])
        flat_ids = [order[i] for loop in loops for i in loop]
        out.append(np.asarray(flat_ids, np.int64)[np.asarray(tris, np.int64)])
    tris = np.concatenate(out) if out else np.empty((0, 3), np.int64)
    local_ids = {g: i for i, g in enumerate(order)}
    P = np.array([points[g] for g in order])
    L = np.vectorize(local_ids.__getitem__, otypes=[np.int64])(tris) if len(tris) else tris
    cross = np.cross(P[L[:, 1]] - P[L[:, 0]], P[L[:, 2]] - P[L[:, 0]])
    total = float(np.linalg.norm(normal))
    if abs(float(np.sum(cross @ normal)) / total - total) > 1e-9 * total or np.any(
        cross @ normal < -1e-12 * total * total
    ):
        raise UncertainCrossingError("a crossed triangle could not be tiled", (a + b + c) / 3.0)
    return tris


def winding_layers(
    vertices: np.ndarray, faces: np.ndarray, t: np.ndarray, u: np.ndarray
) -> tuple[list[tuple[int, np.ndarray, np.ndarray]], int]:
    """Cut a closed shell along its self-crossings and group it into winding-number layers.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
        A closed, consistently oriented 2-manifold shell.
    t, u : numpy.ndarray, shape (k,), int64
        The pairs of its faces that certainly cross (`exactgrasp.geometry.crossings`).

    Returns
    -------
    layers : list of (int, numpy.ndarray (n', 3), numpy.ndarray (m', 3))
        ``(k, vertices, faces)`` for each non-empty layer: k >= 1 for the boundary of
        {w >= k} (outward), k <= -1 for the boundary of {w <= k} (reversed). Each is an
        oriented 2-manifold (`exactgrasp.geometry.topology.split_nonmanifold`).
    cut_faces : int
        Faces that were split.

    Raises
    ------
    UncertainCrossingError
        A crossing that cannot be cut with certainty.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    points = _Points(V)
    per_face, on_edge = _segments(V, F, np.asarray(t), np.asarray(u), points)
    # Faces whose edges were pierced but which no crossing pair names still get the points.
    for f in range(len(F)):
        if f in per_face:
            continue
        for k in range(3):
            p, q = int(F[f, k]), int(F[f, (k + 1) % 3])
            if (min(p, q), max(p, q)) in on_edge:
                per_face[f] = []
                break
    new_faces = [F[np.setdiff1d(np.arange(len(F)), list(per_face))]]
    for f, segs in per_face.items():
        new_faces.append(_split_face(V, F, f, segs, on_edge, points))
    P = points.array()
    G = np.concatenate(new_faces)
    # Patches: faces joined across edges of exactly two faces (crossing curves have four).
    n = len(P)
    tail = G.reshape(-1)
    head = G[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(tail, head) * np.int64(n) + np.maximum(tail, head)
    order = np.argsort(key, kind="stable")
    sk = key[order]
    bounds = np.flatnonzero(np.r_[True, sk[1:] != sk[:-1], True])
    uses = np.diff(bounds)
    pair = bounds[:-1][uses == 2]
    fa, fb = order[pair] // 3, order[pair + 1] // 3
    m = len(G)
    n_patch, patch = connected_components(
        coo_matrix((np.ones(len(fa)), (fa, fb)), (m, m)), directed=False
    )
    cross = np.cross(P[G[:, 1]] - P[G[:, 0]], P[G[:, 2]] - P[G[:, 0]])
    area = np.linalg.norm(cross, axis=1)
    level = np.zeros(n_patch, np.int64)
    mask = np.ones(m, bool)
    for p in range(n_patch):
        members = np.flatnonzero(patch == p)
        for f in members[np.argsort(-area[members])][:8]:
            x = P[G[f]].mean(0)
            mask[f] = False
            w = float(winding_number(x, P, G[mask])) + 0.5
            mask[f] = True
            if abs(w - round(w)) < 1e-3:
                level[p] = round(w)
                break
        else:
            raise UncertainCrossingError(
                "a patch of the cut surface lies on another part of it", x
            )
    layer_of_face = level[patch]
    layer_of_face = np.where(layer_of_face >= 1, layer_of_face, layer_of_face - 1)
    layers = []
    for k in sorted(set(layer_of_face.tolist()), key=lambda k: (k < 0, abs(k))):
        Fk = G[layer_of_face == k]
        used, inverse = np.unique(Fk.reshape(-1), return_inverse=True)
        Vk, Fk, _, _ = split_nonmanifold(P[used], inverse.reshape(-1, 3).astype(np.int64))
        layers.append((int(k), Vk, Fk))
    return layers, len(per_face)
