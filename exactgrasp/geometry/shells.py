"""Shells of a closed mesh: how they relate, and the one solid they bound.

A closed, consistently oriented triangle mesh may hold several shells (sets of triangles
connected by shared edges). `resolve_shells` finds how they relate and returns the mesh of the
solid they bound, read with positive-winding semantics: the solid is the set of points whose
winding number (the sum over shells of +1 inside an outward shell, -1 inside a reversed one) is
at least 1.

* Disjoint shells, and cavities (a reversed shell inside an outward one, possibly holding
  islands) are boundaries of that set: the mesh is returned unchanged.
* Shells whose surfaces cross or may touch, and same-orientation shells nested in each other
  (a region of winding number 2), are replaced by the solid they bound, computed with
  manifold3d booleans, with a warning.
* A reversed shell inside no other shell is an inside-out body: flipped with a warning or
  refused (``orientation``).
* A shell whose surface crosses itself has no well-defined inside and is refused.

Crossings are found with a uniform grid of triangle bounding boxes and an edge-triangle test
whose orientation signs are certified by a static error bound (Shewchuk's, as in the exact
backend's kernels): a sign inside the bound is *uncertain*. Between two shells an uncertain
sign (touching, coplanar contact) counts as "may touch" and the shells are merged, which is
safe. Within one shell only certain crossings count; pairs of triangles sharing an edge are
skipped (two non-coplanar triangles sharing an edge meet only on it), pairs sharing a vertex
are tested (their shared corner gives uncertain signs, never a certain crossing).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exactgrasp.errors import MeshError, warn_caller
from exactgrasp.geometry.manifold import to_manifold
from exactgrasp.geometry.predicates import orient_bound, orient_det
from exactgrasp.geometry.winding import winding_number

__all__ = ["find_crossings", "resolve_shells", "split_shells"]

_NO, _CROSS, _UNSURE = 0, 1, 2
_MERGE_FIX = (
    "overlapping shells cannot be merged; fix the mesh in a modeller (e.g. MeshLab's "
    "'Remove Duplicate Vertices' and 'Repair non Manifold Vertices')."
)
_SELF_FIX = (
    "fix the mesh in a modeller (e.g. MeshLab's 'Select Self Intersecting Faces', then delete "
    "them and close the hole, or Blender's 3D-print toolbox 'Intersect Face')"
)


# -- numba kernels ----------------------------------------------------------------------------


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _sign(det, bound):
    if det > bound:
        return 1
    if det < -bound:
        return -1
    return 0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _edge_tri(X, e0, e1, a, b, c, bound):
    """Does the closed segment from corner ``e0`` to ``e1`` meet the closed triangle of
    corners ``a, b, c``? Corners are rows of X (6, 3): scalar loads, no array views in the
    hot loop.

    Returns ``(code, lam)``: `_NO` (certainly not), `_CROSS` (certainly, through the
    triangle's interior, at ``X[e0] + lam (X[e1] - X[e0])``) or `_UNSURE`.
    """
    px, py, pz = X[e0, 0], X[e0, 1], X[e0, 2]
    qx, qy, qz = X[e1, 0], X[e1, 1], X[e1, 2]
    ax, ay, az = X[a, 0], X[a, 1], X[a, 2]
    bx, by, bz = X[b, 0], X[b, 1], X[b, 2]
    cx, cy, cz = X[c, 0], X[c, 1], X[c, 2]
    dp = orient_det(ax, ay, az, bx, by, bz, cx, cy, cz, px, py, pz)
    dq = orient_det(ax, ay, az, bx, by, bz, cx, cy, cz, qx, qy, qz)
    sp = _sign(dp, bound)
    sq = _sign(dq, bound)
    if sp != 0 and sp == sq:
        return _NO, 0.0
    s1 = _sign(orient_det(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz), bound)
    s2 = _sign(orient_det(px, py, pz, qx, qy, qz, bx, by, bz, cx, cy, cz), bound)
    s3 = _sign(orient_det(px, py, pz, qx, qy, qz, cx, cy, cz, ax, ay, az), bound)
    if (s1 > 0 or s2 > 0 or s3 > 0) and (s1 < 0 or s2 < 0 or s3 < 0):
        return _NO, 0.0
    if sp == 0 or sq == 0 or s1 == 0 or s2 == 0 or s3 == 0:
        return _UNSURE, 0.0
    return _CROSS, dp / (dp - dq)


@njit(cache=True, nogil=True, error_model="numpy")
def _tri_tri(V, F, t, u, skip_shared, X, out):
    """Do triangles t and u of (V, F) meet? `_NO`, `_CROSS` (a certain crossing, its point
    written to ``out`` (3,)) or `_UNSURE`. With ``skip_shared`` (triangles of one shell
    sharing one corner), meeting only at that corner counts as `_NO`. ``X`` (6, 3) is
    scratch space.

    Two closed triangles meet iff an edge of one meets the other, so six edge tests decide.
    """
    for k in range(3):
        for ax in range(3):
            X[k, ax] = V[F[t, k], ax]
            X[k + 3, ax] = V[F[u, k], ax]
    ext = 0.0
    for ax in range(3):
        lo = X[0, ax]
        hi = lo
        for k in range(1, 6):
            lo = min(lo, X[k, ax])
            hi = max(hi, X[k, ax])
        ext = max(ext, hi - lo)
    bound = orient_bound(ext * (1.0 + 1e-12))
    # Cheap rejection: one triangle certainly on one side of the other's plane. With
    # ``skip_shared``, a corner shared by both is left out: the pair then meets only there.
    for first in range(2):
        a, b = (0, 3) if first == 0 else (3, 0)
        ta, tb = (t, u) if first == 0 else (u, t)
        side = 0
        split = False
        for k in range(3):
            vk = F[tb, k]
            if skip_shared and (vk == F[ta, 0] or vk == F[ta, 1] or vk == F[ta, 2]):
                continue
            s = _sign(
                orient_det(X[a, 0], X[a, 1], X[a, 2], X[a + 1, 0], X[a + 1, 1], X[a + 1, 2],
                        X[a + 2, 0], X[a + 2, 1], X[a + 2, 2],
                        X[b + k, 0], X[b + k, 1], X[b + k, 2]),
                bound,
            )  # fmt: skip
            if s == 0 or (side != 0 and s != side):
                split = True
                break
            side = s
        if not split:
            return _NO
    result = _NO
    for first in range(2):
        a, b = (0, 3) if first == 0 else (3, 0)
        for k in range(3):
            e0 = a + k
            e1 = a + (k + 1) % 3
            code, lam = _edge_tri(X, e0, e1, b, b + 1, b + 2, bound)
            if code == _CROSS:
                for ax in range(3):
                    out[ax] = X[e0, ax] + lam * (X[e1, ax] - X[e0, ax])
                return _CROSS
            if code == _UNSURE:
                result = _UNSURE
    return result


@njit(cache=True, nogil=True, error_model="numpy")
def _fill_cells(i0, i1, n, offsets, keys, tris):
    """Write the (flat cell, triangle) entries of every triangle's bounding-box cell range."""
    for f in range(i0.shape[0]):
        q = offsets[f]
        for i in range(i0[f, 0], i1[f, 0] + 1):
            for j in range(i0[f, 1], i1[f, 1] + 1):
                for k in range(i0[f, 2], i1[f, 2] + 1):
                    keys[q] = (i * n[1] + j) * n[2] + k
                    tris[q] = f
                    q += 1


@njit(cache=True, nogil=True, error_model="numpy")
def _pair_scan(V, F, shell, lo, hi, i0, n, keys, tris):
    """Test every pair of triangles sharing a grid cell, once (in the first cell they share).

    Returns arrays ``t, u, code, point (k, 3)`` of the pairs that matter: certain crossings
    within one shell, and certain or uncertain contacts between two shells.
    """
    ts = [np.int64(0) for _ in range(0)]
    us = [np.int64(0) for _ in range(0)]
    codes = [np.int64(0) for _ in range(0)]
    pts = [0.0 for _ in range(0)]
    out = np.zeros(3)
    X = np.empty((6, 3))
    start = 0
    total = keys.shape[0]
    while start < total:
        end = start + 1
        while end < total and keys[end] == keys[start]:
            end += 1
        cell = keys[start]
        # Sweep along x: sorted by lower x, a cell's later triangles start past t's end.
        run = tris[start:end]
        run = run[np.argsort(lo[run, 0], kind="mergesort")]
        for p in range(run.shape[0]):
            t = run[p]
            for q in range(p + 1, run.shape[0]):
                u = run[q]
                if lo[u, 0] > hi[t, 0]:
                    break
                if (
                    lo[t, 1] > hi[u, 1]
                    or lo[u, 1] > hi[t, 1]
                    or lo[t, 2] > hi[u, 2]
                    or lo[u, 2] > hi[t, 2]
                ):
                    continue
                first = (max(i0[t, 0], i0[u, 0]) * n[1] + max(i0[t, 1], i0[u, 1])) * n[2]
                if first + max(i0[t, 2], i0[u, 2]) != cell:
                    continue
                shared = 0
                for a in range(3):
                    for b in range(3):
                        if F[t, a] == F[u, b]:
                            shared += 1
                if shared >= 2:
                    continue
                code = _tri_tri(V, F, t, u, shared == 1 and shell[t] == shell[u], X, out)
                if code == _NO or (code == _UNSURE and shell[t] == shell[u]):
                    continue
                ts.append(t)
                us.append(u)
                codes.append(code)
                pts.append(out[0] if code == _CROSS else np.nan)
                pts.append(out[1] if code == _CROSS else np.nan)
                pts.append(out[2] if code == _CROSS else np.nan)
        start = end
    return (
        np.array(ts, np.int64),
        np.array(us, np.int64),
        np.array(codes, np.int64),
        np.array(pts, np.float64).reshape(-1, 3),
    )


# -- topology and crossings -------------------------------------------------------------------


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


def find_crossings(
    vertices: np.ndarray, faces: np.ndarray, label: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pairs of triangles that cross (within a shell) or may touch (between shells).

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
    label : numpy.ndarray, shape (m,), int64
        Shell of every face (`split_shells`).

    Returns
    -------
    t, u : numpy.ndarray, shape (k,), int64
        Face indices of each pair found.
    code : numpy.ndarray, shape (k,), int64
        1: a certain crossing; 2: uncertain contact (only between different shells).
    point : numpy.ndarray, shape (k, 3), float64
        A point of a certain crossing (NaN for uncertain contacts), in vertex units.
    """
    V = np.ascontiguousarray(vertices, dtype=np.float64)
    F = np.ascontiguousarray(faces, dtype=np.int64)
    corners = V[F]
    lo = np.ascontiguousarray(corners.min(1))
    hi = np.ascontiguousarray(corners.max(1))
    origin = lo.min(0)
    span = float((hi.max(0) - origin).max())
    size = float((hi - lo).max(1).mean())
    h = max(size, span * 1e-6, 1e-300)
    while True:
        # Cells of about a triangle's size: few pairs per cell; coarser while long triangles
        # would fill too many cells.
        n = np.minimum(np.floor((hi.max(0) - origin) / h).astype(np.int64) + 1, 2**20)
        i0 = np.minimum(np.floor((lo - origin) / h).astype(np.int64), n - 1)
        i1 = np.minimum(np.floor((hi - origin) / h).astype(np.int64), n - 1)
        counts = np.prod(i1 - i0 + 1, axis=1)
        if counts.sum() <= 16 * len(F) + 1024 or h >= span:
            break
        h *= 2.0
    offsets = np.zeros(len(F) + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    keys = np.empty(offsets[-1], np.int64)
    tris = np.empty(offsets[-1], np.int64)
    _fill_cells(i0, i1, n, offsets, keys, tris)
    order = np.argsort(keys, kind="stable")
    label = np.ascontiguousarray(label, dtype=np.int64)
    return _pair_scan(V, F, label, lo, hi, i0, n, keys[order], tris[order])


# -- resolution -------------------------------------------------------------------------------


def _signed_volumes(V: np.ndarray, F: np.ndarray, label: np.ndarray, n: int) -> np.ndarray:
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.bincount(label, np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0, minlength=n)


def _compact(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    used, inverse = np.unique(F.reshape(-1), return_inverse=True)
    return np.ascontiguousarray(V[used]), inverse.reshape(-1, 3).astype(np.int64)


def _fmt_shells(indices, shells) -> str:
    return ", ".join(f"{i} ({shells[i]['vertices']} vertices)" for i in indices)


def resolve_shells(
    vertices: np.ndarray,
    faces: np.ndarray,
    name: str,
    *,
    orientation: str = "flip",
    warn: Callable[[str], Any] | None = None,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Split a closed mesh into shells, and return the mesh of the solid they bound.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64, metres
    faces : numpy.ndarray, shape (m, 3), int64
        A closed, consistently oriented surface (every edge in exactly two faces, neighbours
        agreeing on the outside); this is not checked here.
    name : str
        The mesh, in messages.
    orientation : {"flip", "refuse"}
        What to do with a reversed shell that lies inside no other shell (an inside-out
        body) when there are several shells: flip it (and what it holds) with a warning, or
        refuse. A mesh of one shell is returned as is whatever its orientation: the caller
        decides (`exactgrasp.geometry.solid.Solid` does, with the same option).
    warn : callable, optional
        Called with the warning text when the mesh is changed; default `warnings.warn` at
        the first caller outside exactgrasp.

    Returns
    -------
    vertices : numpy.ndarray, shape (n', 3), float64, metres
    faces : numpy.ndarray, shape (m', 3), int64
        The input arrays themselves when nothing changed, else the resolved mesh.
    report : dict
        ``n_shells``; ``shells``: per shell ``{"index", "vertices", "faces", "volume"
        (signed, m^3), "role"}`` with role one of ``"outer"``, ``"cavity"``, ``"island"``
        (an outward shell inside a cavity), ``"merged"``, ``"redundant"`` (dropped: it
        bounds nothing the other shells do not), ``"flipped"``; ``crossing_pairs`` and
        ``touching_pairs`` (certain crossings and uncertain contacts between shells);
        ``actions`` (what was done, in words; empty when nothing changed);
        ``volume_before`` and ``volume_after`` (m^3, signed sums over the shells).

    Raises
    ------
    MeshError
        A shell whose surface crosses itself; shells whose relation has no resolution here
        (see the module docstring); an inside-out shell with ``orientation="refuse"``.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    n_shells, label = split_shells(F, len(V))
    t, u, code, point = find_crossings(V, F, label)
    same = label[t] == label[u]
    if same.any():
        bad = int(label[t[same][0]])
        mine = same & (label[t] == bad)
        x = point[np.flatnonzero(mine)[0]]
        nv = len(np.unique(F[label == bad]))
        where = f"shell {bad} of {n_shells} " if n_shells > 1 else "the surface "
        raise MeshError(
            f"{name}: {where}({nv} vertices, {int((label == bad).sum())} triangles) crosses "
            f"itself: {int(mine.sum())} pairs of its triangles cross, e.g. triangles "
            f"{int(t[mine][0])} and {int(u[mine][0])} near ({x[0]:.6g}, {x[1]:.6g}, "
            f"{x[2]:.6g}), so it has no well-defined inside; {_SELF_FIX}."
        )
    volumes = _signed_volumes(V, F, label, n_shells)
    total = float(volumes.sum())
    report: dict[str, Any] = {
        "n_shells": n_shells,
        "shells": [],
        "crossing_pairs": int((code == _CROSS).sum()),
        "touching_pairs": int((code == _UNSURE).sum()),
        "actions": [],
        "volume_before": total,
        "volume_after": total,
    }
    if n_shells == 1:
        report["shells"] = [
            {"index": 0, "vertices": len(np.unique(F)), "faces": len(F), "volume": total,
             "role": "outer"}
        ]  # fmt: skip
        return vertices, faces, report
    return _resolve(V, F, name, label, n_shells, volumes, t, u, code, orientation, warn, report)


def _resolve(V, F, name, label, n_shells, volumes, t, u, code, orientation, warn, report):
    import manifold3d as m3

    order = np.argsort(label, kind="stable")
    starts = np.searchsorted(label[order], np.arange(n_shells + 1))
    parts = [_compact(V, F[order[starts[i] : starts[i + 1]]]) for i in range(n_shells)]
    shells = [
        {"index": i, "vertices": len(p[0]), "faces": len(p[1]), "volume": float(volumes[i]),
         "role": ""}
        for i, p in enumerate(parts)
    ]  # fmt: skip
    report["shells"] = shells
    sign = np.where(volumes > 0, 1, -1)
    # Clusters: shells linked by crossings or possible contacts.
    la, lb = label[t], label[u]
    graph = coo_matrix((np.ones(len(la)), (la, lb)), (n_shells, n_shells))
    n_clusters, cluster = connected_components(graph, directed=False)
    members = [np.flatnonzero(cluster == c) for c in range(n_clusters)]
    lo = np.array([p[0].min(0) for p in parts])
    hi = np.array([p[0].max(0) for p in parts])

    def inside(x: np.ndarray, j: int) -> bool:
        if np.any(x < lo[j]) or np.any(x > hi[j]):
            return False
        return abs(winding_number(x, parts[j][0], parts[j][1])) > 0.5

    # Which shells hold each cluster (its surfaces meet none of theirs, so one point decides).
    holders = []
    for c in range(n_clusters):
        x = parts[members[c][0]][0][0]
        near = np.flatnonzero(np.all(lo <= x, axis=1) & np.all(x <= hi, axis=1))
        holders.append([int(j) for j in near if cluster[j] != c and inside(x, j)])
    actions: list[str] = []
    # Inside-out bodies: a cluster of reversed shells held by nothing, with what it holds.
    top_inverted = [
        c for c in range(n_clusters) if not holders[c] and np.all(sign[members[c]] < 0)
    ]
    if top_inverted:
        flip = {int(i) for c in top_inverted for i in members[c]}
        flip |= {
            int(i)
            for c in range(n_clusters)
            if any(h in flip for h in holders[c])
            for i in members[c]
        }
        flip_list = sorted(flip)
        if orientation == "refuse":
            raise MeshError(
                f"{name}: shell(s) {_fmt_shells(flip_list, shells)} are inside-out (negative "
                "signed volume, inside no other shell); reverse their triangle winding, or "
                "pass orientation='flip' to let exactgrasp do it."
            )
        for i in flip_list:
            sign[i] = -sign[i]
            parts[i] = (parts[i][0], parts[i][1][:, ::-1].copy())
            shells[i]["role"] = "flipped"
        actions.append(f"flipped inside-out shell(s) {_fmt_shells(flip_list, shells)}")
    base = [int(sum(sign[j] for j in holders[c])) for c in range(n_clusters)]

    def refuse(c: int, why: str) -> MeshError:
        return MeshError(
            f"{name}: shells {_fmt_shells(members[c], shells)} {why}; the solid they bound is "
            "not resolved here. Make every body one outward closed shell (cavities as reversed "
            "shells strictly inside it), e.g. with boolean unions and differences in a modeller "
            "(Blender's Boolean modifier, MeshLab's 'Mesh Boolean')."
        )

    out: list[tuple[np.ndarray, np.ndarray]] = []
    changed = bool(top_inverted)
    for c in range(n_clusters):
        idx = members[c]
        signs = sign[idx]
        w = base[c]
        held = sorted({h for h in holders[c]})
        if len(idx) == 1:
            i = int(idx[0])
            if (signs[0] > 0 and w == 0) or (signs[0] < 0 and w == 1):
                if not shells[i]["role"]:
                    shells[i]["role"] = (
                        "cavity" if signs[0] < 0 else ("island" if held else "outer")
                    )
                out.append(parts[i])
                continue
            shells[i]["role"] = "redundant"
            changed = True
            what = (
                "lies inside shell(s) " + _fmt_shells(held, shells)
                if held
                else "is inside no shell"
            )
            actions.append(
                f"dropped shell {_fmt_shells([i], shells)}: it {what} and, with its "
                f"orientation, bounds a region of winding number {w + int(signs[0])} "
                f"against {w} around it, no boundary of the solid"
            )
            continue
        changed = True
        pos = [int(i) for i in idx if sign[i] > 0]
        neg = [int(i) for i in idx if sign[i] < 0]
        pairs = int(np.isin(la, idx).sum())
        crossing = int(((code == _CROSS) & np.isin(la, idx)).sum())
        how = f"{crossing} crossing and {pairs - crossing} touching triangle pairs"
        if neg and pos:
            if w != 0:
                raise refuse(c, "mix crossing outward and reversed shells inside another shell")
            pos_set = set(pos)
            overlapping_pos = any(
                label[a] in pos_set and label[b] in pos_set and label[a] != label[b]
                for a, b in zip(t[np.isin(la, idx)], u[np.isin(la, idx)], strict=True)
            ) or any(inside(parts[i][0][0], j) for i in pos for j in pos if i != j)
            if overlapping_pos:
                raise refuse(c, "mix reversed shells with outward shells that overlap")
        elif (pos and w >= 1) or (neg and w <= 0):
            for i in idx:
                shells[int(i)]["role"] = "redundant"
            actions.append(
                f"dropped shells {_fmt_shells(idx, shells)} ({how}): they lie where the solid "
                "already is (or is not), and bound no boundary of it"
            )
            continue
        elif (pos and w < 0) or (neg and w >= 2):
            raise refuse(c, f"cross each other where the winding number around them is {w}")
        solid = None
        if pos:
            solid = m3.Manifold.batch_boolean(
                [to_manifold(*parts[i], f"{name} shell {i}", _MERGE_FIX) for i in pos],
                m3.OpType.Add,
            )
        if neg:
            holes = m3.Manifold.batch_boolean(
                [
                    to_manifold(parts[i][0], parts[i][1][:, ::-1], f"{name} shell {i}", _MERGE_FIX)
                    for i in neg
                ],
                m3.OpType.Add,
            )
            solid = holes if solid is None else solid - holes
        mesh = solid.to_mesh64()
        merged_v = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
        merged_f = np.asarray(mesh.tri_verts, dtype=np.int64)
        if not pos:
            merged_f = merged_f[:, ::-1]
        for i in idx:
            shells[int(i)]["role"] = "merged"
        volume = float(
            _signed_volumes(merged_v, merged_f, np.zeros(len(merged_f), np.int64), 1)[0]
        )
        actions.append(
            f"merged shells {_fmt_shells(idx, shells)} ({how}) into the solid they bound "
            f"(signed volume {float(volumes[idx].sum()):.6g} -> {volume:.6g} m^3)"
        )
        if len(merged_f):
            out.append((merged_v, merged_f))
    report["actions"] = actions
    if not changed:
        return V, F, report
    if out:
        offsets = np.cumsum([0] + [len(p[0]) for p in out])
        new_v = np.concatenate([p[0] for p in out])
        new_f = np.concatenate([p[1] + o for p, o in zip(out, offsets, strict=False)])
    else:
        raise MeshError(
            f"{name}: resolving its {n_shells} shells leaves no solid (every shell is "
            "redundant); check the orientation of its shells."
        )
    after = float(_signed_volumes(new_v, new_f, np.zeros(len(new_f), np.int64), 1)[0])
    report["volume_after"] = after
    message = (
        f"{name}: {n_shells} shells; " + "; ".join(actions) + f". Volume "
        f"{report['volume_before']:.6g} -> {after:.6g} m^3 (the solid is the set of points of "
        "winding number >= 1)."
    )
    (warn or warn_caller)(message)
    return new_v, new_f, report
