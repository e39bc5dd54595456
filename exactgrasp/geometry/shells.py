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
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exactgrasp.errors import MeshError, warn_caller
from exactgrasp.geometry.crossings import CROSS, UNSURE, find_crossings
from exactgrasp.geometry.manifold import to_manifold
from exactgrasp.geometry.topology import compact, join_meshes, split_shells
from exactgrasp.geometry.untangle import cut_cluster, untangle
from exactgrasp.geometry.winding import winding_number

__all__ = ["find_crossings", "resolve_shells", "split_shells"]

_MERGE_FIX = (
    "overlapping shells cannot be merged; fix the mesh in a modeller (e.g. MeshLab's "
    "'Remove Duplicate Vertices' and 'Repair non Manifold Vertices')."
)


# -- topology and crossings -------------------------------------------------------------------


# -- resolution -------------------------------------------------------------------------------


def _signed_volumes(V: np.ndarray, F: np.ndarray, label: np.ndarray, n: int) -> np.ndarray:
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.bincount(label, np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0, minlength=n)


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
    vertices_in, faces_in = vertices, faces
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    V, F, label, n_shells, t, u, code, untangled, final = untangle(V, F, name)
    if untangled:
        vertices, faces = V, F
    volumes = _signed_volumes(V, F, label, n_shells)
    total = float(volumes.sum())
    report: dict[str, Any] = {
        "n_shells": n_shells,
        "shells": [],
        "crossing_pairs": int((code == CROSS).sum()),
        "touching_pairs": int((code == UNSURE).sum()),
        "actions": list(untangled),
        "untangled": len(untangled),
        "volume_before": total,
        "volume_after": total,
    }
    if untangled:
        report["volume_before"] = _signed_volume(vertices_in, faces_in)
    if n_shells == 1 or final:
        report["shells"] = [
            {"index": i, "vertices": len(np.unique(F[label == i])),
             "faces": int((label == i).sum()), "volume": float(volumes[i]),
             "role": "resolved" if final else "outer"}
            for i in range(n_shells)
        ]  # fmt: skip
        if untangled:
            report["volume_after"] = total
            _warn_resolved(name, n_shells, report, warn)
        return vertices, faces, report
    return _resolve(V, F, name, label, n_shells, volumes, t, u, code, orientation, warn, report)


def _resolve(V, F, name, label, n_shells, volumes, t, u, code, orientation, warn, report):
    order = np.argsort(label, kind="stable")
    starts = np.searchsorted(label[order], np.arange(n_shells + 1))
    parts = [compact(V, F[order[starts[i] : starts[i + 1]]]) for i in range(n_shells)]
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

    holders = _holders(parts, cluster, members, inside, lo, hi)
    actions: list[str] = report["actions"]
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
    changed = bool(top_inverted) or bool(actions)
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
        crossing = int(((code == CROSS) & np.isin(la, idx)).sum())
        how = f"{crossing} crossing and {pairs - crossing} touching triangle pairs"
        why = ""
        if neg and pos:
            if w != 0:
                why = "mix crossing outward and reversed shells inside another shell"
            pos_set = set(pos)
            overlapping_pos = any(
                label[a] in pos_set and label[b] in pos_set and label[a] != label[b]
                for a, b in zip(t[np.isin(la, idx)], u[np.isin(la, idx)], strict=True)
            ) or any(inside(parts[i][0][0], j) for i in pos for j in pos if i != j)
            if overlapping_pos:
                why = "mix reversed shells with outward shells that overlap"
        elif (pos and w >= 1) or (neg and w <= 0):
            for i in idx:
                shells[int(i)]["role"] = "redundant"
            actions.append(
                f"dropped shells {_fmt_shells(idx, shells)} ({how}): they lie where the solid "
                "already is (or is not), and bound no boundary of it"
            )
            continue
        elif (pos and w < 0) or (neg and w >= 2):
            why = f"cross each other where the winding number around them is {w}"
        if why:
            merged_v, merged_f = cut_cluster([parts[int(i)] for i in idx], w, refuse(c, why))
            for i in idx:
                shells[int(i)]["role"] = "merged"
            actions.append(
                f"cut shells {_fmt_shells(idx, shells)} ({how}, {why}) along their crossings "
                f"into the boundary of the solid (signed volume "
                f"{float(volumes[idx].sum()):.6g} -> {_signed_volume(merged_v, merged_f):.6g} m^3)"
            )
            if len(merged_f):
                out.append((merged_v, merged_f))
            continue
        merged_v, merged_f = _merge(parts, pos, neg, name)
        for i in idx:
            shells[int(i)]["role"] = "merged"
        volume = _signed_volume(merged_v, merged_f)
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
        new_v, new_f = join_meshes(out)
    else:
        raise MeshError(
            f"{name}: resolving its {n_shells} shells leaves no solid (every shell is "
            "redundant); check the orientation of its shells."
        )
    report["volume_after"] = _signed_volume(new_v, new_f)
    _warn_resolved(name, n_shells, report, warn)
    return new_v, new_f, report


def _holders(parts, cluster, members, inside, lo, hi) -> list[list[int]]:
    """The shells that hold each cluster: its surfaces meet none of theirs, so one point (a
    vertex of the cluster) decides, by ``inside(x, shell)``."""
    holders = []
    for c, idx in enumerate(members):
        x = parts[idx[0]][0][0]
        near = np.flatnonzero(np.all(lo <= x, axis=1) & np.all(x <= hi, axis=1))
        holders.append([int(j) for j in near if cluster[j] != c and inside(x, j)])
    return holders


def _merge(parts, pos: list[int], neg: list[int], name: str) -> tuple[np.ndarray, np.ndarray]:
    """The union of the outward shells ``pos`` less the union of the reversed shells ``neg``
    (flipped), with manifold3d; reversed again when there are only reversed shells."""
    import manifold3d as m3

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
    return merged_v, merged_f


def _signed_volume(V: np.ndarray, F: np.ndarray) -> float:
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    return float(_signed_volumes(V, F, np.zeros(len(F), np.int64), 1)[0])


def _warn_resolved(name: str, n_shells: int, report: dict[str, Any], warn) -> None:
    """The one warning of a mesh that was changed: every action, the volume before and after."""
    # A mesh that was untangled or cut first is named by what was done to it, since its
    # shells are those of the result.
    shells = "" if report["untangled"] else f"{n_shells} shells; "
    (warn or warn_caller)(
        f"{name}: {shells}" + "; ".join(report["actions"]) + f". Volume "
        f"{report['volume_before']:.6g} -> {report['volume_after']:.6g} m^3 (the solid is the "
        "set of points of winding number >= 1)."
    )
