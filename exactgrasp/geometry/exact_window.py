"""A closed surface's winding regions inside a box, exactly, where the caller knows that a
level is not reached outside that box: the cut and its rays touch only what lies near the box.

The level set of two closed surfaces at level 2 (`exactgrasp.geometry.level_sets`) lies in
the smaller one, whatever the size of the other: a hand of 272k triangles holds a bottle of
1.6k, and the faces that can bound their intersection are the bottle's and the hand's within
its box. The whole surface's cut (`exact_solid.winding_regions`) welds, cuts, joins and asks
every face; here only these do:

1. **Near faces**: those whose boxes meet the box, padded by far more than a rounding
   (``PAD`` of the coordinates' size). They are cut along every contact among them
   (`exact_cut.cut_exactly`); a contact with a face that misses the padded box lies outside
   it.
2. **Core faces**: the cut's faces that lie within the padded box (a face of the level set's
   boundary lies within the box itself, so it is one). Every contact of a core face is with
   a near face, so it is cut: core faces joined across edges of exactly two faces
   (`exact_solid.patches`) make patches along which the winding numbers do not change.
3. **Rays** from a core face's centroid that rounds into the box (so lies in the padded box,
   correctly rounded) count every face above it: the near faces' cut, and the other faces
   whose boxes meet the padded box along both axes across the ray and lie above it (the
   faces such a ray can cross). Ties are broken as in `exact_solid.Rays`, by the points
   alone, so a face and the tiles of its neighbour's cut agree along their common edge.
4. A patch none of whose faces' centroids rounds into the box has them all outside the box
   (rounding keeps order), where the caller knows the level is not reached on either side,
   so it is reached nowhere along the patch: its levels are `exact_solid.UNDECIDED`, as are
   those of faces outside the padded box.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.geometry.exact_cut import cut_exactly
from exactgrasp.geometry.exact_solid import UNDECIDED, Rays, cut_faces, face_levels, patches

__all__ = ["PAD", "face_boxes", "window_regions"]

#: The box's padding, relative to the largest coordinate of the box: far above a rounding
#: (2**-52), far below any geometry.
PAD = 2.0**-40


def window_regions(
    vertices: np.ndarray,
    faces: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    face_boxes: tuple[np.ndarray, np.ndarray] | None = None,
):
    """`exact_solid.winding_regions` of the faces near a box, for a level the caller knows
    is reached nowhere outside it.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
        Distinct points (welded: equal coordinates are one vertex).
    faces : numpy.ndarray, shape (m, 3), int64
        A closed surface.
    lo, hi : numpy.ndarray, shape (3,), float64
        The box's corners, in the vertices' units.
    face_boxes : (numpy.ndarray, numpy.ndarray), shape (3, j) each, optional
        The first j faces' bounding boxes (their lowest and highest coordinates along each
        axis), where the caller has them; the others' are made here.

    Returns
    -------
    cut : exact_cut.Arrangement
        The exact points (``vertices`` first).
    G : numpy.ndarray, shape (k, 3), int64
        The near faces' cut, into ``cut.points``.
    sources : numpy.ndarray, shape (k,), int64
        The face of ``faces`` each lies in.
    patch : numpy.ndarray, shape (k,), int64
        Each face's patch.
    levels : numpy.ndarray, shape (n_patch, 2), int64
        Each patch's winding numbers (behind, in front); `exact_solid.UNDECIDED` outside
        the box.
    """
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64)
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    boxes = _boxes(V, F, face_boxes)
    pad = PAD * float(np.abs(np.concatenate([lo, hi])).max()) + np.finfo(float).tiny
    near, across = _near_and_across(boxes, lo - pad, hi + pad)
    cut, tiles, tiled, _ = cut_exactly(V, F[near])
    G, counts, sources, _ = cut_faces(F[near], tiles, tiled)
    low, high = _boxes(cut.approx.array(), G, None)
    core = np.all((low >= (lo - pad / 4)[:, None]) & (high <= (hi + pad / 4)[:, None]), axis=0)
    n_patch, patch = patches(G, len(cut.points), core)
    rays = Rays(
        cut,
        np.concatenate([G, F[across]]),
        np.concatenate([counts, np.ones(len(across), np.int64)]),
        (boxes[0][:, across].T, boxes[1][:, across].T),
    )
    return cut, G, near[sources], patch, _levels(rays, patch, n_patch, core, lo, hi)


def face_boxes(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The faces' bounding boxes, as `window_regions` takes them: their lowest and highest
    coordinates along each axis, (3, m) each (a row per axis, contiguous).

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3), float64
    F : numpy.ndarray, shape (m, 3), int64
    """
    a, b, c = (np.ascontiguousarray(V[F[:, k]].T) for k in range(3))
    return np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)


def _boxes(V: np.ndarray, F: np.ndarray, known) -> tuple[np.ndarray, np.ndarray]:
    """Every face's box (`face_boxes`): the first ones ``known`` (or none), the others made
    from their corners."""
    j = 0 if known is None else known[0].shape[1]
    low, high = face_boxes(V, F[j:])
    if not j:
        return low, high
    return np.concatenate([known[0], low], axis=1), np.concatenate([known[1], high], axis=1)


def _near_and_across(boxes, lo: np.ndarray, hi: np.ndarray):
    """The faces whose boxes meet the padded box ``[lo, hi]``, and those a ray from it along
    +k may cross beyond them: across it along the two other axes, above it along k."""
    low, high = boxes
    under = [low[k] <= hi[k] for k in range(3)]
    meets = [under[k] & (high[k] >= lo[k]) for k in range(3)]
    near = meets[0] & meets[1] & meets[2]
    across = (
        (meets[1] & meets[2] & ~under[0])
        | (meets[2] & meets[0] & ~under[1])
        | (meets[0] & meets[1] & ~under[2])
    )
    return np.flatnonzero(near), np.flatnonzero(across)


def _levels(rays: Rays, patch, n_patch: int, core: np.ndarray, lo, hi) -> np.ndarray:
    """(n_patch, 2): each patch's winding numbers from a ray at the centroid of one of its
    core faces that rounds into the box ``[lo, hi]``; `exact_solid.UNDECIDED` where none
    does (or only faces of zero area do)."""
    levels = np.full((n_patch, 2), UNDECIDED, np.int64)
    asked = np.flatnonzero(core)
    # The patches' faces in turn, each patch's first: most patches need only that one.
    asked = asked[np.argsort(patch[asked], kind="stable")]
    start = np.flatnonzero(np.r_[True, np.diff(patch[asked]) != 0])
    for first, stop in zip(start.tolist(), np.r_[start[1:], len(asked)].tolist(), strict=True):
        for f in asked[first:stop].tolist():
            if not _rounds_into(rays.centre(f)[1], lo, hi):
                continue
            found = face_levels(rays, f)
            if found is not None:
                levels[patch[f]] = found
                break
    return levels


def _rounds_into(x: list[float], lo: np.ndarray, hi: np.ndarray) -> bool:
    """Whether a point's correctly rounded coordinates lie in the closed box: then the point
    lies within half a unit in the last place of it; else outside it (rounding keeps
    order)."""
    return all(lo[k] <= x[k] <= hi[k] for k in range(3))
