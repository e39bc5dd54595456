"""The exact backend: certified intersection volumes, the plain boolean and the kernel.

Modules by stage: `reference` (the plain boolean, the agreement rule), `intersector` (the
array-level core; its result in `intersection`, its fallbacks in `extrapolate` and
`arranged`), `backend` (the `Backend`), `tables` (the kernel's named tables), `grids` and
`prepare` (built once per grasp), the compiled kernel `_kernel` (the per-pose driver; its
stages, inline, in ``_pose.pxd``, ``_seeds.pxd`` with ``_edge_seeds.pxd`` and ``_filters.pxd``,
``_search.pxd`` with ``_common_line.pxd``, ``_pairs.pxd``, ``_classify.pxd`` and
``_sums.pxd``, on ``_cells.pxd`` and ``_predicates.pxd``, its tables read through
``_tables.pxd``) and `_entries` (the compiled kernels Python calls outside it); every tolerance
in `tolerances`; the volume's derivatives in `moments` (what they are, the boolean
reference), `moment_layout` (the tables, built once), ``_moment_sums.pxd`` and
``_object_moments.pxd`` (in the kernel), `moment_entries` (the rows each pose touched) and
`gradients` (`VolumeGradients`) or `face_gradients` (by every vertex).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.backends.exact.backend import ExactBackend
    from exactgrasp.backends.exact.gradients import VolumeGradients
    from exactgrasp.backends.exact.intersection import Intersection
    from exactgrasp.backends.exact.intersector import ExactIntersector, repeated_poses
    from exactgrasp.backends.exact.reference import FLOOR, RTOL, agrees, plain_error, plain_volumes

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.backends.exact.backend": ("ExactBackend",),
        "exactgrasp.backends.exact.gradients": ("VolumeGradients",),
        "exactgrasp.backends.exact.intersection": ("Intersection",),
        "exactgrasp.backends.exact.intersector": ("ExactIntersector", "repeated_poses"),
        "exactgrasp.backends.exact.reference": (
            "FLOOR",
            "RTOL",
            "agrees",
            "plain_error",
            "plain_volumes",
        ),
    },
)

__all__ = [
    "FLOOR",
    "RTOL",
    "ExactBackend",
    "ExactIntersector",
    "Intersection",
    "VolumeGradients",
    "agrees",
    "plain_error",
    "plain_volumes",
    "repeated_poses",
]
