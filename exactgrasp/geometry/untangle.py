"""A closed surface made ready for `exactgrasp.geometry.shells`: untangled and cut.

`untangle` drops repeated faces, untangles edges of more than two faces
(`exactgrasp.geometry.topology`) and cuts each group of shells in which a shell crosses or
touches itself (with every shell it meets) into the boundary of its solid; `cut_cluster` does
the same for a group of shells that cross one another where a union cannot express their
solid. Crossings come from `exactgrasp.geometry.crossings`, with copies of one point counted
as one vertex. A group whose crossings are all certain in floating point is cut by
`exactgrasp.geometry.arrangement`; one with contacts that floating-point signs cannot decide
(a crossing exactly through an edge or a corner, triangles in one plane, a fold onto a
neighbour), or whose floating-point cut fails, is cut in exact arithmetic by
`exactgrasp.geometry.exact_solid`.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from exactgrasp.errors import Fix, MeshError, UncertainCrossingError
from exactgrasp.geometry.arrangement import winding_layers
from exactgrasp.geometry.crossings import CROSS, UNSURE, find_crossings
from exactgrasp.geometry.exact_solid import solid_boundary
from exactgrasp.geometry.topology import (
    bounding_faces,
    compact,
    format_point,
    join_meshes,
    split_nonmanifold,
    split_shells,
)
from exactgrasp.geometry.winding import winding_number

__all__ = ["crossing_pairs", "cut_cluster", "format_point", "untangle"]


def crossing_pairs(V: np.ndarray, F: np.ndarray, label: np.ndarray):
    """`find_crossings` with self-contacts, copies of one point counted as one vertex."""
    _, identity = np.unique(V, axis=0, return_inverse=True)
    return find_crossings(V, F, label, identity=identity.reshape(-1), self_contacts=True)


def _untangle_edges(V, F, name, actions):
    """Repeated faces dropped and edges of more than two faces untangled (what was done is
    appended to ``actions``); an open or misoriented surface refused. Also returns how many
    coincident copies of faces closed shells share (kept for the exact cut)."""
    G, repeated, cancelled, defects = bounding_faces(V, F)
    if not len(G):
        raise MeshError(
            f"{name}: its {len(F)} faces cancel in pairs (each on the same corners as its "
            "reverse), so it bounds no solid; remove the reversed copies, or reverse the "
            "inside-out shells."
        )
    copies = 0 if G is F else len(G) - len(np.unique(np.sort(G, axis=1), axis=0))
    if repeated or cancelled:
        actions.append(
            f"dropped {repeated} repeated and {cancelled} mutually cancelling (reversed) faces"
        )
    if not defects.is_cycle:
        raise MeshError(
            f"{name}: not a closed surface ({defects.describe()}), so it bounds no solid; ",
            Fix("repair", True, "pass"),
            " to close it first.",
        )
    W = V
    if defects.nonmanifold and not copies:
        W, G, n_edges, n_split = split_nonmanifold(V, G)
        actions.append(
            f"separated the faces of {n_edges} edges shared by more than two faces (e.g. at "
            f"{format_point(defects.nonmanifold_at)}) into pairs bounding one wedge each, "
            f"splitting {n_split} vertices"
        )
    return W, G, copies


def untangle(V: np.ndarray, F: np.ndarray, name: str):
    """Repeated faces dropped, non-manifold edges untangled, shells that cross or touch
    themselves cut with the shells they meet; with the shells and their crossings, what was
    done, and whether the result is final (every shell was cut with its group: the mesh is the
    solid's boundary as it is)."""
    actions: list[str] = []
    W, G, copies = _untangle_edges(V, F, name, actions)
    if copies:
        # Shells sharing faces: the whole surface is cut exactly, coincident faces counted.
        Vk, Fk, report = solid_boundary(W, G, 0, inside_out=True, name=name)
        if not len(Fk):
            raise MeshError(
                f"{name}: its surface bounds no solid (its winding number is below 1 "
                "everywhere); check the orientation of its shells."
            )
        actions.append(
            f"cut the surface ({len(W)} vertices, {len(G)} triangles), whose shells share "
            f"{copies} coincident faces, along every contact in exact arithmetic "
            f"({report['cut']} triangles split) into the boundary of the points of winding "
            "number >= 1"
            + (", turned outward (the surface is inside out)" if report["turned"] else "")
        )
        n_shells, label = split_shells(Fk, len(Vk))
        t, u, code, _ = crossing_pairs(Vk, Fk, label)
        return Vk, Fk, label, n_shells, t, u, code, actions, True
    n_shells, label = split_shells(G, len(W))
    t, u, code, point = crossing_pairs(W, G, label)
    same = label[t] == label[u]
    final = False
    if same.any():
        # A shell that crosses or may touch itself is cut with every shell it meets.
        links = coo_matrix((np.ones(len(t)), (label[t], label[u])), (n_shells, n_shells))
        _, group = connected_components(links, directed=False)
        replaced = np.zeros(n_shells, bool)
        pieces: list[tuple[np.ndarray, np.ndarray]] = []
        for g in np.unique(group[label[t[same]]]):
            members = np.flatnonzero(group == g)
            cut = _cut_group(W, G, label, members, (t, u, code, point), name, n_shells)
            if cut is None:
                continue  # it only touches itself: its shells bound their solid as they are
            replaced[members] = True
            pieces.append(cut[:2])
            actions.append(cut[2])
        if replaced.any():
            # Cut groups are the solid's boundary already: with nothing else left, the
            # shells need relating no more.
            final = bool(replaced.all())
            W, G = compact(*join_meshes([(W, G[~replaced[label]]), *pieces]))
            n_shells, label = split_shells(G, len(W))
            t, u, code, point = crossing_pairs(W, G, label)
    if not actions:
        return V, F, label, n_shells, t, u, code, actions, False
    return W, G, label, n_shells, t, u, code, actions, final


def _cut_group(W, G, label, members, pairs, name, n_shells):
    """Cut a group of shells (one of them crossing or touching itself) along all their
    contacts and keep the boundary of the solid: the patches between winding numbers 1 and 0,
    counting the shells around the group. A group whose solid is then empty while it wraps
    space negatively (an inside-out body) gives the boundary of that region, turned outward.
    Returns (vertices, faces, action), or None when the group bounds its solid as it is."""
    t, _, code, point = pairs
    inside = np.isin(label, members)
    Vc, Fc = compact(W, G[inside])
    rest = G[~inside]
    around = round(float(winding_number(Vc[0], W, rest))) if len(rest) else 0
    mine = np.isin(label[t], members)
    n_cross = int((code[mine] == CROSS).sum())
    n_touch = int((code[mine] == UNSURE).sum())
    listed = ", ".join(str(int(m)) for m in members)
    where = (
        f"shells {listed} of {n_shells}"
        if len(members) > 1
        else (f"shell {listed} of {n_shells}" if n_shells > 1 else "the surface")
    )
    exact = False
    cut = None if n_touch else _float_cut(Vc, Fc, around)
    if cut is None:
        Vk, Fk, report = solid_boundary(Vc, Fc, around, inside_out=True, name=name)
        if not report["changed"]:
            return None
        n_cut, flipped = report["cut"], report["turned"]
        exact = True
    else:
        Vk, Fk, n_cut, flipped = cut
    first = np.flatnonzero(mine)[0]
    near = point[first] if code[first] == CROSS else W[G[t[first]]].mean(0)
    what = _contacts(len(members) == 1, n_cross, n_touch)
    along = "along every contact in exact arithmetic" if exact else "along the crossings"
    action = (
        f"cut {where} ({len(Vc)} vertices, {len(Fc)} triangles), which {what} (e.g. near "
        f"{format_point(near)}), {along} ({n_cut} triangles split) into the boundary of the "
        "points of winding number >= 1"
        + (", turned outward (the group is inside out)" if flipped else "")
    )
    return Vk, Fk, action


def _contacts(one: bool, n_cross: int, n_touch: int) -> str:
    """How a shell (``one``) or a group meets itself, in words."""
    what = []
    if n_cross:
        crossing = "crosses itself" if one else "cross themselves and each other"
        what.append(f"{crossing} in {n_cross} triangle pairs")
    if n_touch:
        touching = "touches itself" if one else "touch themselves and each other"
        count = f"{n_touch} more" if n_cross else f"{n_touch} triangle pairs"
        what.append(f"{touching} exactly at edges, corners or in a plane in {count}")
    return " and ".join(what)


def _float_cut(Vc, Fc, around: int):
    """The floating-point cut of a group whose crossings are all certain: (vertices, faces,
    triangles split, turned inside out), or None where it cannot decide."""
    _, local_label = split_shells(Fc, len(Vc))
    t, u, code, _ = crossing_pairs(Vc, Fc, local_label)
    if (code == UNSURE).any():
        return None
    try:
        layers, n_cut = winding_layers(Vc, Fc, t, u)
    except UncertainCrossingError:
        return None
    Vk, Fk = _solid_layer(layers, around)
    flipped = False
    if len(Fk) == 0 and around == 0 and any(k == -1 for k, _, _ in layers):
        # Only a negative layer: an inside-out group, read as the region it wraps.
        Vk, Fk = _solid_layer(layers, 1)
        Fk = Fk[:, ::-1].copy()
        flipped = True
    return Vk, Fk, n_cut, flipped


def cut_cluster(
    parts, around: int, uncertain: bool = False, name: str = "mesh"
) -> tuple[np.ndarray, np.ndarray, bool]:
    """The boundary of the solid inside a group of shells that cross or touch one another:
    their surfaces cut along every contact, and the patches between winding numbers 1 and 0,
    counting the ``around`` of the shells that hold the group. Cut in floating point where
    every crossing is certain, else (or with ``uncertain``: contacts are known that
    floating-point signs cannot decide) in exact arithmetic; also returns whether the exact
    cut was used."""
    V, F = join_meshes(parts)
    if not uncertain:
        _, label = split_shells(F, len(V))
        t, u, code, _ = crossing_pairs(V, F, label)
        uncertain = bool((code == UNSURE).any())
    if not uncertain:
        try:
            layers, _ = winding_layers(V, F, t, u)
            return (*_solid_layer(layers, around), False)
        except UncertainCrossingError:
            pass
    W, G, _ = solid_boundary(V, F, around, name=name)
    return W, G, True


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
