"""`run_batch`: the descriptor of every grasp in a manifest, resumable, on many cores.

Work is cut into parts of ``part_size`` consecutive manifest rows (the files, and the unit of
resuming), and parts into tasks sized from the rows left and the workers (`task_chunks`), run
on a dask.distributed cluster (a local cluster of single-threaded processes by default, or an
existing scheduler); the workers only compute and send results back, and this process writes
every file, so workers need no shared file system and each part is renamed into place whole.
A resume skips the parts already there. See ``docs/batch.md`` for the file layout and the
choices made; the ``exactgrasp batch`` command is `exactgrasp.cli.batch`.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from exactgrasp.backends import Backend, as_backend
from exactgrasp.backends.defaults import DEFAULT_BACKEND
from exactgrasp.batch.manifest import DEFAULT_PART_SIZE, Manifest, ManifestRow, read_manifest
from exactgrasp.batch.store import (
    DESCRIPTORS_FILE,
    ERRORS_FILE,
    FORMAT,
    TIMINGS_FILE,
    check_run_record,
    consolidate,
    part_path,
    read_part,
    remove_temp_files,
    run_lock,
    write_part,
)
from exactgrasp.batch.worker import default_workers, open_pool
from exactgrasp.diagnostics import ignores_third_party_warnings
from exactgrasp.errors import BatchError, Fix
from exactgrasp.geometry.intake import UNITS
from exactgrasp.given import given
from exactgrasp.paths.presets import as_sampler
from exactgrasp.paths.sampler import PathSampler
from exactgrasp.progress import progress_bar
from exactgrasp.version import __version__

__all__ = ["DEFAULT_PART_SIZE", "TASK_SHARES", "BatchSummary", "run_batch", "task_chunks"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchSummary:
    """What a batch run did.

    Attributes
    ----------
    out : pathlib.Path
        The output folder.
    n_rows : int
        Rows in the manifest.
    done, failed : int
        Rows with a descriptor / rows in ``errors.jsonl``, over this run and earlier ones.
    computed, skipped : int
        Rows computed by this run / found already computed by an earlier run.
    seconds : float
        Wall time of this run, cluster start included (s).
    compute_seconds : float
        Wall time from the first task submitted to the last part written (s), the workers
        started and warmed up (`exactgrasp.batch.worker.warm_up`) before it.
    workers : int
        Worker processes (threads on an existing cluster); 0 when run in this process.
    """

    out: Path
    n_rows: int
    done: int
    failed: int
    computed: int
    skipped: int
    seconds: float
    compute_seconds: float
    workers: int

    @property
    def ok(self) -> bool:
        """True when no row failed."""
        return self.failed == 0

    @property
    def exit_status(self) -> int:
        """0 when every row has a descriptor, 1 when any failed."""
        return 0 if self.ok else 1

    def text(self) -> str:
        """A one-paragraph report for the terminal."""
        rate = 60.0 * self.computed / self.compute_seconds if self.compute_seconds > 0 else 0.0
        failed = (
            f"{self.failed} failed (see {self.out / ERRORS_FILE})" if self.failed else "0 failed"
        )
        return (
            f"{self.n_rows} grasps: {self.done} done, {failed}; {self.computed} computed now, "
            f"{self.skipped} already done; {self.seconds:.1f} s in all, {rate:.1f} grasps/min "
            f"on {self.workers} worker(s) -> {self.out / DESCRIPTORS_FILE}"
        )


# -- the run ------------------------------------------------------------------------------------


def _failure(row: ManifestRow, exc: BaseException) -> dict:
    # The whole task died (a worker crashed or was lost), not the grasp's computation.
    message = f"the worker computing this grasp was lost: {exc}"
    return {"id": row.id, "row": row.index, "values": None, "metadata": None,
            "error": type(exc).__name__, "message": message}  # fmt: skip


def _run_params(manifest: Manifest, engine: Backend, sampler: PathSampler, **extra) -> dict:
    params = {
        "format": FORMAT,
        "exactgrasp_version": __version__,
        "backend": engine.name,
        "backend_params": engine.params,
        "sampler": sampler.params,
        "n_paths": sampler.n_paths,
        "n_steps": sampler.n_steps,
        "manifest_sha256": manifest.sha256,
        "n_rows": len(manifest.rows),
        **extra,
    }
    # Through JSON and back, so that it compares equal to the run.json read on a resume.
    return json.loads(json.dumps(params))


@ignores_third_party_warnings
def _refuse_unguarded_script() -> None:
    """Refuse a call made while a spawned worker re-runs the calling script: its top level
    lacks the ``__main__`` guard, and the call would otherwise start a cluster inside each
    worker, which fails with a message about a folder in use and a nanny."""
    frame = sys._getframe(2)
    while frame is not None:
        if frame.f_globals.get("__name__") == "__mp_main__":
            script = frame.f_globals.get("__file__", "the script")
            raise BatchError(
                f"run_batch was called while a worker process imported {script}: run_batch "
                "starts worker processes, which import the script that calls it, so its top "
                'level must be guarded: put the call under `if __name__ == "__main__":` '
                "(see docs/batch.md)."
            )
        frame = frame.f_back


def run_batch(
    manifest: str | os.PathLike,
    out: str | os.PathLike,
    backend: str | Backend = DEFAULT_BACKEND,
    sampler: PathSampler | str | dict | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool | None = None,
    part_size: int = DEFAULT_PART_SIZE,
    on_limit: str | None = None,
    retry_failed: bool = False,
    units: str | None = None,
    repair: bool | None = None,
) -> BatchSummary:
    """Compute the descriptor of every grasp in a manifest into a folder; resume if killed.

    Parameters
    ----------
    manifest : path-like
        ``.jsonl`` or ``.parquet``; rows ``{"id": ..., "grasp": path or inline grasp}``.
    out : path-like
        Output folder (created). Running again with the same arguments finishes what is left.
    backend : str or Backend
        A registered name with the library defaults (``"voxel"``, the default
        `backends.defaults.DEFAULT_BACKEND`; ``"exact"``; ...) or a configured instance, e.g.
        ``ExactBackend(broadphase=None)``: a copy travels to each task (it must pickle), and
        the copies in one worker process share their caches (`Backend.__setstate__`).
    sampler : PathSampler or str or dict, optional
        Anything `exactgrasp.paths.as_sampler` takes; default: the ``"balanced"`` preset.
    workers : int, optional
        Worker processes of the local cluster (default: the cores this process may use);
        0 computes in this process without a cluster. Not allowed with ``scheduler``.
    scheduler : str, optional
        Address of a running dask scheduler (``tcp://host:8786``); its workers must be able
        to import exactgrasp and read the grasp files.
    progress : bool, optional
        Progress bar (True) or nothing (False); default: a bar on a terminal, else a plain
        line at most every 5 s of a long run (`exactgrasp.progress.ProgressLog`).
    part_size : int
        Manifest rows per part (an output file, the unit of resuming); the work is cut into
        tasks sized from the rows left and the workers (`task_chunks`).
    on_limit : {"error", "clip"}, optional
        Overrides what grasp files say about joint values outside the limits.
    retry_failed : bool
        Compute again the parts that hold failed rows.
    units : {"m", "cm", "mm", "inch", "in"}, optional
        Overrides the grasp files' ``object_units``.
    repair : bool, optional
        Overrides the grasp files' ``object_repair``.

    Returns
    -------
    BatchSummary
        ``exit_status`` is 1 when any row failed.

    Raises
    ------
    BatchError
        A bad manifest (before any work), or an output folder holding another run.
    SamplerError
        A ``sampler`` that `exactgrasp.paths.as_sampler` does not take.
    """
    started = time.perf_counter()
    _refuse_unguarded_script()
    if scheduler is not None and workers is not None:
        raise BatchError(
            Fix("workers", None, shown=""),
            " sets up a local cluster; with ",
            Fix("scheduler", shown=""),
            " ",
            Fix("workers", None, "pass", python="use its workers"),
            ".",
        )
    for name, value, low in (("workers", workers, 0), ("part_size", part_size, 1)):
        if value is not None and (not isinstance(value, int | np.integer) or value < low):
            raise BatchError(Fix(name), f" must be an integer >= {low}, got {value!r}.")
    if on_limit not in (None, "error", "clip"):
        raise BatchError(f"on_limit must be 'error' or 'clip', got {on_limit!r}.")
    if units is not None and units not in UNITS:
        raise BatchError(f"units must be one of {sorted(UNITS)}, got {units!r}.")
    if repair not in (None, True, False):
        raise BatchError(f"repair must be True, False or None, got {repair!r}.")
    overrides = given({"units": units, "repair": repair, "on_limit": on_limit})
    sampler = as_sampler(sampler)
    engine = as_backend(backend)
    # A name travels as it is and each worker builds its own; an instance travels as a copy.
    spec = backend if isinstance(backend, str) else engine
    manifest = read_manifest(manifest)
    params = _run_params(
        manifest, engine, sampler, part_size=part_size, **{"on_limit": None, **overrides}
    )
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    n_parts = -(-len(manifest.rows) // part_size)
    n_values = sampler.n_paths * sampler.n_steps
    with run_lock(out):
        check_run_record(out, params)
        remove_temp_files(out)
        parts = [manifest.rows[p * part_size : (p + 1) * part_size] for p in range(n_parts)]
        present = _existing_parts(out, parts, n_values, retry_failed)
        skipped = sum(len(parts[p]) for p in present)
        todo = {p: rows for p, rows in enumerate(parts) if p not in present}
        n_workers, compute_seconds = 0, 0.0
        if todo:
            if workers is None and scheduler is None:
                workers = default_workers()
            with open_pool(workers, scheduler) as pool:
                pool.warm(spec)
                n_workers, compute_start = pool.workers, time.perf_counter()
                expected = [params["exactgrasp_version"], params["backend_params"]]
                task = (str(manifest.base_dir), spec, sampler.params, overrides, expected)
                _compute(pool, todo, task, out, n_values, len(manifest.rows), skipped, progress)
                compute_seconds = time.perf_counter() - compute_start
        done, failed = consolidate(out, n_parts, params)
    summary = BatchSummary(
        out=out,
        n_rows=len(manifest.rows),
        done=done,
        failed=failed,
        computed=len(manifest.rows) - skipped,
        skipped=skipped,
        seconds=time.perf_counter() - started,
        compute_seconds=compute_seconds,
        workers=n_workers,
    )
    with open(out / TIMINGS_FILE, "a") as handle:
        record = {k: v for k, v in summary.__dict__.items() if k != "out"}
        handle.write(json.dumps({"run": record}) + "\n")
    return summary


def _existing_parts(out: Path, parts: list, n_values: int, retry_failed: bool) -> set[int]:
    """The parts a previous run completed; parts that are not valid are removed."""
    present = set()
    for part, rows in enumerate(parts):
        table = read_part(out, part, rows, n_values)
        path = part_path(out, part)
        if table is None and path.exists():
            log.warning("%s is not a valid part of this run; computing it again", path)
        retry = table is not None and retry_failed and table.column("error").null_count < len(rows)
        if table is None or retry:
            path.unlink(missing_ok=True)
        else:
            present.add(part)
    return present


#: A task takes at most 1/TASK_SHARES of a worker's share of the rows left: tasks shrink as the
#: run ends, so the last ones are single rows and no worker waits long on another.
TASK_SHARES = 3


def task_chunks(todo: dict[int, list], workers: int) -> list[tuple[int, list]]:
    """Cut the parts' rows into tasks sized from the rows left and the workers.

    A task holds ``ceil(left / (TASK_SHARES * workers))`` consecutive rows of one part (one
    at least), ``left`` being the rows not yet given to a task: large tasks first, while
    there is much to share, then smaller ones, so that workers finish together. Parts (the
    files and the unit of resuming) do not change: a part is written when all its tasks are in.

    Parameters
    ----------
    todo : dict of int to list of ManifestRow
        Part number -> its rows, in part order.
    workers : int
        Tasks that run at once (0 or 1: one task per part).

    Returns
    -------
    list of (int, list of ManifestRow)
        (part, rows) per task, in manifest order.
    """
    if workers <= 1:
        return list(todo.items())
    left = sum(len(rows) for rows in todo.values())
    chunks = []
    for part, rows in todo.items():
        start = 0
        while start < len(rows):
            size = max(1, -(-left // (TASK_SHARES * workers)))
            chunks.append((part, rows[start : start + size]))
            left -= len(chunks[-1][1])
            start += size
    return chunks


def _compute(pool, todo: dict, task: tuple, out: Path, n_values, n_rows, skipped, progress):
    """Run the parts in ``todo`` (part -> rows) through ``pool`` as `task_chunks`; write each
    part when all its rows are in, and each task's wall and CPU seconds to the timings file."""
    queue = deque(task_chunks(todo, pool.workers))
    collected: dict[int, dict[int, dict]] = {p: {} for p in todo}
    with (
        progress_bar(n_rows, "grasps", progress) as bar,
        open(out / TIMINGS_FILE, "a") as timings,
    ):
        bar.update(skipped)

        def fill():
            while queue and pool.in_flight < pool.window:
                part, rows = queue.popleft()
                pool.submit((part, rows), (rows, *task))

        fill()
        for (part, rows), outcome, error in pool.completed():
            if error is not None and len(rows) > 1:
                # Find the grasp that kills its worker: run the task's rows one by one.
                log.warning("a task of part %d failed (%s); retrying row by row", part, error)
                queue.extendleft((part, [row]) for row in reversed(rows))
            else:
                for result in [_failure(rows[0], error)] if error else outcome["results"]:
                    collected[part][result["row"]] = result
                if outcome:
                    line = {"part": part, "first_row": rows[0].index, "rows": len(rows)}
                    keys = (
                        "seconds",
                        "cpu_seconds",
                        "thread_cpu_seconds",
                        "worker",
                        "links_prepared",
                    )
                    line.update((key, outcome.get(key)) for key in keys)
                    timings.write(json.dumps(line) + "\n")
                    timings.flush()
                bar.update(len(rows))
                if len(collected[part]) == len(todo[part]):
                    got = collected.pop(part)
                    write_part(out, part, [got[row.index] for row in todo[part]], n_values)
            fill()
    if collected:
        raise BatchError(f"parts {sorted(collected)} were not completed; run again to resume.")
