"""Intersection backends, by name.

Built-in: ``"voxel"`` (the paper's voxel-count estimator) and ``"exact"`` (the true volume of
hand ∩ moved object: a compiled kernel of certified surface integrals over the manifold3d
unions of hand and object, a plain manifold3d boolean for the poses it cannot certify, and a
coal or python-fcl broad phase that skips poses whose surfaces are apart; see
``docs/exact-backend.md``). Other packages add backends through the entry
point group ``exactgrasp.backends``; `register_backend` adds one at run time (see
``docs/backends.md``). Re-exports the registry and the backend interface.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.backends import registry
    from exactgrasp.backends.base import Backend, check_poses
    from exactgrasp.backends.registry import (
        ENTRY_POINT_GROUP,
        as_backend,
        available_backends,
        backend_class,
        get_backend,
        register_backend,
        shared_backend,
        unregister_backend,
    )

__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.backends.base": ("Backend", "check_poses"),
        "exactgrasp.backends.registry": (
            "ENTRY_POINT_GROUP",
            "as_backend",
            "available_backends",
            "backend_class",
            "get_backend",
            "register_backend",
            "shared_backend",
            "unregister_backend",
        ),
    },
    {"registry": "exactgrasp.backends.registry"},
)

__all__ = [
    "ENTRY_POINT_GROUP",
    "Backend",
    "as_backend",
    "available_backends",
    "backend_class",
    "check_poses",
    "get_backend",
    "register_backend",
    "registry",
    "shared_backend",
    "unregister_backend",
]
