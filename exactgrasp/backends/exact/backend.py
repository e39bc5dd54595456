"""The "exact" backend: `ExactBackend`, the `Backend` wrapping `intersector.ExactIntersector`
(the true volume of hand ∩ moved object, pose by pose; see ``docs/exact-backend.md``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from exactgrasp.backends import defaults
from exactgrasp.backends.base import Backend, check_poses
from exactgrasp.backends.exact.options import PARAMETERS, check_options
from exactgrasp.backends.exact.tolerances import RTOL
from exactgrasp.cache import LRUCache

if TYPE_CHECKING:
    from exactgrasp.backends.exact.gradients import VolumeGradients
    from exactgrasp.backends.exact.intersector import ExactIntersector
    from exactgrasp.grasp import Grasp


class ExactBackend(Backend):
    """Exact hand ∩ moved object volumes (manifold3d unions + certified surface integrals).

    Parameters
    ----------
    broadphase : {"coal", "fcl", None}
        Library that skips whole poses whose surfaces are apart; None tests every pose in
        full. The volumes do not depend on it.
    n_jobs : int or None
        Threads over poses. None (default): every core (``os.cpu_count()``), except inside a
        batch worker, which sets the number (one per worker process: the batch already runs a
        worker per core; `exactgrasp.backends.base.thread_limit`). -1: every core, always.
        The volumes do not depend on it.
    hand_cell, object_cell : float, optional
        Grid cell edges of the hand and of the object (canonical units); None (default):
        1/`defaults.EXACT_CELLS_PER_EXTENT` of each mesh's largest extent.
    capacity : int
        Edge crossings recorded per pose before the pose falls back to a boolean (default
        `defaults.EXACT_CAPACITY`).

    Every option is checked against `PARAMETERS`, here, once; the intersectors built from
    them take them as they are.
    """

    name = "exact"
    volume_rtol = RTOL
    parameter_constraints = PARAMETERS
    #: Built intersectors kept per grasp geometry (least recently used dropped first).
    cache_size = defaults.EXACT_CACHE_SIZE

    def __init__(
        self,
        broadphase: str | None = defaults.EXACT_BROADPHASE,
        n_jobs: int | None = defaults.EXACT_N_JOBS,
        hand_cell: float | None = None,
        object_cell: float | None = None,
        capacity: int = defaults.EXACT_CAPACITY,
    ):
        self.options = check_options(
            broadphase,
            n_jobs,
            {"hand_cell": hand_cell, "object_cell": object_cell, "capacity": capacity},
            type(self).__name__,
        )
        self.broadphase = self.options.broadphase
        self.n_jobs = self.options.n_jobs
        # Provenance records the tuning that differs from the defaults (None cells are left
        # out by `check_options`).
        self.tuning = dict(self.options.tuning)
        if self.tuning["capacity"] == defaults.EXACT_CAPACITY:
            del self.tuning["capacity"]
        # Keyed by the grasp's geometry alone: this instance's options are fixed.
        self._intersectors = LRUCache(self.cache_size)

    @property
    def params(self) -> dict[str, Any]:
        """Parameters (the volumes depend on none of them; recorded for provenance)."""
        return {"broadphase": self.broadphase, "n_jobs": self.n_jobs, **self.tuning}

    def intersector(self, grasp: Grasp) -> ExactIntersector:
        """The `ExactIntersector` of a grasp, built once per `grasp.geometry_key`."""
        return self._intersectors.get(
            grasp.geometry_key,
            lambda: self.intersector_of(
                grasp.canonical_hand_links(), grasp.canonical_object_bodies()
            ),
        )

    def intersector_of(
        self, hand_links: list, object_bodies: list, faces: bool = False
    ) -> ExactIntersector:
        """A new `ExactIntersector` of meshes with this backend's options (not kept).

        Parameters
        ----------
        hand_links, object_bodies : list of (V (n, 3) float64, F (m, 3) int)
            As `ExactIntersector` takes them.
        faces : bool
            As `ExactIntersector` takes it: moments per face of either mesh.
        """
        # Here, not above: the class and its parameters load without the kernels, for ``--help``.
        from exactgrasp.backends.exact.intersector import ExactIntersector

        return ExactIntersector(hand_links, object_bodies, options=self.options, faces=faces)

    def volumes(self, grasp: Grasp, poses: np.ndarray) -> np.ndarray:
        """Exact volume of hand ∩ moved object per pose, in cubed canonical units."""
        return self.intersector(grasp).volumes(check_poses(poses))

    def volumes_with_progress(
        self, grasp: Grasp, poses: np.ndarray, advance: Callable[[int], Any] | None = None
    ) -> np.ndarray:
        """`volumes` in one call, ``advance(k)`` called as pieces of the intersector's own
        work end (`ExactIntersector.volumes`)."""
        return self.intersector(grasp).volumes(check_poses(poses), progress=advance)

    def hand_volume(self, grasp: Grasp) -> float:
        """The volume of the union of the hand's links the intersector built, in cubed
        canonical units (equal to `Grasp.canonical_hand_volume` to manifold3d's rounding)."""
        return self.intersector(grasp).hand_volume

    def volume_gradients(self, grasp: Grasp, poses: np.ndarray) -> VolumeGradients:
        """Volumes of hand ∩ moved object and their derivatives by a rigid motion of the
        object and by the hand's joints.

        Parameters
        ----------
        grasp : Grasp
        poses : numpy.ndarray, shape (n, 4, 4) or (4, 4)
            Rigid motions of the object in the canonical frame, as for `volumes`.

        Returns
        -------
        VolumeGradients
            ``volumes`` (n,), ``twist`` (n, 6), ``joints`` (n, k) and ``joint_names`` (k);
            a single (4, 4) pose counts as n = 1, all in the canonical frame's units (one
            unit is ``1 / grasp.frame.scale`` metres). See `VolumeGradients` for the
            conventions and ``docs/exact-backend.md`` ("Derivatives", "Units: the canonical
            frame", for the same in metres).
        """
        arr = check_poses(poses)
        flat = arr.reshape(-1, 4, 4)
        from exactgrasp.backends.exact.gradients import (
            VolumeGradients,
            object_twist,
            volume_moments,
        )
        from exactgrasp.hands.twists import link_twists

        volumes, links = volume_moments(self.intersector(grasp), flat)
        names, twists = link_twists(grasp.hand)
        # dV/dq_j = Σ_l ξ_jl · (F_l, M_l): the hand's links move, the object stays.
        joints = np.einsum("jlc,nlc->nj", twists, links)
        return VolumeGradients(volumes, object_twist(links), joints, names)
