"""Default values of the backends and of the code that picks them: the one place they are set.

The backends, `exactgrasp.descriptor`, `exactgrasp.compare`, `exactgrasp.overlap`, the batch
runner and the command line read their defaults from here.
"""

from __future__ import annotations

#: Backend used when none is named (the paper's estimator).
DEFAULT_BACKEND = "voxel"
#: Backends compared when none are named; the last is the reference.
COMPARED_BACKENDS = ("voxel", "exact")

#: Voxels along the longest side of the hand's bounding box (the paper's value).
VOXEL_HAND_RESOLUTION = 100
#: Voxels along the longest side of the object's bounding box (the paper's value).
VOXEL_OBJECT_RESOLUTION = 50
#: How many cubic voxels a grid's shorter side gets: "floor" (the authors' code, the default)
#: or "round".
VOXEL_GRID_RULES = ("floor", "round")
#: Hand grids and object point sets a `VoxelBackend` keeps, each (least recently used first out).
VOXEL_CACHE_SIZE = 8

#: Library of the exact backend's broad phase (``"coal"``, ``"fcl"`` or None).
EXACT_BROADPHASE = "coal"
#: Threads over poses of the exact backend: None is every core (``os.cpu_count()``), or what a
#: batch worker sets (`exactgrasp.backends.base.thread_limit`).
EXACT_N_JOBS = None
#: The exact backend builds its broad phase's BVHs (once) only for a call with at least (the
#: triangles of both meshes) / this many poses the kernel's own test leaves open (not known to
#: cross): culling one spares at most the kernel's time on it, about what building a BVH over
#: this many triangles takes (see docs/performance.md).
EXACT_CULL_TRIANGLES_PER_POSE = 256
#: Edge crossings recorded per pose before the exact kernel falls back to a boolean.
EXACT_CAPACITY = 400_000
#: Grid cells of the exact backend along a mesh's largest extent (measured best on the Barrett
#: hand, see docs/performance.md).
EXACT_CELLS_PER_EXTENT = 48
#: Exact intersectors (one per grasp geometry) an `ExactBackend` keeps.
EXACT_CACHE_SIZE = 4

#: `exactgrasp.overlap.intersection_volume`'s broad phase. It differs from
#: `EXACT_BROADPHASE` because nothing keeps its intersector for a later call: ``"auto"`` builds
#: coal's BVH only for stacks of more than `OVERLAP_AUTO_BVH_POSES` poses, where it pays.
OVERLAP_BROADPHASE = "auto"
#: ``"auto"`` builds coal's BVH for stacks of more poses than this: building it costs about
#: what the kernel spends on a few hundred poses, and it only saves the kernel's time on poses
#: whose surfaces are apart (see docs/penetration-volume.md).
OVERLAP_AUTO_BVH_POSES = 256
#: `exactgrasp.overlap.intersection_volume`'s threads over poses: one, since a call on two
#: meshes is often a single pose and threads would only add their start-up.
OVERLAP_N_JOBS = 1

#: Backend instances `exactgrasp.backends.registry.shared_backend` keeps.
SHARED_CACHE_SIZE = 16
