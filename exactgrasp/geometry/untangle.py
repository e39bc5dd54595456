"""A closed surface made ready for `exactgrasp.geometry.shells`: untangled and cut.

`untangle` drops repeated faces, untangles edges of more than two faces
(`exactgrasp.geometry.topology`) and cuts each shell that crosses itself into winding-number
layers (`exactgrasp.geometry.arrangement`); `cut_cluster` does the same for a group of shells
that cross one another where a union cannot express their solid. Crossings come from
`exactgrasp.geometry.crossings`, with copies of one point counted as one vertex; a surface
that touches itself where signs are uncertain is kept only if its winding number stays 0 or 1
along a grid of lines (`check_self_contact`).
"""

from __future__ import annotations

import numpy as np

from exactgrasp.errors import MeshError, UncertainCrossingError
from exactgrasp.geometry.arrangement import winding_layers
from exactgrasp.geometry.crossings import CROSS, UNSURE, find_crossings
from exactgrasp.geometry.topology import (
    compact,
    drop_repeated_faces,
    edge_defects,
    split_nonmanifold,
    split_shells,
)
from exactgrasp.geometry.winding import winding_range_columns

__all__ = ["SELF_FIX", "crossing_pairs", "cut_cluster", "format_point", "untangle"]

SELF_FIX = (
    "fix the mesh in a modeller (e.g. MeshLab's 'Select Self Intersecting Faces', then delete "
    "them and close the hole, or Blender's 3D-print toolbox 'Intersect Face')"
)


def format_point(x: np.ndarray) -> str:
    """A point for messages: ``(x, y, z)`` to 6 significant digits."""
    return f"({x[0]:.6g}, {x[1]:.6g}, {x[2]:.6g})"


def crossing_pairs(V: np.ndarray, F: np.ndarray, label: np.ndarray):
    """`find_crossings` with self-contacts, copies of one point counted as one vertex."""
    _, identity = np.unique(V, axis=0, return_inverse=True)
    return find_crossings(V, F, label, identity=identity.reshape(-1), self_contacts=True)


def check_self_contact(V, F, mine, t, u, contact, name, s, n_shells) -> None:
    """A shell whose triangles touch where floating-point signs cannot tell touching from
    crossing: kept if its winding number stays 0 or 1 (-1 or 0 if reversed) along a grid of
    vertical lines, refused otherwise (it then passes through itself exactly at an edge or a
    corner, which is not cut here)."""
    corners = V[F]
    lo, hi = corners.reshape(-1, 3).min(0), corners.reshape(-1, 3).max(0)
    spacing = float(max(hi[0] - lo[0], hi[1] - lo[1])) / 96.0 or 1.0
    # Lines off the box's simple fractions, where modelled features (and the contacts, often
    # in a coordinate plane) tend to sit.
    origin = lo - np.array([0.381966, 0.618034, 0.0]) * spacing
    shape = np.floor((hi[:2] - origin[:2]) / spacing).astype(np.int64) + 1
    least, most = winding_range_columns((corners - origin) / spacing, int(shape[0]), int(shape[1]))
    if most - least <= 1 and least in (-1, 0):
        return
    i = int(np.flatnonzero(mine)[0])
    where = f"shell {s} of {n_shells}" if n_shells > 1 else "the surface"
    raise MeshError(
        f"{name}: {where} passes through itself (winding numbers from {least} to {most}) "
        f"where its triangles meet exactly at an edge or a corner ({int(mine.sum())} triangle "
        f"pairs, e.g. triangles {int(t[i])} and {int(u[i])} near {format_point(contact)}), "
        f"which floating-point signs cannot cut; {SELF_FIX}, or perturb the mesh slightly."
    )


def untangle(V: np.ndarray, F: np.ndarray, name: str):
    """Repeated faces dropped, non-manifold edges untangled, self-crossing shells cut into
    winding-number layers; with the shells and their crossings, and what was done."""
    actions: list[str] = []
    G, repeated, cancelled = drop_repeated_faces(F)
    if repeated or cancelled:
        actions.append(
            f"dropped {repeated} repeated and {cancelled} mutually cancelling (reversed) faces"
        )
    defects = edge_defects(V, G)
    if not defects.is_cycle:
        raise MeshError(
            f"{name}: not a closed surface ({defects.describe()}), so it bounds no solid; "
            "close it first (repair=True)."
        )
    W = V
    if defects.nonmanifold:
        W, G, n_edges, n_split = split_nonmanifold(V, G)
        actions.append(
            f"separated the faces of {n_edges} edges shared by more than two faces (e.g. at "
            f"{format_point(defects.nonmanifold_at)}) into pairs bounding one solid wedge each, "
            f"splitting {n_split} vertices"
        )
    n_shells, label = split_shells(G, len(W))
    t, u, code, point = crossing_pairs(W, G, label)
    same = label[t] == label[u]
    cross = same & (code == CROSS)
    if cross.any():
        kept = [G[~np.isin(label, label[t[cross]])]]
        coords = [W]
        offset = len(W)
        for s in np.unique(label[t[cross]]):
            mine = cross & (label[t] == s)
            faces_s = np.flatnonzero(label == s)
            local = np.full(len(G), -1)
            local[faces_s] = np.arange(len(faces_s))
            Vs, Fs = compact(W, G[faces_s])
            where = f"shell {s} of {n_shells}" if n_shells > 1 else "the surface"
            x = point[np.flatnonzero(mine)[0]]
            try:
                layers, n_cut = winding_layers(Vs, Fs, local[t[mine]], local[u[mine]])
            except UncertainCrossingError as exc:
                raise MeshError(
                    f"{name}: {where} ({len(Vs)} vertices, {len(Fs)} triangles) crosses itself "
                    f"in {int(mine.sum())} triangle pairs (e.g. near {format_point(x)}), and near "
                    f"{format_point(exc.point)} {exc.why}, so the crossing cannot be cut with "
                    f"certainty; {SELF_FIX}."
                ) from exc
            for _, Vk, Fk in layers:
                coords.append(Vk)
                kept.append(Fk + offset)
                offset += len(Vk)
            kinds = ", ".join(
                f"w >= {k}" if k > 0 else f"w <= {k} (reversed)" for k, _, _ in layers
            )
            actions.append(
                f"cut {where} ({len(Vs)} vertices, {len(Fs)} triangles), which crosses itself "
                f"in {int(mine.sum())} triangle pairs (e.g. near {format_point(x)}), along its "
                f"crossings ({n_cut} triangles split) into the boundaries of {kinds}"
            )
        W = np.concatenate(coords)
        G = np.concatenate(kept)
        W, G = compact(W, G)
        n_shells, label = split_shells(G, len(W))
        t, u, code, point = crossing_pairs(W, G, label)
        same = label[t] == label[u]
    touch = same & (code == UNSURE)
    for s in np.unique(label[t[touch]]):
        mine = touch & (label[t] == s)
        contact = W[G[t[np.flatnonzero(mine)[0]]]].mean(0)
        check_self_contact(W, G[label == s], mine, t, u, contact, name, s, n_shells)
    if not actions:
        return V, F, label, n_shells, t, u, code, actions
    return W, G, label, n_shells, t, u, code, actions


def cut_cluster(parts, around: int, refusal: MeshError) -> tuple[np.ndarray, np.ndarray]:
    """The boundary of the solid inside a group of crossing shells: their surfaces cut along
    every crossing, and the patches between winding numbers 1 and 0, counting the
    ``around`` of the shells that hold the group (`exactgrasp.geometry.arrangement`).
    ``refusal`` is raised where the shells touch with uncertain signs (a coplanar contact
    would need cutting too) or a crossing cannot be cut."""
    offsets = np.cumsum([0] + [len(p[0]) for p in parts])
    V = np.concatenate([p[0] for p in parts])
    F = np.concatenate([p[1] + o for p, o in zip(parts, offsets, strict=False)])
    _, label = split_shells(F, len(V))
    t, u, code, _ = crossing_pairs(V, F, label)
    if (code == UNSURE).any():
        raise refusal
    try:
        layers, _ = winding_layers(V, F, t, u)
    except UncertainCrossingError:
        raise refusal from None
    # The solid's boundary there lies between the group's winding numbers 1 - around (behind)
    # and -around; `winding_layers` numbers a layer k <= 0 as k - 1.
    level = 1 - around
    wanted = level if level >= 1 else level - 1
    for k, Vk, Fk in layers:
        if k == wanted:
            return Vk, Fk
    return np.empty((0, 3)), np.empty((0, 3), np.int64)
