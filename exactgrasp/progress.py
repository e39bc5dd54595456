"""Progress bars that stay quiet when nobody is watching, and the one line printed when the
package's compiled kernels compile (first use only).

`progress_bar` gives a tqdm bar whose rate and time left leave out its first update: the first
results of a run may include compiling the kernels, which happens once, and would make the
rest look many times slower than it is.

The compile notice: importing this module registers a listener for numba's
``numba:compile`` event, which numba fires only when it compiles a function (a cache miss),
never when a kernel loads from its on-disk cache. The first time in a process that a kernel
of one family (`COMPILE_SECONDS`) compiles, one line goes to stderr,
``compiling exactgrasp kernels (exact backend), first use only (about 23 s)``, above any bar,
and the bars show "compiling kernels" until the compilation ends. It prints whether or not
stderr is a terminal (a log then says why the first call took long); a non-empty
``EXACTGRASP_NO_PROGRESS`` silences it, as it silences the bars. Layer 0: imports nothing from
exactgrasp.
"""

from __future__ import annotations

import os
import sys
import threading
import weakref

from numba.core import event
from tqdm.auto import tqdm

__all__ = ["COMPILE_SECONDS", "ProgressBar", "progress_bar", "progress_enabled"]

#: Seconds each family of kernels takes to compile from an empty cache on the reference
#: 2-core machine, as the notice announces them (measured by ``benchmarks/cold_start.py``;
#: see "Cold start" in docs/performance.md).
COMPILE_SECONDS = {"exact backend": 23, "voxel estimator": 5, "geometry": 2}

# The family of a kernel is that of the package module that calls it from Python (module
# prefix -> family, first match), else of the module that defines it.
_FAMILIES = (
    ("exactgrasp.backends.exact", "exact backend"),
    ("exactgrasp.backends.voxel", "voxel estimator"),
    ("exactgrasp.", "geometry"),
)


def progress_enabled(enable: bool | None = None) -> bool:
    """Whether to draw a bar: ``enable`` if given, else only when stderr is a terminal and
    ``EXACTGRASP_NO_PROGRESS`` is unset (so logs and CI stay clean)."""
    if enable is not None:
        return enable
    if os.environ.get("EXACTGRASP_NO_PROGRESS"):
        return False
    return bool(getattr(sys.stderr, "isatty", lambda: False)())


class ProgressBar(tqdm):
    """A tqdm bar whose rate starts at its first update.

    The first update's items count in the bar; the time up to it counts in "elapsed" but not
    in the rate, so the time left is unknown ("?") until a second update, and honest after.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._rate_started = False
        if not self.disable:
            _BARS.add(self)

    def update(self, n: int | float = 1) -> bool | None:
        """Add ``n`` items done (see `tqdm.tqdm.update`)."""
        if self._rate_started or self.disable or not n:
            return super().update(n)
        self._rate_started = True
        self.n += n
        self.initial = self.n
        self.last_print_n = self.n
        self.last_print_t = self._time()
        self.refresh()
        return True

    def close(self) -> None:
        """Close the bar (see `tqdm.tqdm.close`)."""
        _BARS.discard(self)
        super().close()


def progress_bar(total: int, desc: str = "", enable: bool | None = None) -> ProgressBar:
    """A `ProgressBar` (a context manager), disabled unless `progress_enabled`."""
    return ProgressBar(total=total, desc=desc, disable=not progress_enabled(enable), leave=False)


# -- the compile notice ----------------------------------------------------------------------

#: The bars open now, told when kernels compile.
_BARS: weakref.WeakSet[ProgressBar] = weakref.WeakSet()


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


class _CompileNotice(event.Listener):
    """Prints the notice when a family first compiles; marks the bars while any kernel does."""

    def __init__(self):
        self.depth = 0
        self.announced: set[str] = set()
        self.lock = threading.Lock()

    def on_start(self, ev: event.Event) -> None:
        # A notice must never break a compilation: any error here is dropped.
        try:
            with self.lock:
                self.depth += 1
                if self.depth != 1 or os.environ.get("EXACTGRASP_NO_PROGRESS"):
                    return
                family = _family(ev.data.get("dispatcher"))
                if family is None:
                    return
                first = family not in self.announced
                self.announced.add(family)
            if first:
                seconds = COMPILE_SECONDS[family]
                tqdm.write(
                    f"compiling exactgrasp kernels ({family}), first use only (about {seconds} s)",
                    file=sys.stderr,
                )
            for bar in list(_BARS):
                bar.set_postfix_str("compiling kernels", refresh=True)
        except Exception:
            pass

    def on_end(self, ev: event.Event) -> None:
        try:
            with self.lock:
                self.depth -= 1
                if self.depth:
                    return
            for bar in list(_BARS):
                if bar.postfix:
                    bar.set_postfix_str("", refresh=True)
        except Exception:
            pass


event.register("numba:compile", _CompileNotice())
