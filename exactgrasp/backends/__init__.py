"""Intersection backends, by name.

Built-in: ``"voxel"`` (the paper's voxel-count estimator) and ``"exact"`` (manifold3d boolean
volumes with a coal or python-fcl broad phase). Other packages add backends through the entry
point group ``exactgrasp.backends``; `register_backend` adds one at run time.
"""

from __future__ import annotations

import importlib
import warnings
from importlib.metadata import entry_points
from typing import Any

from exactgrasp.backends.base import Backend, check_poses
from exactgrasp.errors import BackendError, MissingDependencyError

ENTRY_POINT_GROUP = "exactgrasp.backends"

#: name -> "module:Class"; loaded lazily so an optional dependency is only needed when used.
_BUILTIN: dict[str, str] = {
    "voxel": "exactgrasp.backends.voxel:VoxelBackend",
    "exact": "exactgrasp.backends.exact:ExactBackend",
}
#: Packages a built-in backend cannot work without (module, pip package, extra).
_NEEDS: dict[str, list[tuple[str, str, str]]] = {
    "voxel": [("numba", "numba", "all")],
    "exact": [("manifold3d", "manifold3d", "all")],
}
_REGISTERED: dict[str, type[Backend]] = {}


def register_backend(name: str, cls: type[Backend]) -> None:
    """Make a backend class available under ``name`` (overrides entry points and built-ins)."""
    if not (isinstance(cls, type) and issubclass(cls, Backend)):
        raise BackendError(f"register_backend({name!r}): {cls!r} is not a Backend subclass.")
    _REGISTERED[name] = cls


def _entry_points() -> dict[str, Any]:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def _names() -> list[str]:
    return sorted(set(_BUILTIN) | set(_entry_points()) | set(_REGISTERED))


def _load(name: str) -> type[Backend]:
    if name in _REGISTERED:
        return _REGISTERED[name]
    for module, package, extra in _NEEDS.get(name, []):
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise MissingDependencyError(f"the {name!r} backend", package, extra) from exc
    if name in _BUILTIN:
        module_name, _, attr = _BUILTIN[name].partition(":")
        cls = getattr(importlib.import_module(module_name), attr, None)
        if cls is None:
            raise BackendError(f"backend {name!r}: {module_name} defines no {attr}.")
        return cls
    eps = _entry_points()
    if name in eps:
        try:
            return eps[name].load()
        except ImportError as exc:
            missing = getattr(exc, "name", None) or str(exc)
            raise MissingDependencyError(f"the {name!r} backend", missing, "all") from exc
    raise BackendError(f"unknown backend {name!r}; available: {_names()}.")


def available_backends() -> set[str]:
    """Names of the backends whose dependencies are installed.

    Returns
    -------
    set of str
    """
    out = set()
    for name in _names():
        try:
            _load(name)
        except (MissingDependencyError, ImportError):
            continue
        except Exception as exc:  # a broken plugin must not hide the working backends
            warnings.warn(f"backend {name!r} is unusable and skipped: {exc}", stacklevel=2)
            continue
        out.add(name)
    return out


def get_backend(name: str | Backend, **params: Any) -> Backend:
    """A backend instance by name.

    Parameters
    ----------
    name : str or Backend
        ``"voxel"``, ``"exact"`` or a registered name; a `Backend` instance is returned as is
        (then ``params`` must be empty).
    **params
        Constructor parameters of that backend, e.g. ``broadphase="coal"`` or
        ``object_resolution=50``.

    Returns
    -------
    Backend
    """
    if isinstance(name, Backend):
        if params:
            raise BackendError(
                f"get_backend got a {type(name).__name__} instance and parameters "
                f"{sorted(params)}; set parameters when constructing the backend."
            )
        return name
    if not isinstance(name, str):
        raise BackendError(f"backend must be a name or a Backend, got {type(name).__name__}.")
    cls = _load(name)
    try:
        return cls(**params)
    except TypeError as exc:
        raise BackendError(f"backend {name!r}: bad parameters {sorted(params)} ({exc}).") from exc


__all__ = [
    "ENTRY_POINT_GROUP",
    "Backend",
    "available_backends",
    "check_poses",
    "get_backend",
    "register_backend",
]
