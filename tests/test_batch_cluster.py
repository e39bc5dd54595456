"""A real cluster: ``dask scheduler`` and two ``dask worker`` processes started from the command
line on localhost, as on machines (docs/batch.md), a batch run against its address, one worker
killed mid-run, and every row finished, byte for byte as a run in one process.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

import exactgrasp as eg
from exactgrasp.batch import read_batch, run_batch
from exactgrasp.batch.worker import cluster_environment

SAMPLER = eg.PathSampler(4, 3, 3, n_steps=4)
N_ROWS = 12


def _dask(*args: str, env: dict | None = None, log: Path) -> subprocess.Popen:
    # `python -m dask` is the `dask` command of this interpreter's environment; a process
    # group of its own, so that killing it takes its children (a worker's nanny and process).
    return subprocess.Popen(
        [sys.executable, "-m", "dask", *args],
        env={**os.environ, **(env or {})},
        stdout=log.open("w"),
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )


def _kill(process: subprocess.Popen) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=30)


def _wait_for(predicate, what: str, timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > end:
            raise TimeoutError(f"no {what} after {timeout:.0f} s")
        time.sleep(0.2)


@pytest.fixture
def manifest(tmp_path) -> Path:
    rows = []
    for i in range(N_ROWS):
        pose = np.eye(4)
        pose[:3, 3] = (0.003 * (i % 4), 0.002 * (i // 4), 0.11 + 0.002 * i)
        hand = eg.hands.barrett({"finger_1_med_joint": 0.1 * i, "finger_3_med_joint": 0.08 * i})
        grasp = eg.Grasp(hand, eg.objects.box((0.06, 0.1, 0.1)), pose, name=f"g{i}")
        grasp.save(tmp_path / "grasps" / f"g{i}.json")
        rows.append({"id": f"g{i}", "grasp": f"grasps/g{i}.json"})
    path = tmp_path / "manifest.jsonl"
    path.write_text("".join(json.dumps(row) + "\n" for row in rows))
    return path


def test_command_line_cluster_survives_a_killed_worker(manifest, tmp_path):
    from distributed import Client

    processes = []
    try:
        address_file = tmp_path / "scheduler.json"
        processes.append(
            _dask(
                "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                "--scheduler-file", str(address_file), env=cluster_environment(),
                log=tmp_path / "scheduler.log",
            )
        )  # fmt: skip
        _wait_for(address_file.exists, "scheduler file")
        _wait_for(lambda: "address" in address_file.read_text(), "scheduler address")
        address = json.loads(address_file.read_text())["address"]
        # One thread a worker, the thread limits and settings in its environment, as
        # docs/batch.md says.
        for name in ("w0", "w1"):
            processes.append(
                _dask(
                    "worker", address, "--nthreads", "1", "--name", name, "--no-dashboard",
                    env=cluster_environment(), log=tmp_path / f"{name}.log",
                )
            )  # fmt: skip
        with Client(address) as client:
            client.wait_for_workers(2, timeout=180)
            assert sum(client.nthreads().values()) == 2

        out = tmp_path / "cluster"
        command = [sys.executable, "-m", "exactgrasp.cli", "batch", str(manifest)]
        command += ["--out", str(out), "--scheduler", address, "--no-progress"]
        command += ["--sampler", json.dumps(SAMPLER.params)]
        batch = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        timings = out / "timings.jsonl"

        def tasks() -> list[dict]:
            lines = timings.read_text().splitlines() if timings.exists() else []
            return [t for t in map(json.loads, lines) if "part" in t]

        # Both workers have finished a task (so each holds the next one): kill w1, its nanny
        # and its worker process, as a machine that dies.
        both = lambda: len({t["worker"] for t in tasks()}) == 2  # noqa: E731
        _wait_for(lambda: both() or batch.poll() is not None, "task from each worker", 600)
        done_at_kill = sum(t["rows"] for t in tasks())
        assert done_at_kill < N_ROWS, "the run ended before a worker could be killed"
        _kill(processes[2])
        output, _ = batch.communicate(timeout=600)
        assert batch.returncode == 0, output.decode()

        # Every row is there: w1's unfinished work went to w0.
        assert sum(t["rows"] for t in tasks()) == N_ROWS
        ids = read_batch(out).ids
        assert ids == [f"g{i}" for i in range(N_ROWS)]
        assert (out / "errors.jsonl").read_text() == ""
    finally:
        for process in reversed(processes):
            _kill(process)

    # Byte for byte the run of one process (no cluster at all).
    local = tmp_path / "local"
    summary = run_batch(manifest, local, sampler=SAMPLER, workers=0, progress=False)
    assert summary.done == N_ROWS
    names = ["run.json", "descriptors.parquet", "errors.jsonl"]
    names += [f"parts/{p.name}" for p in sorted((local / "parts").iterdir())]
    for name in names:
        assert (out / name).read_bytes() == (local / name).read_bytes(), f"{name} differs"
