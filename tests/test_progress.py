"""Progress bars and the compile notice: one line on a cold numba cache, none on a warm one."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import time
from pathlib import Path

from numba.core import event

from exactgrasp import progress
from exactgrasp.progress import (
    COMPILE_SECONDS,
    ProgressBar,
    ProgressLog,
    compile_seconds,
    progress_bar,
)

ROOT = Path(__file__).resolve().parents[1]

# A user's own compiled function (no notice), then one of the package's smallest kernels.
SCRIPT = """
import sys
sys.path.insert(0, {root!r})
import numba
import exactgrasp.geometry.predicates as predicates

@numba.njit
def users_own(x):
    return x + 1.0

users_own(1.0)
print("notice below", file=sys.stderr)
predicates.orient_bound(1.0)
predicates.orient_bound(2.0)
"""


def _stderr(cache: Path, **env: str) -> str:
    """stderr of `SCRIPT` run in a fresh process with ``NUMBA_CACHE_DIR=cache``."""
    environ = {k: v for k, v in os.environ.items() if k != "EXACTGRASP_NO_PROGRESS"}
    environ.update(NUMBA_CACHE_DIR=str(cache), **env)
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT.format(root=str(ROOT))],
        env=environ,
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    )
    return out.stderr


def test_compile_notice_prints_once_on_a_cold_cache_only(tmp_path):
    fewest, most = COMPILE_SECONDS["geometry"]
    line = (
        f"compiling exactgrasp kernels (geometry), first use only ({fewest}-{most} s on an "
        "idle 2-core machine, longer on a busy one)"
    )
    cold = _stderr(tmp_path / "cache")
    assert cold.splitlines() == ["notice below", line]
    warm = _stderr(tmp_path / "cache")
    assert warm.splitlines() == ["notice below"]
    quiet = _stderr(tmp_path / "other", EXACTGRASP_NO_PROGRESS="1")
    assert quiet.splitlines() == ["notice below"]


class _Clock:
    def __init__(self):
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def test_bar_rate_leaves_out_the_first_update(tmp_path):
    with open(tmp_path / "bar.txt", "w") as sink, progress_bar(100, "poses", True) as bar:
        bar.fp = sink
        clock = _Clock()
        bar._time = clock
        bar.start_t = bar.last_print_t = clock()
        clock.now += 30.0  # the first results, compiling included
        bar.update(10)
        assert bar.n == 10
        assert not bar.format_dict["rate"]
        clock.now += 1.0
        bar.update(10)
        assert bar.format_dict["rate"] == 10.0
        assert bar.format_dict["elapsed"] == 31.0


def test_disabled_bar_counts_nothing():
    with progress_bar(5, "poses", False) as bar:
        bar.update(3)
        assert bar.disable


def test_the_clock_keeps_ticking_and_the_time_is_counted_while_compiling():
    """A compilation of 1.3 s with no update of the bar: the bar is redrawn every
    `TICK_SECONDS` with its elapsed time, and `compile_seconds` grows by those 1.3 s."""
    sink = io.StringIO()
    bar = ProgressBar(total=10, desc="exact poses", file=sink, mininterval=0)
    before = compile_seconds()
    event.start_event("numba:compile", data={"dispatcher": None})
    try:
        time.sleep(1.3)
        assert compile_seconds() - before >= 1.3  # counted while it runs, too
    finally:
        event.end_event("numba:compile", data={"dispatcher": None})
        text = sink.getvalue()
        bar.close()
    clocks = re.findall(r"00:0(\d)", text)
    assert "1" in clocks, text  # drawn at 00:01, with no update of the bar
    assert text.count("\r") >= 1.3 / progress.TICK_SECONDS
    assert 1.3 <= compile_seconds() - before < 2.5


# -- plain lines where stderr is not a terminal --------------------------------------------------


def test_a_long_call_logs_a_line_every_interval_and_its_total():
    sink, clock = io.StringIO(), _Clock()
    assert progress.LOG_SECONDS == 5.0  # docs/cli.md says so
    with ProgressLog(4266, "exact poses", file=sink, clock=clock) as log:
        for step in range(12):  # 12 updates, 1 s apart: lines at 5 s and 10 s
            clock.now += 1.0
            log.update(100)
            if step == 3:
                assert sink.getvalue() == ""  # 4 s in: nothing yet
    assert sink.getvalue().splitlines() == [
        "exact poses: 500/4,266 (12 %), 5 s",
        "exact poses: 1,000/4,266 (23 %), 10 s",
        "exact poses: 1,200/4,266 (28 %), 12 s",  # the total, at the end
    ]


def test_a_short_call_logs_nothing():
    sink, clock = io.StringIO(), _Clock()
    with ProgressLog(100, "poses", file=sink, interval=5.0, clock=clock) as log:
        for _ in range(10):
            clock.now += 0.49
            log.update(10)
    assert sink.getvalue() == ""


def test_progress_bar_logs_when_stderr_is_not_a_terminal(monkeypatch):
    stderr = io.StringIO()  # isatty() is False
    monkeypatch.setattr(sys, "stderr", stderr)
    monkeypatch.delenv("EXACTGRASP_NO_PROGRESS")
    monkeypatch.setattr(progress, "LOG_SECONDS", 0.0)  # every update is "long"
    with progress_bar(3, "grasps") as log:
        assert isinstance(log, ProgressLog) and not log.disable
        log.update(1)
    assert stderr.getvalue().splitlines()[0].startswith("grasps: 1/3 (33 %), ")
    # Chosen: no bar and no line; a bar; or nothing at all where EXACTGRASP_NO_PROGRESS is set.
    assert progress_bar(3, "grasps", False).disable
    assert isinstance(progress_bar(3, "grasps", True), ProgressBar)
    monkeypatch.setenv("EXACTGRASP_NO_PROGRESS", "1")
    assert progress_bar(3, "grasps").disable
