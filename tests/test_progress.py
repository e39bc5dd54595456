"""Progress bars, and plain log lines where stderr is not a terminal."""

from __future__ import annotations

import io
import sys

from exactgrasp import progress
from exactgrasp.progress import ProgressBar, ProgressLog, progress_bar


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
        clock.now += 30.0  # the first results, the hand's grids and tables included
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
