"""Default values of the backends and of the code that picks them: the one place they are set.

The backends' constructors read them from here; everything else that runs a backend takes
``backend=`` (a registered name, meaning these defaults, or a configured instance), so no
other module writes a backend's default again.
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
#: The grid rule used when none is named.
VOXEL_GRID_RULE = VOXEL_GRID_RULES[0]
#: Weight of a surface sample: "paper" (w_s = V_o/2 * 1/16, the default) or "area".
VOXEL_SURFACE_WEIGHT = "paper"
#: Seed of the voxel backend's surface sampler.
VOXEL_SEED = 0
#: Hand grids and object point sets a `VoxelBackend` keeps, each (least recently used first out).
VOXEL_CACHE_SIZE = 8

#: Library of the exact backend's broad phase (``"coal"``, ``"fcl"`` or None).
EXACT_BROADPHASE = "coal"
#: Threads over poses of the exact backend: None is every core (``os.cpu_count()``), or what a
#: batch worker sets (`exactgrasp.backends.base.thread_limit`).
EXACT_N_JOBS = None
#: The exact backend builds its broad phase's BVHs (once) only for a call with at least (the
#: triangles of both meshes) / this many poses that neither its bounds nor the kernel's own
#: test decide: culling one spares the kernel's time on it less the culling's own, and on the
#: study records' Barrett hand 11-96 triangles' worth of building for each such pose (a
#: build repaid after 907-7,341 of them; `benchmarks/exact_culling.py`, docs/performance.md).
EXACT_CULL_TRIANGLES_PER_POSE = 32
#: Edge crossings recorded per pose before the exact kernel falls back to a boolean.
EXACT_CAPACITY = 400_000
#: Grid cells of the exact backend along a mesh's largest extent (measured best on the Barrett
#: hand, see docs/performance.md).
EXACT_CELLS_PER_EXTENT = 48
#: Exact intersectors (one per grasp geometry) an `ExactBackend` keeps.
EXACT_CACHE_SIZE = 4

#: Backend instances `exactgrasp.backends.registry.shared_backend` keeps.
SHARED_CACHE_SIZE = 16
