"""`Intersection`, what the exact intersector returns for a stack of poses: volumes, their
error bounds, where each came from, and the call's counters."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from exactgrasp.backends.exact.tables import ARRANGED, CULLED, DEGENERATE, OK, OVERFLOW

__all__ = ["POSE_SOURCES", "Intersection"]

#: What `Intersection.pose_sources` says, indexed by the kernel's result code.
POSE_SOURCES = np.empty(ARRANGED + 1, dtype="<U11")
POSE_SOURCES[[OK, CULLED, DEGENERATE, OVERFLOW, ARRANGED]] = (
    "kernel", "culled", "limit", "limit", "arrangement"
)  # fmt: skip


@dataclass(frozen=True)
class Intersection:
    """What `ExactIntersector.intersect` found for a stack of poses (see there).

    Attributes
    ----------
    volumes : numpy.ndarray, shape poses.shape[:-2], float64
        Intersection volumes (cubed canonical units).
    volume_bounds : numpy.ndarray, same shape
        ``|volume - true volume| <= bound``.
    pose_sources : numpy.ndarray, same shape, str
        ``"kernel"``, ``"culled"``, ``"limit"`` or ``"arrangement"``.
    stats : dict
        Counters of the call (poses, repeats, culled, limit, cells, pairs, threads, seconds).
    """

    volumes: np.ndarray
    volume_bounds: np.ndarray
    pose_sources: np.ndarray
    stats: dict[str, Any]
