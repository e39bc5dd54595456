"""`Intersection`, what the exact intersector returns for a stack of poses: volumes, their
error bounds, where each came from, and the call's counters."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from exactgrasp.backends.exact.tables import (
    ARRANGED,
    CULLED,
    DEGENERATE,
    OK,
    OVERFLOW,
    STAT_CELLS_INSIDE,
    STAT_CELLS_OUTSIDE,
    STAT_CELLS_TOUCHED,
)

__all__ = ["POSE_SOURCES", "Intersection", "call_stats"]

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


def call_stats(
    poses: int,
    run: int,
    codes: np.ndarray,
    stats: np.ndarray,
    pairs: np.ndarray,
    hand,
    jobs: int,
    t0: float,
) -> dict[str, Any]:
    """`Intersection.stats` of a call (see `ExactIntersector.intersect`): ``poses`` in all,
    ``run`` of them computed (the others repeats), their ``codes`` (poses,) and kernel
    statistics (poses, N_STATS), the face pairs tested and crossing (2,) summed over the poses
    run, the hand's `tables.HandTables`, the threads run and the call's start
    (`time.perf_counter`)."""
    tot = stats.sum(0)
    return {
        "poses": poses,
        "poses_repeated": poses - run,
        "poses_culled": int((codes == CULLED).sum()),
        "poses_limit": int(((codes == DEGENERATE) | (codes == OVERFLOW)).sum()),
        "poses_arranged": int((codes == ARRANGED).sum()),
        "parts": len(hand.parts) - 1,
        "threads": jobs,
        "parts_culled": int(tot[STAT_CELLS_OUTSIDE]),
        "parts_inside": int(tot[STAT_CELLS_INSIDE]),
        "parts_clipped": int(tot[STAT_CELLS_TOUCHED]),
        "pairs_tested": int(pairs[0]),
        "pairs_crossing": int(pairs[1]),
        "seconds": time.perf_counter() - t0,
    }
