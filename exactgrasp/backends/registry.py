"""Backends by name: the built-ins, those registered at run time and entry-point plugins.

`BACKENDS` maps a name to a `BackendEntry` (a class, or a ``"module:Class"`` path imported on
first use); the entry point group ``exactgrasp.backends`` is read on every lookup and fills in
the names `BACKENDS` lacks. `shared_backend` keeps one instance per (name, parameters), so the
per-geometry caches of a backend serve every later grasp.
"""

from __future__ import annotations

import importlib
import inspect
import json
import warnings
from collections.abc import Iterable
from importlib.metadata import entry_points
from typing import Any, NamedTuple

from exactgrasp.backends import defaults
from exactgrasp.backends.base import Backend
from exactgrasp.cache import LRUCache
from exactgrasp.errors import BackendError, MissingDependencyError

__all__ = [
    "BACKENDS",
    "BUILTIN_BACKENDS",
    "ENTRY_POINT_GROUP",
    "BackendEntry",
    "as_backend",
    "available_backends",
    "backend_class",
    "get_backend",
    "register_backend",
    "shared_backend",
    "unregister_backend",
]

ENTRY_POINT_GROUP = "exactgrasp.backends"


class BackendEntry(NamedTuple):
    """How to get one backend class.

    Attributes
    ----------
    target : str or type
        The `Backend` subclass, or its ``"module:Class"`` path (imported on first use, so an
        optional dependency is needed only when the backend is).
    requires : tuple of (module, package, extra)
        Modules the backend cannot work without, with the pip package and the exactgrasp extra
        that install each; checked before the target is imported.
    """

    target: str | type[Backend]
    requires: tuple[tuple[str, str, str], ...] = ()


#: The built-in backends (manifold3d, which they need, is a core dependency; their kernels are
#: compiled with the package).
BUILTIN_BACKENDS: dict[str, BackendEntry] = {
    "voxel": BackendEntry("exactgrasp.backends.voxel:VoxelBackend"),
    "exact": BackendEntry("exactgrasp.backends.exact:ExactBackend"),
}
#: Every backend known without reading entry points: the built-ins and `register_backend`'s.
BACKENDS: dict[str, BackendEntry] = dict(BUILTIN_BACKENDS)

_SHARED = LRUCache(defaults.SHARED_CACHE_SIZE)


def register_backend(
    name: str,
    cls: type[Backend] | str,
    requires: Iterable[tuple[str, str, str]] = (),
) -> None:
    """Make a backend available under ``name`` (overrides entry points and built-ins).

    Parameters
    ----------
    name : str
    cls : type or str
        A `Backend` subclass, or its ``"module:Class"`` path to import on first use.
    requires : iterable of (module, package, extra)
        Modules to check before importing ``cls``; a missing one raises
        `MissingDependencyError` naming its package and extra.
    """
    if isinstance(cls, str):
        module, _, attr = cls.partition(":")
        if not (module and attr):
            raise BackendError(
                f"register_backend({name!r}): {cls!r} is not a 'module:Class' path."
            )
    elif not (isinstance(cls, type) and issubclass(cls, Backend)):
        raise BackendError(f"register_backend({name!r}): {cls!r} is not a Backend subclass.")
    BACKENDS[name] = BackendEntry(cls, tuple(tuple(r) for r in requires))
    _SHARED.clear()


def unregister_backend(name: str) -> None:
    """Undo `register_backend`: drop ``name``, or restore the built-in it overrode."""
    if name in BUILTIN_BACKENDS:
        BACKENDS[name] = BUILTIN_BACKENDS[name]
    else:
        BACKENDS.pop(name, None)
    _SHARED.clear()


def _entry_points() -> dict[str, Any]:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def _names() -> list[str]:
    return sorted(set(BACKENDS) | set(_entry_points()))


def _import(name: str, module: str, load: Any) -> Any:
    """``load()``, a missing third-party module turned into a `MissingDependencyError`.

    An ImportError from inside the backend's own package is a bug there and is not renamed.
    """
    try:
        return load()
    except MissingDependencyError:
        raise
    except ImportError as exc:
        missing = getattr(exc, "name", None)
        if not missing or missing.partition(".")[0] == module.partition(".")[0]:
            raise
        raise MissingDependencyError(f"the {name!r} backend", missing, "all") from exc


def _load(name: str) -> type[Backend]:
    entry = BACKENDS.get(name)
    if entry is None:
        eps = _entry_points()
        if name not in eps:
            raise BackendError(f"unknown backend {name!r}; available: {_names()}.")
        return _import(name, eps[name].module, eps[name].load)
    for module, package, extra in entry.requires:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise MissingDependencyError(f"the {name!r} backend", package, extra) from exc
    if not isinstance(entry.target, str):
        return entry.target
    module_name, _, attr = entry.target.partition(":")
    cls = getattr(
        _import(name, module_name, lambda: importlib.import_module(module_name)), attr, None
    )
    if cls is None:
        raise BackendError(f"backend {name!r}: {module_name} defines no {attr}.")
    return cls


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


def backend_class(name: str) -> type[Backend]:
    """The class of a backend by name, without constructing it (e.g. to read its
    ``parameter_constraints``).

    Raises
    ------
    BackendError, MissingDependencyError
        As `get_backend`: an unknown name, or an optional package it needs is missing.
    """
    if not isinstance(name, str):
        raise BackendError(f"backend must be a name, got {type(name).__name__}.")
    return _load(name)


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
    # The parameters are matched to the constructor's signature before the call, so that a
    # TypeError raised inside the constructor (a bug) is not mistaken for bad parameters.
    try:
        inspect.signature(cls).bind(**params)
    except TypeError as exc:
        raise BackendError(
            f"backend {name!r}: bad parameters {sorted(params)} "
            f"({cls.__qualname__}.__init__() {exc})."
        ) from exc
    return cls(**params)


def shared_backend(name: str | Backend, **params: Any) -> Backend:
    """One backend instance per (name, parameters) in this process, built on first use.

    Its caches (hand grids, object points, exact intersectors) then serve every later grasp
    with the same geometry. The last `defaults.SHARED_CACHE_SIZE` combinations are kept.

    Parameters
    ----------
    name : str or Backend
        As for `get_backend`; an instance is returned as is.
    **params
        Constructor parameters; values that are not JSON make the instance unshared.

    Returns
    -------
    Backend
    """
    if isinstance(name, Backend):
        return get_backend(name, **params)
    try:
        key = json.dumps([name, params], sort_keys=True)
    except (TypeError, ValueError):
        key = None
    return _SHARED.get(key, lambda: get_backend(name, **params))


def as_backend(backend: str | Backend) -> Backend:
    """The backend a caller named: the one spelling of ``backend=`` in every public function.

    Parameters
    ----------
    backend : str or Backend
        A registered name, which means that backend with the library defaults
        (`exactgrasp.backends.defaults`; one instance per process, `shared_backend`, so its
        caches serve every later call), or a configured instance, used as it is (e.g.
        ``ExactBackend(broadphase=None, n_jobs=1)``).

    Returns
    -------
    Backend

    Raises
    ------
    BackendError, MissingDependencyError
        An unknown name or another type; an optional package the backend needs is missing.
    """
    if isinstance(backend, Backend):
        return backend
    if not isinstance(backend, str):
        raise BackendError(
            f"backend must be a name or a Backend, got {type(backend).__name__}; pass e.g. "
            "backend='exact' or backend=ExactBackend(broadphase=None, n_jobs=1)."
        )
    return shared_backend(backend)
