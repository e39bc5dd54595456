"""The exact fallback for a pose the kernel cannot certify: the volume's limit along a small
translation, from certified kernel volumes at nearby poses.

A pose the kernel's signs cannot decide holds an exact coincidence of the two surfaces (a
vertex on a face, coplanar faces, an edge through an edge). Moving the object by ``t u``
along a fixed direction ``u`` undoes it for every small ``t > 0``, and there the volume of
``A ∩ (B + t u)`` is a cubic polynomial in ``t`` (every vertex of the intersection moves
linearly with ``t``, so every tetrahedron of it has a cubic volume) until another contact
begins. The volume is continuous in ``t``, so the volume at the pose is that cubic's value at
0, which four samples give exactly: ``V(0) = 4 V(h) - 6 V(2h) + 4 V(3h) - V(4h)``. A fifth
sample checks that the four lie on one cubic (no other contact began between them); the
moments of the hand's surface inside the object (polynomials of lower degree) come the same
way. The samples are certified kernel volumes, so each limit's bound is theirs, weighted.
Both sides of the pose are sampled: a contact that begins within a few steps on one side (a
sliver thinner than the step) bends that side's samples: the two limits then differ, and a
smaller step is tried; failing that, the result is the middle of the two limits with half
their difference added to the bound. Samples that are all exactly 0 on both sides may have
stepped off a contact thinner than the step: its volume, at most twice the step times the
surfaces' area, is added to the bound.

A full crossing buffer (the kernel's capacity too small for the pose) is run again with a
larger buffer instead. A pose where neither works is refused (`UncertainPoseError`): a wrong
number is never returned.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from exactgrasp.backends.exact.tables import CULLED, OK, OVERFLOW
from exactgrasp.errors import UncertainPoseError

__all__ = ["STEPS", "extrapolated"]

#: The translation steps ``h`` tried, relative to the scene's size (local coordinates): far
#: below any feature of a real mesh, far above the kernel's certified error; the smaller one
#: where the larger steps over a contact thinner than itself.
STEPS = (1e-8, 1e-11)
#: Directions tried in turn (fixed, so that results are reproducible bit for bit).
DIRECTIONS = np.array(
    [
        [0.5773502691896258, 0.6236095644623235, 0.5270462766947299],
        [-0.2672612419124244, 0.5345224838248488, -0.8017837257372732],
        [0.8451542547285166, -0.1690308509457033, -0.5070925528371099],
    ]
)
#: ``V(0)`` from ``V(h), ..., V(4h)`` on a cubic.
WEIGHTS = np.array([4.0, -6.0, 4.0, -1.0])
#: Larger crossing buffers tried for a pose that filled the kernel's.
GROWTH = (4, 16, 64)
#: Rounding of the weighted sums, per unit of the summed magnitudes.
SUM_ROUNDING = 8 * np.finfo(float).eps

Kernel = Callable[[np.ndarray, int], tuple]


def extrapolated(
    kernel: Kernel,
    pose: np.ndarray,
    code: int,
    size: float,
    area: float,
    capacity: int,
    links: int,
) -> tuple[float, float, np.ndarray]:
    """The volume at a pose the kernel could not certify, its bound and its link moments.

    Parameters
    ----------
    kernel : callable
        ``kernel(poses (k, 4, 4), capacity)`` returns the kernel's volumes, bounds, codes (k,)
        and link moments (k, links, 6) for those poses (local coordinates).
    pose : numpy.ndarray, shape (4, 4)
        The pose, in local coordinates.
    code : int
        What the kernel said of it (`DEGENERATE` or `OVERFLOW`).
    size : float
        The scene's size in local coordinates (the translation steps are `STEPS` of it).
    area : float
        Both surfaces' areas, summed (what a contact thinner than a step can hold).
    capacity : int
        The kernel's crossing buffer.
    links : int
        Hand links whose moments are wanted (0 for volumes alone).

    Returns
    -------
    volume, bound : float
        ``|volume - true volume| <= bound``; a volume within its bound of 0 is 0.
    moments : numpy.ndarray, shape (links, 6)

    Raises
    ------
    UncertainPoseError
        Where no direction gives certified samples on either side.
    """
    if code == OVERFLOW:
        for growth in GROWTH:
            v, b, c, m = kernel(pose[None], capacity * growth)
            if c[0] in (OK, CULLED):
                return float(v[0]), float(b[0]), m[0]
    best = None
    for u in DIRECTIONS:
        for step in STEPS:
            h = step * size
            sides = [_limit(kernel, pose, side * h * u, capacity) for side in (1, -1)]
            sides = [s for s in sides if s is not None]
            if not sides:
                continue
            found = _combined(sides, h * area, links)
            if best is None or found[1] < best[1]:
                best = found
            if len(sides) == 2 and found[3]:
                break
        if best is not None and best[3]:
            break
    if best is None:
        raise UncertainPoseError(pose)
    volume, bound, moments, _ = best
    if volume <= bound:
        return 0.0, bound, np.zeros_like(moments)
    return volume, bound, moments


def _combined(sides: list, sliver: float, links: int):
    """One result from the limits of one or both sides: (volume, bound, moments, whether
    both sides agree to their bounds). Two limits that differ bound the truth between them
    (a contact that began within a few steps bent one side); samples that are all exactly
    0 may have stepped off a contact thinner than the step, of volume at most ``2 sliver``."""
    volumes = np.array([s[0] for s in sides])
    bounds = np.array([s[1] for s in sides])
    volume = 0.5 * (volumes.max() + volumes.min())
    bound = 0.5 * (volumes.max() - volumes.min()) + bounds.max()
    if all(s[3] for s in sides):
        bound = max(bound, 2.0 * sliver)
    agree = len(sides) == 2 and abs(volumes[0] - volumes[1]) <= bounds.sum()
    moments = np.mean([s[2] for s in sides], axis=0) if links else sides[0][2]
    return volume, bound, moments, agree


def _limit(kernel: Kernel, pose: np.ndarray, step: np.ndarray, capacity: int):
    """The limit of the volume at ``pose`` from certified samples at ``pose`` translated by 1
    to 5 ``step``: (volume, bound, link moments, whether every sample was exactly 0); None
    where a sample is not certified or the fifth is off the cubic through the other four."""
    shifted = np.repeat(pose[None], 5, axis=0)
    shifted[:, :3, 3] += np.outer(np.arange(1, 6), step)
    v, b, c, m = kernel(shifted, capacity)
    if not np.isin(c, (OK, CULLED)).all():
        return None
    back = [3, 2, 1, 0]
    predicted = WEIGHTS @ v[back]
    allowed = np.abs(WEIGHTS) @ b[back] + b[4]
    allowed += SUM_ROUNDING * (np.abs(WEIGHTS) @ np.abs(v[back]) + abs(v[4]))
    if abs(predicted - v[4]) > allowed:
        return None
    volume = float(WEIGHTS @ v[:4])
    bound = float(np.abs(WEIGHTS) @ b[:4] + SUM_ROUNDING * (np.abs(WEIGHTS) @ np.abs(v[:4])))
    return volume, bound, np.tensordot(WEIGHTS, m[:4], axes=1), not v.any()
