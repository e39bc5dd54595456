"""The paper's voxel-count estimator: backend, hand grids, object points and the kernel."""

from exactgrasp.backends.voxel.backend import (
    HandOccupancy,
    ObjectPoints,
    VoxelBackend,
    estimate_counts,
    estimate_counts_numpy,
    estimate_volumes,
    estimate_volumes_numpy,
    hand_occupancy,
    object_points,
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
