"""Progress bars that stay quiet when nobody is watching, and that say so, with their clock
still ticking, while the package's kernels compile (first use only).

`progress_bar` gives a tqdm bar whose rate and time left leave out its first update: the first
results of a run may include compiling the kernels, which happens once, and would make the
rest look many times slower than it is.

While a kernel compiles (`exactgrasp.compiling` prints the notice and counts the time), the
open bars show "compiling kernels" and are redrawn every `TICK_SECONDS`: tqdm redraws on
updates only, and none come while a kernel compiles. Layer 1: imports
`exactgrasp.compiling` only.
"""

from __future__ import annotations

import os
import sys
import threading
import weakref

from tqdm.auto import tqdm

from exactgrasp.compiling import COMPILE_SECONDS, compile_seconds, on_compile

__all__ = [
    "COMPILE_SECONDS",
    "TICK_SECONDS",
    "ProgressBar",
    "compile_seconds",
    "progress_bar",
    "progress_enabled",
]

#: How often the open bars are redrawn while kernels compile (their clock keeps ticking).
TICK_SECONDS = 0.5


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


# -- while kernels compile ---------------------------------------------------------------------

#: The bars open now, told when kernels compile.
_BARS: weakref.WeakSet[ProgressBar] = weakref.WeakSet()
_DONE = threading.Event()


def _tick() -> None:
    while not _DONE.wait(TICK_SECONDS):
        for bar in list(_BARS):
            bar.refresh()


def _compiling(started: bool) -> None:
    """Mark the open bars and keep redrawing them while kernels compile."""
    if started:
        if _BARS:
            for bar in list(_BARS):
                bar.set_postfix_str("compiling kernels", refresh=True)
            _DONE.clear()
            threading.Thread(target=_tick, daemon=True).start()
        return
    _DONE.set()
    for bar in list(_BARS):
        if bar.postfix:
            bar.set_postfix_str("", refresh=True)


on_compile(_compiling)
