"""The paper's voxel-count estimator: backend, hand grids, object points and the kernel."""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.backends.voxel.backend import VoxelBackend
    from exactgrasp.backends.voxel.grids import HandOccupancy, hand_occupancy
    from exactgrasp.backends.voxel.kernel import (
        estimate_counts,
        estimate_counts_numpy,
        estimate_volumes,
        estimate_volumes_numpy,
    )
    from exactgrasp.backends.voxel.points import ObjectPoints, object_points

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.backends.voxel.backend": ("VoxelBackend",),
        "exactgrasp.backends.voxel.grids": ("HandOccupancy", "hand_occupancy"),
        "exactgrasp.backends.voxel.kernel": (
            "estimate_counts",
            "estimate_counts_numpy",
            "estimate_volumes",
            "estimate_volumes_numpy",
        ),
        "exactgrasp.backends.voxel.points": ("ObjectPoints", "object_points"),
    },
)

__all__ = [
    "HandOccupancy",
    "ObjectPoints",
    "VoxelBackend",
    "estimate_counts",
    "estimate_counts_numpy",
    "estimate_volumes",
    "estimate_volumes_numpy",
    "hand_occupancy",
    "object_points",
]
