"""Progress bars on a terminal, and plain log lines on a long call when stderr is not one.

Where stderr is not a terminal (a log file, a pipe, a job's output) and nobody chose
(``progress=None``), a bar's redrawn line would fill the log with carriage returns;
`ProgressLog` writes one plain line at most every `LOG_SECONDS` instead, the first only once
a call has run that long, so a short call writes nothing.

`progress_bar` gives a tqdm bar whose rate and time left leave out its first update: the first
results of a run include what is built once per hand and object (grids, tables, solids), and
would make the rest look many times slower than it is.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import IO

from tqdm.auto import tqdm

__all__ = [
    "LOG_SECONDS",
    "ProgressBar",
    "ProgressLog",
    "progress_bar",
    "progress_enabled",
]

#: Fewest seconds between two lines of a `ProgressLog`, and before its first: often enough to
#: show a long call moving, rarely enough to keep a log readable.
LOG_SECONDS = 5.0


def progress_enabled(enable: bool | None = None) -> bool:
    """Whether to draw a bar: ``enable`` if given, else only when stderr is a terminal and
    ``EXACTGRASP_NO_PROGRESS`` is unset (elsewhere `progress_bar` gives a `ProgressLog`)."""
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


class ProgressLog:
    """Progress as plain lines (``poses: 1,200/4,266 (28 %), 10 s``), one at most every
    ``interval`` seconds and none before: a call shorter than that writes nothing; a longer
    one ends with a line of its total.

    Parameters
    ----------
    total : int
        Items to do.
    desc : str
        What they are, at the start of each line.
    file : file-like, optional
        Where the lines go (default: stderr at each line).
    interval : float, optional
        Seconds between lines (default `LOG_SECONDS`, read when the log is made).
    clock : callable, optional
        Seconds now (default `time.monotonic`).

    Shares what the package's callers use of a `ProgressBar`: ``update``, ``close``, ``n``,
    ``total``, ``disable`` (False) and the context manager.
    """

    disable = False

    def __init__(
        self,
        total: int,
        desc: str = "",
        file: IO[str] | None = None,
        interval: float | None = None,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.total, self.desc, self.n = total, desc, 0
        self.file = file
        self.interval = LOG_SECONDS if interval is None else interval
        self.clock = clock
        self.start = self.last = clock()
        self.lines = 0

    def update(self, n: int | float = 1) -> None:
        """Add ``n`` items done; write a line if `interval` has passed since the last."""
        self.n += n
        if self.clock() - self.last >= self.interval:
            self._write()

    def close(self) -> None:
        """End the log: a last line with the total, if any line was written."""
        if self.lines:
            self._write()

    def _write(self) -> None:
        self.last = now = self.clock()
        share = f" ({100 * self.n / self.total:.0f} %)" if self.total else ""
        print(
            f"{self.desc}: {self.n:,}/{self.total:,}{share}, {now - self.start:.0f} s",
            file=sys.stderr if self.file is None else self.file,
            flush=True,
        )
        self.lines += 1

    def __enter__(self) -> ProgressLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def progress_bar(
    total: int, desc: str = "", enable: bool | None = None
) -> ProgressBar | ProgressLog:
    """A `ProgressBar` (a context manager), disabled unless `progress_enabled`; or, when
    nobody chose (``enable`` None) and stderr is not a terminal, a `ProgressLog` (unless
    ``EXACTGRASP_NO_PROGRESS`` is set)."""
    if enable is None and not progress_enabled() and not os.environ.get("EXACTGRASP_NO_PROGRESS"):
        return ProgressLog(total, desc)
    return ProgressBar(total=total, desc=desc, disable=not progress_enabled(enable), leave=False)
