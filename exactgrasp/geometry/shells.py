"""Shells of a closed mesh: how they relate, and the one solid they bound.

A closed, consistently oriented triangle mesh may hold several shells (sets of triangles
connected by shared edges). `resolve_shells` finds how they relate and returns the mesh of the
solid they bound, read with positive-winding semantics: the solid is the set of points whose
winding number (the sum over shells of +1 inside an outward shell, -1 inside a reversed one) is
at least 1.

* Disjoint shells, and cavities (a reversed shell inside an outward one, possibly holding
  islands) are boundaries of that set: the mesh is returned unchanged.
* Shells whose surfaces cross, and same-orientation shells nested in each other (a region of
  winding number 2), are replaced by the solid they bound, with a warning: outward shells
  whose crossings are all certain are merged with manifold3d booleans; shells that touch or
  overlap where floating-point signs cannot decide (faces in one plane, an edge through an
  edge or a corner, a corner on a face), and mixes a union cannot express, are cut along
  their contacts (`exactgrasp.geometry.untangle.cut_cluster`, in exact arithmetic where
  needed) and the patches between winding numbers 1 and 0 kept.
* A reversed shell inside no other shell is an inside-out body: flipped with a warning or
  refused (``orientation``).
* A shell that crosses or touches itself has been cut already
  (`exactgrasp.geometry.untangle`).

Crossings are found with a uniform grid of triangle bounding boxes and an edge-triangle test
whose orientation signs are certified by a static error bound (Shewchuk's, as in the exact
backend's kernels): a sign inside the bound is *uncertain*. Between two shells an uncertain
sign (touching, coplanar contact) counts as "may touch": the shells are related as one group.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exactgrasp.errors import MeshError, warn_once
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


class _Shells:
    """The shells of one mesh while they are resolved, and what was done to them.

    Attributes
    ----------
    name : str
        The mesh, in messages.
    parts : list of (numpy.ndarray (k, 3) float64 m, numpy.ndarray (l, 3) int64)
        Each shell's own vertices and faces (faces reversed once a shell is flipped).
    rows : list of dict
        Each shell's row of the report (``"role"`` empty until decided).
    sign : numpy.ndarray, shape (n,), int
        +1 for an outward shell, -1 for a reversed one (after flipping).
    volumes : numpy.ndarray, shape (n,), float64, m^3
        Signed volumes as given.
    lo, hi : numpy.ndarray, shape (n, 3), float64, m
        Each shell's bounding box.
    actions : list of str
        What was done, in words (the report's ``actions``, appended to).
    """

    def __init__(self, V, F, name, label, n_shells, volumes, actions) -> None:
        order = np.argsort(label, kind="stable")
        starts = np.searchsorted(label[order], np.arange(n_shells + 1))
        self.name = name
        self.parts = [compact(V, F[order[starts[i] : starts[i + 1]]]) for i in range(n_shells)]
        self.rows = [
            {"index": i, "vertices": len(p[0]), "faces": len(p[1]), "volume": float(volumes[i]),
             "role": ""}
            for i, p in enumerate(self.parts)
        ]  # fmt: skip
        self.sign = np.where(volumes > 0, 1, -1)
        self.volumes = volumes
        self.lo = np.array([p[0].min(0) for p in self.parts])
        self.hi = np.array([p[0].max(0) for p in self.parts])
        self.actions = actions

    def inside(self, x: np.ndarray, j: int) -> bool:
        """Whether the point ``x`` (3,) lies inside shell ``j``."""
        if np.any(x < self.lo[j]) or np.any(x > self.hi[j]):
            return False
        return abs(winding_number(x, self.parts[j][0], self.parts[j][1])) > 0.5

    def named(self, indices) -> str:
        """The shells ``indices`` in messages."""
        return ", ".join(f"{i} ({self.rows[i]['vertices']} vertices)" for i in indices)

    def set_role(self, indices, role: str) -> None:
        for i in indices:
            self.rows[int(i)]["role"] = role


def _resolve(V, F, name, label, n_shells, volumes, t, u, code, orientation, warn, report):
    shells = _Shells(V, F, name, label, n_shells, volumes, report["actions"])
    report["shells"] = shells.rows
    # Clusters: shells linked by crossings or possible contacts.
    la, lb = label[t], label[u]
    graph = coo_matrix((np.ones(len(la)), (la, lb)), (n_shells, n_shells))
    n_clusters, cluster = connected_components(graph, directed=False)
    members = [np.flatnonzero(cluster == c) for c in range(n_clusters)]
    holders = _holders(shells, cluster, members)
    _flip_inside_out(shells, members, holders, orientation)
    out: list[tuple[np.ndarray, np.ndarray]] = []
    for c, idx in enumerate(members):
        # The winding number around the cluster, from the shells that hold it.
        w = int(sum(shells.sign[j] for j in holders[c]))
        if len(idx) == 1:
            part = _lone_shell(shells, int(idx[0]), w, sorted(set(holders[c])))
        else:
            in_cluster = np.isin(la, idx)
            pair_labels = list(zip(la[in_cluster], lb[in_cluster], strict=True))
            crossing = int((code[in_cluster] == CROSS).sum())
            part = _resolve_cluster(shells, idx, w, pair_labels, crossing)
        if part is not None and len(part[1]):
            out.append(part)
    if not shells.actions:
        return V, F, report
    if not out:
        raise MeshError(
            f"{name}: resolving its {n_shells} shells leaves no solid (every shell is "
            "redundant); check the orientation of its shells."
        )
    new_v, new_f = join_meshes(out)
    report["volume_after"] = _signed_volume(new_v, new_f)
    _warn_resolved(name, n_shells, report, warn)
    return new_v, new_f, report


def _flip_inside_out(shells: _Shells, members, holders, orientation: str) -> None:
    """Flip (or refuse) the inside-out bodies: each cluster of reversed shells held by
    nothing, with every cluster it holds."""
    n_clusters = len(members)
    top_inverted = [
        c for c in range(n_clusters) if not holders[c] and np.all(shells.sign[members[c]] < 0)
    ]
    if not top_inverted:
        return
    flip = {int(i) for c in top_inverted for i in members[c]}
    flip |= {
        int(i) for c in range(n_clusters) if any(h in flip for h in holders[c]) for i in members[c]
    }
    flip_list = sorted(flip)
    if orientation == "refuse":
        raise MeshError(
            f"{shells.name}: shell(s) {shells.named(flip_list)} are inside-out (negative "
            "signed volume, inside no other shell); reverse their triangle winding, or "
            "pass orientation='flip' to let exactgrasp do it."
        )
    for i in flip_list:
        shells.sign[i] = -shells.sign[i]
        shells.parts[i] = (shells.parts[i][0], shells.parts[i][1][:, ::-1].copy())
    shells.set_role(flip_list, "flipped")
    shells.actions.append(f"flipped inside-out shell(s) {shells.named(flip_list)}")


def _lone_shell(shells: _Shells, i: int, w: int, held: list[int]):
    """Shell ``i``, alone in its cluster inside winding number ``w``: kept when it is a
    boundary of the solid (its mesh returned), else dropped (None)."""
    sign = shells.sign[i]
    if (sign > 0 and w == 0) or (sign < 0 and w == 1):
        if not shells.rows[i]["role"]:
            shells.rows[i]["role"] = "cavity" if sign < 0 else ("island" if held else "outer")
        return shells.parts[i]
    shells.rows[i]["role"] = "redundant"
    what = "lies inside shell(s) " + shells.named(held) if held else "is inside no shell"
    shells.actions.append(
        f"dropped shell {shells.named([i])}: it {what} and, with its "
        f"orientation, bounds a region of winding number {w + int(sign)} "
        f"against {w} around it, no boundary of the solid"
    )
    return None


def _resolve_cluster(shells: _Shells, idx: np.ndarray, w: int, pair_labels, crossing: int):
    """The boundary of the solid that the crossing or touching shells ``idx`` bound inside
    winding number ``w`` (their mesh, or None when they bound none of it): dropped, cut
    along their contacts (in exact arithmetic where floating-point signs cannot decide
    them), or merged with manifold3d.

    ``pair_labels`` holds the shells of each of the cluster's triangle pairs, ``crossing``
    how many of them cross for certain."""
    pos = [int(i) for i in idx if shells.sign[i] > 0]
    neg = [int(i) for i in idx if shells.sign[i] < 0]
    how = f"{crossing} crossing and {len(pair_labels) - crossing} touching triangle pairs"
    if not (neg and pos) and ((pos and w >= 1) or (neg and w <= 0)):
        shells.set_role(idx, "redundant")
        shells.actions.append(
            f"dropped shells {shells.named(idx)} ({how}): they lie where the solid "
            "already is (or is not), and bound no boundary of it"
        )
        return None
    why = _cut_reason(shells, pos, neg, w, pair_labels)
    if why or crossing < len(pair_labels):
        # Contacts that floating-point signs cannot decide are cut exactly, as is what a
        # union less a union cannot express.
        parts = [shells.parts[int(i)] for i in idx]
        merged_v, merged_f, exactly = cut_cluster(
            parts, w, crossing < len(pair_labels), shells.name
        )
        along = " in exact arithmetic" if exactly else ""
        if why:
            done = f"cut shells {shells.named(idx)} ({how}, {why}) along their crossings"
            done += f"{along} into the boundary of the solid"
        else:
            done = f"merged shells {shells.named(idx)} ({how}) into the solid they bound, "
            done += f"cut along their contacts{along}"
    else:
        merged_v, merged_f = _merge(shells.parts, pos, neg, shells.name)
        done = f"merged shells {shells.named(idx)} ({how}) into the solid they bound"
    shells.set_role(idx, "merged")
    shells.actions.append(
        f"{done} (signed volume {float(shells.volumes[idx].sum()):.6g} -> "
        f"{_signed_volume(merged_v, merged_f):.6g} m^3)"
    )
    return merged_v, merged_f


def _cut_reason(shells: _Shells, pos: list[int], neg: list[int], w: int, pair_labels) -> str:
    """Why a cluster with a boundary of the solid in it is cut along its crossings rather than
    merged with manifold3d (empty: merged): what a union less a union cannot resolve."""
    if neg and pos:
        pos_set = set(pos)
        overlapping_pos = any(
            a in pos_set and b in pos_set and a != b for a, b in pair_labels
        ) or any(shells.inside(shells.parts[i][0][0], j) for i in pos for j in pos if i != j)
        if overlapping_pos:
            return "mix reversed shells with outward shells that overlap"
        if w != 0:
            return "mix crossing outward and reversed shells inside another shell"
        return ""
    if (pos and w < 0) or (neg and w >= 2):
        return f"cross each other where the winding number around them is {w}"
    return ""


def _holders(shells: _Shells, cluster: np.ndarray, members) -> list[list[int]]:
    """The shells that hold each cluster: its surfaces meet none of theirs, so one point (a
    vertex of the cluster) decides, by `_Shells.inside`."""
    holders = []
    for c, idx in enumerate(members):
        x = shells.parts[idx[0]][0][0]
        near = np.flatnonzero(np.all(shells.lo <= x, axis=1) & np.all(x <= shells.hi, axis=1))
        holders.append([int(j) for j in near if cluster[j] != c and shells.inside(x, j)])
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
    # Read back at once: a union that manifold3d itself cannot import faithfully (a surface
    # folding back on itself) is refused here, where the mesh is named, not at a boolean.
    shells = ", ".join(str(i) for i in (*pos, *neg))
    to_manifold(merged_v, merged_f, f"{name} (shells {shells} merged)", _MERGE_FIX)
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
    (warn or warn_once)(
        f"{name}: {shells}" + "; ".join(report["actions"]) + f". Volume "
        f"{report['volume_before']:.6g} -> {report['volume_after']:.6g} m^3 (the solid is the "
        "set of points of winding number >= 1)."
    )
