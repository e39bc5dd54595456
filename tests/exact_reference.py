"""The references that prove "exact": libigl's CGAL arrangement (exact arithmetic, GPL: a test
dependency of the dev extra that exactgrasp never imports), exact rational volumes of meshes
with dyadic coordinates, and Monte Carlo on winding numbers as a coarse independent check.

Every reference reads a mesh as exactgrasp does: the solid of winding number >= 1.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

_EMPTY_V = np.zeros((0, 3))
_EMPTY_F = np.zeros((0, 3), dtype=np.int64)


def _cgal():
    return pytest.importorskip("igl.copyleft.cgal", reason="libigl (the dev extra) not installed")


def mesh_volume(V: np.ndarray, F: np.ndarray) -> float:
    """Signed volume by the divergence theorem (m^3 for metres), in float64, about the
    vertices' centre (about the origin, a mesh far from it would lose its digits)."""
    V = np.asarray(V, float)
    V = V - V.mean(0)
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def cgal_solid(V, F) -> tuple[np.ndarray, np.ndarray]:
    """The boundary of the points of winding number >= 1, by CGAL's exact arrangement
    (vertices rounded to float64 on output)."""
    V = np.ascontiguousarray(V, float)
    F = np.ascontiguousarray(F, np.int64)
    VC, FC, _ = _cgal().mesh_boolean(V, F, _EMPTY_V, _EMPTY_F, "union")
    return VC, FC


def cgal_volume(V, F) -> float:
    """Volume of the solid of winding number >= 1, by CGAL's exact arrangement."""
    return mesh_volume(*cgal_solid(V, F))


def _cgal_intersection_mesh(a, b) -> tuple[np.ndarray, np.ndarray]:
    VA, FA = (np.ascontiguousarray(x) for x in (np.asarray(a[0], float), np.asarray(a[1])))
    VB, FB = (np.ascontiguousarray(x) for x in (np.asarray(b[0], float), np.asarray(b[1])))
    VC, FC, _ = _cgal().mesh_boolean(
        VA, FA.astype(np.int64), VB, FB.astype(np.int64), "intersection"
    )
    return VC, FC


def exact_shift(*vertex_arrays) -> np.ndarray:
    """(3,): a translation, integers near the meshes' common centre, by which every coordinate
    moves without rounding (checked in exact arithmetic); 0 on an axis where none does."""
    V = np.concatenate([np.asarray(v, float) for v in vertex_arrays])
    shift = np.zeros(3)
    for k in range(3):
        s = float(np.round((V[:, k].min() + V[:, k].max()) / 2))
        x = np.unique(V[:, k])
        if all(Fraction(c) - Fraction(s) == Fraction(c - s) for c in x.tolist()):
            shift[k] = s
    return shift


def cgal_intersection_volume(a, b) -> float:
    """Volume of solid(a) ∩ solid(b) for two (vertices, faces) pairs, by CGAL's exact
    arrangement: the cells of winding number >= 1 with respect to both."""
    VC, FC = _cgal_intersection_mesh(a, b)
    return mesh_volume(VC, FC) if len(FC) else 0.0


def cgal_intersection(a, b) -> tuple[float, float]:
    """`cgal_intersection_volume` with what libigl's rounding leaves uncertain: (volume,
    bound). CGAL computes the intersection exactly, but libigl returns its vertices rounded
    to float64 (each coordinate by at most half a unit in its last place, ``δ``), which moves
    each face by at most ``√3 δ`` and the volume by at most ``√3 δ`` times the surface's area
    (first order; the terms in ``δ²`` are below 1e-13 of it). The volume of the rounded mesh
    is summed exactly, so that is the whole bound. Both meshes are first moved by
    `exact_shift` (which changes no volume), so that ``δ`` is that of the scene's size, not
    of its distance from the origin."""
    shift = exact_shift(a[0], b[0])
    VC, FC = _cgal_intersection_mesh((a[0] - shift, a[1]), (b[0] - shift, b[1]))
    if not len(FC):
        return 0.0, 0.0
    delta = float(np.spacing(np.abs(VC).max())) / 2
    p, q, r = VC[FC[:, 0]], VC[FC[:, 1]], VC[FC[:, 2]]
    area = float(np.linalg.norm(np.cross(q - p, r - p), axis=1).sum()) / 2
    return float(rational_volume(VC, FC)), 3**0.5 * delta * area * (1 + 1e-6)


def rational_volume(V, F) -> Fraction:
    """Signed volume in exact rational arithmetic (every float is a dyadic rational): the
    solid's volume wherever the winding number is 0 or 1."""
    P = [[Fraction(float(c)) for c in row] for row in np.asarray(V, float)]
    total = Fraction(0)
    for i, j, k in np.asarray(F):
        a, b, c = P[i], P[j], P[k]
        total += (
            a[0] * (b[1] * c[2] - b[2] * c[1])
            - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
        )
    return total / 6


def monte_carlo_intersection(a, b, n: int = 200_000, seed: int = 0, batches: int = 4):
    """Volume of solid(a) ∩ solid(b) from uniform points in the two meshes' common bounding
    box, inside where libigl's generalized winding number exceeds 0.5 for both: (estimate,
    standard error from ``batches`` independent batches)."""
    import igl

    lo = np.maximum(np.min(a[0], 0), np.min(b[0], 0))
    hi = np.minimum(np.max(a[0], 0), np.max(b[0], 0))
    if np.any(hi <= lo):
        return 0.0, 0.0
    rng = np.random.default_rng(seed)
    box = float(np.prod(hi - lo))
    estimates = []
    for _ in range(batches):
        q = lo + rng.random((n // batches, 3)) * (hi - lo)
        inside = np.ones(len(q), bool)
        for V, F in (a, b):
            w = igl.winding_number(np.asarray(V, float), np.asarray(F, np.int64), q)
            inside &= w > 0.5
        estimates.append(box * inside.mean())
    est = np.array(estimates)
    return float(est.mean()), float(est.std(ddof=1) / np.sqrt(batches))
