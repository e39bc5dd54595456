"""Progress bars that stay quiet when nobody is watching."""

from __future__ import annotations

import os
import sys

from tqdm.auto import tqdm


def progress_enabled(enable: bool | None = None) -> bool:
    """Whether to draw a bar: ``enable`` if given, else only when stderr is a terminal and
    ``EXACTGRASP_NO_PROGRESS`` is unset (so logs and CI stay clean)."""
    if enable is not None:
        return enable
    if os.environ.get("EXACTGRASP_NO_PROGRESS"):
        return False
    return bool(getattr(sys.stderr, "isatty", lambda: False)())


def progress_bar(total: int, desc: str = "", enable: bool | None = None) -> tqdm:
    """A tqdm bar (a context manager), disabled unless `progress_enabled`."""
    return tqdm(total=total, desc=desc, disable=not progress_enabled(enable), leave=False)
