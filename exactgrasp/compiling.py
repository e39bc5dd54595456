"""How the package's numba kernels are compiled: `kernel` for those Python calls, `inner` for
those only other kernels call. (The winding-number, crossing and voxel kernels are compiled
ahead of time with Cython when the package is built, and their ``.pyx`` and ``.pxd`` sources
join the cache key below.)

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
  (`kernel_sources_digest`, Python and Cython sources): numba checks only a function's own
  file, so a cached kernel would otherwise keep the old code of a callee (or a constant)
  edited in another file.

Import this module's decorators in every kernel module; see "Cold start" in
docs/performance.md for the measurements and the rules that keep compilation short (no
``inline="always"`` but for the seeds' one small cell filter, writable arrays, no numba sorts).

It also watches numba's ``numba:compile`` event, which numba fires only when it compiles a
function (a cache miss), never when a kernel loads from its on-disk cache. The first time in a
process that a kernel of one family (`COMPILE_SECONDS`) compiles, one line goes to stderr,
``compiling exactgrasp kernels (exact backend), first use only (20-45 s on an idle 2-core
machine, longer on a busy one)``, above any
progress bar, whether or not stderr is a terminal (a log then says why the first call took
long); a non-empty ``EXACTGRASP_NO_PROGRESS`` silences it. `compile_seconds` counts the time
spent compiling, which timings report apart; `on_compile` tells the progress bars. Layer 0:
imports nothing from exactgrasp.
"""

from __future__ import annotations

import hashlib
import os
import sys
import threading
import time
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

import numba
from numba.core import errors, event, types
from numba.core.caching import FunctionCache
from numba.core.registry import CPUDispatcher

__all__ = [
    "COMPILE_SECONDS",
    "KERNEL_PACKAGES",
    "KERNEL_SOURCES",
    "NOTICE",
    "compile_seconds",
    "inner",
    "kernel",
    "kernel_sources_digest",
    "on_compile",
]

_NO_WRAPPERS = ("no_cpython_wrapper", "no_cfunc_wrapper")

#: The folders (relative to the package) whose modules hold kernels, the kernels' callees and
#: the constants compiled into them; with this module, their sources key the on-disk cache.
KERNEL_PACKAGES = ("geometry", "backends/exact", "backends/voxel")

#: The sources digested: Python modules, and the Cython kernels and their inline parts
#: (installed beside their compiled extensions).
KERNEL_SOURCES = ("*.py", "*.pyx", "*.pxd")


@cache
def kernel_sources_digest() -> str:
    """SHA-256 of this module and of every source (`KERNEL_SOURCES`) in `KERNEL_PACKAGES`, in
    path order."""
    root = Path(__file__).resolve().parent
    files = [Path(__file__).resolve()]
    for folder in KERNEL_PACKAGES:
        files += sorted(p for pattern in KERNEL_SOURCES for p in (root / folder).rglob(pattern))
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def code_digest(*modules: str | os.PathLike) -> str:
    """`kernel_sources_digest` and the SHA-256 of each of ``modules`` (the source files that
    compute a disk cache's entries): part of that cache's keys, so that an edit to any of them
    starts it afresh.

    Parameters
    ----------
    *modules : path-like
        Source files, usually the caller's ``__file__``.

    Returns
    -------
    str
        ``"<kernel sources>/<module>/..."``, SHA-256 hex digests.
    """
    own = [hashlib.sha256(Path(module).read_bytes()).hexdigest() for module in modules]
    return "/".join([kernel_sources_digest(), *own])


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


# -- the compile notice and the time spent compiling -------------------------------------------

#: Seconds each family of kernels takes to compile from an empty cache, fewest to most, as
#: the notice announces them: the range measured on the reference 2-core machine, quiet to
#: shared with other jobs (``benchmarks/cold_start.py``; "Cold start" in docs/performance.md).
COMPILE_SECONDS = {"exact backend": (20, 45), "geometry": (2, 5)}
#: The notice, once per family and process.
NOTICE = (
    "compiling exactgrasp kernels ({family}), first use only ({fewest}-{most} s on an idle "
    "2-core machine, longer on a busy one)"
)

# The family of a kernel is that of the package module that calls it from Python (module
# prefix -> family, first match), else of the module that defines it.
_FAMILIES = (
    ("exactgrasp.backends.exact", "exact backend"),
    ("exactgrasp.", "geometry"),
)


def _family(dispatcher) -> str | None:
    """The family of the kernel being compiled, or None for a function outside the package."""
    own = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
    if not own.startswith("exactgrasp."):
        return None
    caller = own
    frame = sys._getframe(1)
    while frame is not None:
        name = frame.f_globals.get("__name__", "")
        # Above numba's own frames, the first package frame is the kernel's Python caller.
        if name.startswith("exactgrasp.") and name != __name__:
            caller = name
            break
        frame = frame.f_back
    return next(family for prefix, family in _FAMILIES if caller.startswith(prefix))


class _CompileWatch(event.Listener):
    """Prints the notice when a family first compiles, counts the seconds spent compiling
    (outermost compilations) and calls the `on_compile` hooks."""

    def __init__(self):
        self.depth = 0
        self.started = 0.0
        self.total = 0.0
        self.announced: set[str | None] = set()
        self.hooks: list[Callable[[bool], Any]] = []
        self.lock = threading.Lock()

    def seconds(self) -> float:
        with self.lock:
            running = time.perf_counter() - self.started if self.depth else 0.0
            return self.total + running

    def _call_hooks(self, started: bool) -> None:
        for hook in list(self.hooks):
            hook(started)

    def on_start(self, ev: event.Event) -> None:
        # Never break a compilation: any error here is dropped.
        try:
            with self.lock:
                self.depth += 1
                if self.depth != 1:
                    return
                self.started = time.perf_counter()
                quiet = bool(os.environ.get("EXACTGRASP_NO_PROGRESS"))
                family = None if quiet else _family(ev.data.get("dispatcher"))
                first = family is not None and family not in self.announced
                self.announced.add(family)
            if first:
                from tqdm.auto import tqdm  # writes above any open bar

                fewest, most = COMPILE_SECONDS[family]
                tqdm.write(NOTICE.format(family=family, fewest=fewest, most=most), file=sys.stderr)
            self._call_hooks(True)
        except Exception:
            pass

    def on_end(self, ev: event.Event) -> None:
        try:
            with self.lock:
                self.depth -= 1
                if self.depth:
                    return
                self.total += time.perf_counter() - self.started
            self._call_hooks(False)
        except Exception:
            pass


_WATCH = _CompileWatch()
event.register("numba:compile", _WATCH)


def compile_seconds() -> float:
    """Wall seconds this process has spent compiling numba functions so far (outermost
    compilations, the one running included; loading a kernel from numba's cache is not
    compiling).

    The difference of two calls is the compile time of what ran in between, which
    ``Descriptor.metadata["compile_seconds"]`` and the command line report apart.
    """
    return _WATCH.seconds()


def on_compile(hook: Callable[[bool], Any]) -> None:
    """Call ``hook(True)`` when an outermost compilation starts and ``hook(False)`` when it
    ends (the progress bars' way to show it)."""
    _WATCH.hooks.append(hook)
