"""How the package's numba kernels are compiled: `kernel` for those Python calls, `inner` for
those only other kernels call.

Both are ``numba.njit`` with ``cache=True`` (compiled once per machine, then loaded from
numba's on-disk cache) plus two rules that cut compile time without changing a result:

* one compilation per argument type, not per constant: numba compiles a function called with
  a constant (``f(x, 0)``, a loop variable's first value ``-1``, ``True``) once for that
  constant and once more for the plain type; these dispatchers first try the plain types
  (``int64``, ``bool``) and keep the constant only where the function cannot compile without
  it (a heterogeneous tuple indexed by it);
* `inner` leaves out the wrappers that let Python call a function (``no_cpython_wrapper``,
  ``no_cfunc_wrapper``): for a kernel taking the named tuples of tables they are most of its
  code. A Python call (a test, an interactive check) still works: it compiles a twin with the
  wrappers, not cached, and calls that.

* the on-disk cache is keyed also on the source of every module in the kernels' packages
  (`kernel_sources_digest`): numba checks only a function's own file, so a cached kernel
  would otherwise keep the old code of a callee (or a constant) edited in another file.

Import this module's decorators in every kernel module; see "Cold start" in
docs/performance.md for the measurements and the rules that keep compilation short (no
``inline="always"``, writable arrays, no numba sorts). Layer 0: imports nothing from
exactgrasp.
"""

from __future__ import annotations

import hashlib
from functools import cache
from pathlib import Path
from typing import Any

import numba
from numba.core import errors, types
from numba.core.caching import FunctionCache
from numba.core.registry import CPUDispatcher

__all__ = ["KERNEL_PACKAGES", "inner", "kernel", "kernel_sources_digest"]

_NO_WRAPPERS = ("no_cpython_wrapper", "no_cfunc_wrapper")

#: The folders (relative to the package) whose modules hold kernels, the kernels' callees and
#: the constants compiled into them; with this module, their sources key the on-disk cache.
KERNEL_PACKAGES = ("geometry", "backends/exact", "backends/voxel")


@cache
def kernel_sources_digest() -> str:
    """SHA-256 of this module and of every module in `KERNEL_PACKAGES`, in path order."""
    root = Path(__file__).resolve().parent
    files = [Path(__file__).resolve()]
    for folder in KERNEL_PACKAGES:
        files += sorted((root / folder).rglob("*.py"))
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


class _KernelCache(FunctionCache):
    """numba's on-disk cache of one function, its entries keyed also on
    `kernel_sources_digest`."""

    def _index_key(self, sig, codegen):
        return (*super()._index_key(sig, codegen), kernel_sources_digest())


class _Kernel(CPUDispatcher):
    """A CPU dispatcher that compiles for the plain types of constant arguments first."""

    def get_call_template(self, args, kws):
        plain = tuple(types.unliteral(a) for a in args)
        plain_kws = {k: types.unliteral(v) for k, v in kws.items()}
        if plain != tuple(args) or plain_kws != kws:
            try:
                return super().get_call_template(plain, plain_kws)
            except errors.TypingError:
                pass
        return super().get_call_template(args, kws)


class _Inner(_Kernel):
    """A `_Kernel` without the Python wrappers; Python calls go to a twin that has them."""

    def __call__(self, *args, **kwargs):
        twin = self.__dict__.get("_python_twin")
        if twin is None:
            options = {k: v for k, v in self.targetoptions.items() if k not in _NO_WRAPPERS}
            options.pop("nopython", None)
            twin = self.__dict__["_python_twin"] = numba.njit(**options)(self.py_func)
        return twin(*args, **kwargs)


def _make(cls: type, options: dict[str, Any]):
    def decorate(function):
        settings = dict(options)
        cache = settings.pop("cache", True)
        dispatcher = numba.njit(cache=False, **settings)(function)
        # Same layout, one overridden method: the dispatcher keeps every numba behaviour.
        dispatcher.__class__ = cls
        if cache:
            # What numba's own ``cache=True`` does, with the cache keyed as above.
            dispatcher._cache = _KernelCache(function)
        return dispatcher

    return decorate


def kernel(**options: Any):
    """``numba.njit(cache=True, **options)`` for a kernel Python calls (see the module).

    Parameters
    ----------
    **options
        Any ``numba.njit`` option (``nogil``, ``error_model``, ``parallel``, ``cache``, ...).
    """
    return _make(_Kernel, options)


def inner(**options: Any):
    """Like `kernel`, without the Python wrappers: for kernels only other kernels call.

    Parameters
    ----------
    **options
        Any ``numba.njit`` option (``nogil``, ``error_model``, ...).
    """
    return _make(_Inner, {**options, **dict.fromkeys(_NO_WRAPPERS, True)})
