"""What a hand's links are, prepared once per process and per content, whatever the joints.

A row of a dataset is a hand at some joint angles. Its links' meshes do not change with the
joints, only their poses do; so each link becomes a manifold3d solid once, kept in
`LINK_SOLIDS` under the SHA-256 of its mesh arrays (its content: two hands loaded from two
copies of one file share the entries; a changed mesh gets new ones), and is moved to its pose
for each row. The union's volume, which does depend on the joints (the links overlap at their
joints, more or less as they bend), is then summed from the links' volumes and their overlaps
(`exactgrasp.geometry.manifold.union_volume_by_overlaps`) instead of a boolean of the whole
hand.

`LINK_SOLIDS.builds` counts the links prepared in this process: a batch worker reports it,
which is how the tests see that each distinct hand is prepared once per worker.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from exactgrasp.cache import LRUCache, mesh_key
from exactgrasp.geometry.manifold import placed, to_manifold, union_volume_by_overlaps

__all__ = ["LINK_SOLIDS", "LinkSolid", "posed_link_solids", "union_volume_of_links"]

#: Link solids of every hand this process has seen, by content (a Barrett hand has 9 links).
LINK_SOLIDS = LRUCache(256)


class LinkSolid:
    """One link's solid in its own frame, and its volume (m^3), built once per content.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
        The link in its own frame, metres.
    faces : numpy.ndarray, shape (m, 3), int
    name : str
        The link, in messages.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, name: str):
        self.solid = to_manifold(vertices, faces, f"hand link {name}")
        self.volume = float(self.solid.volume())


def _links_and_poses(hand: Any) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    """``(name, V, F, pose (4, 4))`` per link: the model's own meshes and link poses when it
    has them (an articulated model), else the posed meshes themselves at the identity."""
    model = hand.model
    if hasattr(model, "link_local_meshes") and hasattr(model, "link_poses"):
        poses = model.link_poses(hand.joints)
        return [
            (name, V, F, T)
            for (name, V, F), T in zip(model.link_local_meshes(), poses, strict=True)
        ]
    eye = np.eye(4)
    return [
        (name, V, F, eye) for name, (V, F) in zip(hand.link_names, hand.link_arrays(), strict=True)
    ]


def posed_link_solids(hand: Any) -> list[tuple[Any, float]]:
    """Every link of ``hand`` as a manifold3d solid at its pose, with its volume (m^3).

    Parameters
    ----------
    hand : exactgrasp.Hand

    Returns
    -------
    list of (manifold3d.Manifold, float)
        In the hand frame; the solids are the cached ones moved (lazily) to the joints' poses.
    """
    out = []
    for name, V, F, pose in _links_and_poses(hand):
        link = LINK_SOLIDS.get(mesh_key(V, F), lambda V=V, F=F, name=name: LinkSolid(V, F, name))
        out.append((placed(link.solid, pose), link.volume))
    return out


def union_volume_of_links(hand: Any) -> float:
    """Volume of the union of a hand's posed links (m^3), from the prepared link solids.

    Parameters
    ----------
    hand : exactgrasp.Hand

    Returns
    -------
    float
        Equal to the boolean union's volume to rounding (``docs/batch.md``, tested).
    """
    links = posed_link_solids(hand)
    return union_volume_by_overlaps([s for s, _ in links], [v for _, v in links])
