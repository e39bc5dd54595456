"""`VoxelBackend`: the paper's voxel-count estimator of intersection volume (section III-B).

The hand becomes an inside/outside grid (`grids`); the object becomes points (`points`): the
centres of its interior voxels, each standing for a cube of volume ``V_o``, and samples on its
surface, each standing for ``w_s``. For every pose the points inside the hand are counted
(`kernel`), on every core (or as many threads as `backends.base.thread_limit` allows, one in
a batch worker). Each instance keeps its grids, points and hand volumes, keyed by the
geometry's content; `exactgrasp.backends.registry.shared_backend` shares one instance per
parameters in a process. Its own room loads inside the methods: the class and its
parameters load without the kernels and what they import, for ``--help``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from exactgrasp.backends import defaults
from exactgrasp.backends.base import PROGRESS_PIECES, Backend, check_poses
from exactgrasp.backends.params import Interval, Options, Param, validate_parameters
from exactgrasp.cache import LRUCache
from exactgrasp.errors import BackendError

if TYPE_CHECKING:
    from exactgrasp.backends.voxel.grids import HandOccupancy
    from exactgrasp.backends.voxel.points import ObjectPoints
    from exactgrasp.grasp import Grasp

__all__ = ["MAX_RESOLUTION", "SURFACE_SAMPLE_MODES", "SURFACE_WEIGHTS", "VoxelBackend"]

SURFACE_WEIGHTS = ("paper", "area")
SURFACE_SAMPLE_MODES = ("generate", "none")
MAX_RESOLUTION = 1000

# Poses per piece at least when progress is reported: a piece takes a fraction of a second,
# and each starts the kernel's threads anew.
_PROGRESS_POSES = 8_192


class VoxelBackend(Backend):
    """The paper's voxel-count estimator (see ``docs/voxel-estimator.md``).

    Parameters
    ----------
    hand_resolution : int
        Voxels along the longest side of the hand's bounding box, 2 to `MAX_RESOLUTION`
        (paper: 100).
    object_resolution : int
        Voxels along the longest side of the object's bounding box (paper: 50).
    surface_spacing : float, optional
        Minimum distance between generated surface samples, in object voxels (object's
        longest side / `object_resolution`). Default: the spacing that gives about 7,300
        samples, as in the authors' sample files.
    surface_samples : None, int, "generate" or "none"
        Where surface points come from. None: the samples given with the object when there
        are any (e.g. the authors' ``*_P.ply``), generated ones otherwise. "generate": always
        generated. An int: generate about that many (instead of `surface_spacing`). "none":
        interior voxel centres only.
    surface_weight : {"paper", "area"}
        Volume per surface point inside the hand: "paper" ``V_o / 2 * 1/16``; "area"
        ``(A / n)**1.5 / 2`` with A the object's area and n the number of samples (the
        authors' code).
    seed : int
        Seed of the surface sampler.
    grid : {"floor", "round"}
        Voxels along the shorter sides of both grids: "floor" (default, the authors' code:
        ``floor(resolution * side / longest)``, which can leave up to one voxel of a side
        out, -12 % of the cereal box's interior) or "round" (the nearest whole number, a
        box's interior within half a voxel per side). See ``docs/voxel-estimator.md``.
    """

    name = "voxel"
    #: Relative accuracy claimed for a volume where the object lies well inside the hand.
    volume_rtol = 0.05
    #: What each constructor parameter may be (checked by `validate_parameters`).
    parameter_constraints: ClassVar[dict[str, Param]] = {
        "hand_resolution": Param(
            Interval(int, 2, MAX_RESOLUTION), hint="voxels along the hand's longest side"
        ),
        "object_resolution": Param(
            Interval(int, 2, MAX_RESOLUTION), hint="voxels along the object's longest side"
        ),
        "surface_spacing": Param(
            Interval(float, 0.05, 1000),
            None,
            hint="least distance between generated surface samples, in object voxels",
        ),
        "surface_samples": Param(
            None,
            Interval(int, 1, 10_000_000),
            Options(SURFACE_SAMPLE_MODES),
            hint="given samples, a count to generate, always generated, or no surface points",
        ),
        "surface_weight": Param(Options(SURFACE_WEIGHTS)),
        "seed": Param(Interval(int, 0, None), hint="seed of the surface sampler"),
        "grid": Param(
            Options(defaults.VOXEL_GRID_RULES), hint="rounding of the grids' shorter sides"
        ),
    }

    def __init__(
        self,
        hand_resolution: int = defaults.VOXEL_HAND_RESOLUTION,
        object_resolution: int = defaults.VOXEL_OBJECT_RESOLUTION,
        surface_spacing: float | None = None,
        surface_samples: int | str | None = None,
        surface_weight: str = defaults.VOXEL_SURFACE_WEIGHT,
        seed: int = defaults.VOXEL_SEED,
        grid: str = defaults.VOXEL_GRID_RULE,
    ):
        given = validate_parameters(
            self.parameter_constraints,
            {
                "hand_resolution": hand_resolution,
                "object_resolution": object_resolution,
                "surface_spacing": surface_spacing,
                "surface_samples": surface_samples,
                "surface_weight": surface_weight,
                "seed": seed,
                "grid": grid,
            },
            type(self).__name__,
        )
        if isinstance(given["surface_samples"], int) and given["surface_spacing"] is not None:
            raise BackendError(
                "VoxelBackend: give either surface_samples (a count) or surface_spacing, not both."
            )
        if given["surface_samples"] == "none" and given["surface_spacing"] is not None:
            raise BackendError(
                "VoxelBackend: surface_spacing has no effect with surface_samples='none'."
            )
        self.hand_resolution: int = given["hand_resolution"]
        self.object_resolution: int = given["object_resolution"]
        self.surface_spacing: float | None = given["surface_spacing"]
        self.surface_samples: int | str | None = given["surface_samples"]
        self.surface_weight: str = given["surface_weight"]
        self.seed: int = given["seed"]
        self.grid: str = given["grid"]
        # This instance's parameters are fixed, so its caches are keyed by content alone.
        self._hand_grids = LRUCache(defaults.VOXEL_CACHE_SIZE)
        self._object_points = LRUCache(defaults.VOXEL_CACHE_SIZE)
        self._hand_volumes = LRUCache(defaults.VOXEL_CACHE_SIZE)

    @property
    def params(self) -> dict[str, Any]:
        """Constructor parameters (JSON-serialisable), in declaration order."""
        return {name: getattr(self, name) for name in self.parameter_constraints}

    def hand_grid(self, grasp: Grasp) -> HandOccupancy:
        """The hand's occupancy grid for `grasp`.

        Cached by this backend per ``grasp.hand_key`` (the hash of the hand's canonical
        geometry).
        """
        from exactgrasp.backends.voxel import grids

        return self._hand_grids.get(
            getattr(grasp, "hand_key", None),
            lambda: grids.hand_occupancy(
                grasp.canonical_hand_links(), self.hand_resolution, self.grid
            ),
        )

    def object_point_set(self, grasp: Grasp) -> ObjectPoints:
        """The object's points for `grasp`.

        Cached by this backend per ``grasp.object_key`` (the hash of the object's canonical
        geometry and samples).
        """

        from exactgrasp.backends.voxel import points

        def build() -> ObjectPoints:
            supplied = None
            if self.surface_samples is None:
                supplied = grasp.canonical_object_surface_samples()
            return points.object_points(
                grasp.canonical_object_bodies(),
                self.object_resolution,
                surface_samples=supplied,
                surface_mode="none" if self.surface_samples == "none" else "generate",
                surface_count=(
                    self.surface_samples if isinstance(self.surface_samples, int) else None
                ),
                surface_spacing=self.surface_spacing,
                surface_weight=self.surface_weight,
                seed=self.seed,
                grid_rule=self.grid,
            )

        return self._object_points.get(getattr(grasp, "object_key", None), build)

    def hand_volume(self, grasp: Grasp) -> float:
        """The hand's volume (union of its links), cubed canonical units.

        `Grasp.canonical_hand_volume`, cached by this backend per ``grasp.hand_key``: the
        union of a real hand's links takes longer than the estimate itself.
        """
        return self._hand_volumes.get(
            getattr(grasp, "hand_key", None), lambda: float(grasp.canonical_hand_volume)
        )

    def volumes(self, grasp: Grasp, poses: np.ndarray) -> np.ndarray:
        """Estimated intersection volume per pose, canonical units cubed.

        Threads: every core, or what `exactgrasp.backends.base.thread_limit` allows; the
        values do not depend on them.

        Parameters
        ----------
        grasp : Grasp
        poses : numpy.ndarray, shape (..., 4, 4)

        Returns
        -------
        numpy.ndarray, shape poses.shape[:-2], float64
        """
        return self._volumes(grasp, check_poses(poses))

    def _volumes(self, grasp: Grasp, poses: np.ndarray) -> np.ndarray:
        """`volumes` of poses `check_poses` returned."""
        from exactgrasp.backends.voxel.kernel import volumes_of_checked

        return volumes_of_checked(self.hand_grid(grasp), self.object_point_set(grasp), poses)

    def volumes_with_progress(
        self, grasp: Grasp, poses: np.ndarray, advance: Callable[[int], Any] | None = None
    ) -> np.ndarray:
        """`volumes`, calling ``advance(k)`` as ``k`` more poses are done.

        In `PROGRESS_PIECES` pieces of at least 8,192 poses: a descriptor's poses are one
        piece, which the estimate counts in a fraction of a second.

        Parameters
        ----------
        grasp : Grasp
        poses : numpy.ndarray, shape (..., 4, 4)
        advance : callable, optional
            Called with the number of poses finished since the last call.

        Returns
        -------
        numpy.ndarray, shape poses.shape[:-2], float64
        """
        poses = check_poses(poses)
        flat = poses.reshape(-1, 4, 4)
        step = max(_PROGRESS_POSES, -(-len(flat) // PROGRESS_PIECES))
        out = np.empty(len(flat))
        for start in range(0, len(flat), step):
            out[start : start + step] = self._volumes(grasp, flat[start : start + step])
            if advance is not None:
                advance(len(flat[start : start + step]))
        return out.reshape(poses.shape[:-2])
