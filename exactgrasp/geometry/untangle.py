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
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exactgrasp.errors import Fix, MeshError, UncertainCrossingError
from exactgrasp.geometry.arrangement import winding_layers
from exactgrasp.geometry.crossings import CROSS, UNSURE, find_crossings
from exactgrasp.geometry.topology import (
    compact,
    drop_repeated_faces,
    edge_defects,
    format_point,
    join_meshes,
    split_nonmanifold,
    split_shells,
)
from exactgrasp.geometry.winding import winding_number, winding_range_columns

__all__ = ["SELF_FIX", "crossing_pairs", "cut_cluster", "format_point", "untangle"]

SELF_FIX = (
    "fix the mesh in a modeller (e.g. MeshLab's 'Select Self Intersecting Faces', then delete "
    "them and close the hole, or Blender's 3D-print toolbox 'Intersect Face')"
)


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


def _untangle_edges(V, F, name, actions):
    """Repeated faces dropped and edges of more than two faces untangled (what was done is
    appended to ``actions``); an open or misoriented surface refused."""
    G, repeated, cancelled = drop_repeated_faces(F)
    if repeated or cancelled:
        actions.append(
            f"dropped {repeated} repeated and {cancelled} mutually cancelling (reversed) faces"
        )
    defects = edge_defects(V, G)
    if not defects.is_cycle:
        raise MeshError(
            f"{name}: not a closed surface ({defects.describe()}), so it bounds no solid; ",
            Fix("repair", True, "pass"),
            " to close it first.",
        )
    W = V
    if defects.nonmanifold:
        W, G, n_edges, n_split = split_nonmanifold(V, G)
        actions.append(
            f"separated the faces of {n_edges} edges shared by more than two faces (e.g. at "
            f"{format_point(defects.nonmanifold_at)}) into pairs bounding one wedge each, "
            f"splitting {n_split} vertices"
        )
    return W, G


def untangle(V: np.ndarray, F: np.ndarray, name: str):
    """Repeated faces dropped, non-manifold edges untangled, self-crossing shells cut; with
    the shells and their crossings, what was done, and whether the result is final (every
    shell was cut with the group it crosses: the mesh is the solid's boundary as it is)."""
    actions: list[str] = []
    W, G = _untangle_edges(V, F, name, actions)
    n_shells, label = split_shells(G, len(W))
    t, u, code, point = crossing_pairs(W, G, label)
    same = label[t] == label[u]
    cross = same & (code == CROSS)
    final = False
    if cross.any():
        # Shells linked to a self-crossing one by certain crossings are cut with it, as one
        # group, unless some of them touch where signs are uncertain (a touching contact is
        # not cut, so patches there could not be told apart): then each self-crossing shell
        # is cut alone into its layers, and the shells are related afterwards.
        certain = code == CROSS
        links = coo_matrix(
            (np.ones(int(certain.sum())), (label[t[certain]], label[u[certain]])),
            (n_shells, n_shells),
        )
        _, group = connected_components(links, directed=False)
        unsure = np.zeros(n_shells, bool)
        unsure[label[t[code == UNSURE]]] = True
        unsure[label[u[code == UNSURE]]] = True
        replaced = np.zeros(n_shells, bool)
        layered = False
        pieces: list[tuple[np.ndarray, np.ndarray]] = []
        for s in np.unique(label[t[cross]]):
            if replaced[s]:
                continue
            members = np.flatnonzero(group == group[s])
            if not unsure[members].any():
                replaced[members] = True
                Vc, Fc, action = _cut_group(W, G, label, members, name, n_shells)
                pieces.append((Vc, Fc))
                actions.append(action)
                continue
            replaced[s] = True
            layered = True
            layers, action = _cut_alone(W, G, label, s, t, u, point, cross, name, n_shells)
            pieces += layers
            actions.append(action)
        # Cut groups are the solid's boundary already: with nothing else left, the shells need
        # relating no more.
        final = bool(replaced.all()) and not layered
        W, G = compact(*join_meshes([(W, G[~replaced[label]]), *pieces]))
        n_shells, label = split_shells(G, len(W))
        t, u, code, point = crossing_pairs(W, G, label)
        same = label[t] == label[u]
    touch = same & (code == UNSURE)
    for s in np.unique(label[t[touch]]):
        mine = touch & (label[t] == s)
        contact = W[G[t[np.flatnonzero(mine)[0]]]].mean(0)
        check_self_contact(W, G[label == s], mine, t, u, contact, name, s, n_shells)
    if not actions:
        return V, F, label, n_shells, t, u, code, actions, False
    return W, G, label, n_shells, t, u, code, actions, final


def _cut_alone(W, G, label, s, t, u, point, cross, name, n_shells):
    """Cut shell ``s`` along its own crossings into its winding-number layers (for the
    shells around it to be related afterwards); returns the layers' meshes and the action."""
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
    kinds = ", ".join(f"w >= {k}" if k > 0 else f"w <= {k} (reversed)" for k, _, _ in layers)
    action = (
        f"cut {where} ({len(Vs)} vertices, {len(Fs)} triangles), which crosses itself "
        f"in {int(mine.sum())} triangle pairs (e.g. near {format_point(x)}), along its "
        f"crossings ({n_cut} triangles split) into the boundaries of {kinds}"
    )
    return [(Vk, Fk) for _, Vk, Fk in layers], action


def _cut_group(W, G, label, members, name, n_shells):
    """Cut a group of shells (one of them crossing itself) along all their crossings and keep
    the boundary of the solid: the patches between winding numbers 1 and 0, counting the
    shells around the group. A group whose solid is then empty while it wraps space
    negatively (an inside-out body) gives the boundary of that region, turned outward."""
    inside = np.isin(label, members)
    Vc, Fc = compact(W, G[inside])
    rest = G[~inside]
    around = round(float(winding_number(Vc[0], W, rest))) if len(rest) else 0
    what = ", ".join(str(int(m)) for m in members)
    where = (
        f"shells {what} of {n_shells}"
        if len(members) > 1
        else (f"shell {what} of {n_shells}" if n_shells > 1 else "the surface")
    )
    _, local_label = split_shells(Fc, len(Vc))
    t, u, code, point = crossing_pairs(Vc, Fc, local_label)
    try:
        layers, n_cut = winding_layers(Vc, Fc, t[code == CROSS], u[code == CROSS])
    except UncertainCrossingError as exc:
        raise MeshError(
            f"{name}: {where} ({len(Vc)} vertices, {len(Fc)} triangles) cross in "
            f"{int((code == CROSS).sum())} triangle pairs (e.g. near {format_point(point[0])}), "
            f"and near {format_point(exc.point)} {exc.why}, so the crossing cannot be cut "
            f"with certainty; {SELF_FIX}."
        ) from exc
    Vk, Fk = _solid_layer(layers, around)
    flipped = ""
    if len(Fk) == 0 and around == 0 and any(k == -1 for k, _, _ in layers):
        # Only a negative layer: an inside-out group, read as the region it wraps.
        Vk, Fk = _solid_layer(layers, 1)
        Fk = Fk[:, ::-1].copy()
        flipped = ", turned outward (the group is inside out)"
    crossing = "crosses itself" if len(members) == 1 else "cross themselves and each other"
    action = (
        f"cut {where} ({len(Vc)} vertices, {len(Fc)} triangles), which {crossing} in "
        f"{int((code == CROSS).sum())} triangle pairs (e.g. near {format_point(point[0])}), "
        f"along the crossings ({n_cut} triangles split) into the boundary of the points of "
        f"winding number >= 1{flipped}"
    )
    return Vk, Fk, action


def cut_cluster(parts, around: int, refusal: MeshError) -> tuple[np.ndarray, np.ndarray]:
    """The boundary of the solid inside a group of crossing shells: their surfaces cut along
    every crossing, and the patches between winding numbers 1 and 0, counting the
    ``around`` of the shells that hold the group (`exactgrasp.geometry.arrangement`).
    ``refusal`` is raised where the shells touch with uncertain signs (a coplanar contact
    would need cutting too) or a crossing cannot be cut."""
    V, F = join_meshes(parts)
    _, label = split_shells(F, len(V))
    t, u, code, _ = crossing_pairs(V, F, label)
    if (code == UNSURE).any():
        raise refusal
    try:
        layers, _ = winding_layers(V, F, t, u)
    except UncertainCrossingError:
        raise refusal from None
    return _solid_layer(layers, around)


def _solid_layer(layers, around: int) -> tuple[np.ndarray, np.ndarray]:
    """Of a group's winding-number layers (`winding_layers`), the boundary of the solid when
    the shells around the group add ``around``: the patches between the group's winding
    numbers 1 - around (behind) and -around. `winding_layers` numbers a layer k <= 0 as
    k - 1. Empty arrays when there is none."""
    level = 1 - around
    wanted = level if level >= 1 else level - 1
    for k, Vk, Fk in layers:
        if k == wanted:
            return Vk, Fk
    return np.empty((0, 3)), np.empty((0, 3), np.int64)
