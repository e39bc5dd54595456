"""Where a closed surface's winding number reaches a level, exactly: that set's volume, in
rational arithmetic, and its boundary's triangles with the input face each lies in.

Two closed surfaces whose winding numbers are 0 or 1 (2-manifolds, outward), given as one
surface, have winding number 2 exactly in their intersection, so level 2 of the pair is the
intersection (`exactgrasp.backends.exact.arranged` uses it where floating point cannot decide
a volume). The surface is cut along every contact and each patch's winding numbers are found
exactly (`exactgrasp.geometry.exact_solid.winding_regions`); the volume is the divergence
theorem's sum over the boundary's triangles, on their exact points. Where the caller knows a
box outside which the level is not reached (level 2 lies in the smaller surface's box), only
the faces near that box are cut and asked (`exactgrasp.geometry.exact_window`).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from math import gcd

import numpy as np

from exactgrasp.geometry.exact_solid import winding_regions
from exactgrasp.geometry.exact_window import window_regions
from exactgrasp.geometry.rational import triple

__all__ = ["LevelSet", "level_set"]


@dataclass(frozen=True)
class LevelSet:
    """The points where a closed surface's winding number is at least a level.

    Attributes
    ----------
    volume : fractions.Fraction
        Exact, in the vertices' units cubed.
    triangles : numpy.ndarray, shape (k, 3, 3), float64
        The boundary's triangles, facing out of the set, corners rounded to float64.
    sources : numpy.ndarray, shape (k,), int64
        The input face each triangle lies in.
    """

    volume: Fraction
    triangles: np.ndarray
    sources: np.ndarray


def level_set(
    vertices: np.ndarray, faces: np.ndarray, level: int, window: tuple | None = None
) -> LevelSet:
    """The points where a closed surface's winding number is at least ``level`` (>= 1).

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
        A closed surface: every edge used as often in each direction.
    level : int
    window : tuple, optional
        ``(lo, hi)`` or ``(lo, hi, face_boxes)``: a box (corners (3,)) outside which the
        winding number is below ``level``, known to the caller; then only the faces near it
        are cut and asked (`exact_window.window_regions`, which also says what
        ``face_boxes`` is), and the vertices must be distinct points.

    Returns
    -------
    LevelSet
    """
    if window is None:
        cut, G, sources, patch, levels, _, _ = winding_regions(vertices, faces)
    else:
        cut, G, sources, patch, levels = window_regions(vertices, faces, *window)
    inside = levels >= level
    face_sign = (inside[:, 0].astype(np.int64) - inside[:, 1].astype(np.int64))[patch]
    kept = np.flatnonzero(face_sign)
    P = cut.points
    total, den = 0, 1
    for f in kept.tolist():
        a, b, c = G[f]
        A, B, C = P[a], P[b], P[c]
        # 6 × the tetrahedron (0, A, B, C) of homogeneous integer points: det / (W_A W_B W_C).
        det, w = triple(B, C, A), A[3] * B[3] * C[3]
        det = det if face_sign[f] > 0 else -det
        total, den = total * w + det * den, den * w
        g = gcd(total, den)
        total, den = total // g, den // g
    volume = Fraction(total, 6 * den) * Fraction(2) ** (3 * cut.ints.exponent)
    oriented = np.where(face_sign[kept, None] > 0, G[kept], G[kept][:, ::-1])
    approx = cut.approx.array()
    triangles = approx[oriented] if len(kept) else np.zeros((0, 3, 3))
    return LevelSet(volume, triangles, sources[kept])
