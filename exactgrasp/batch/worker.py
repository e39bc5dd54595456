"""The worker side of a batch run: computing rows, and the pools that run parts.

`exactgrasp.batch.run` keeps the run logic (parts, resume, files); this module holds what
executes on a worker process (`compute_rows`, `warm_up`) or in this process (`open_pool`, the
pools).

distributed loads only through `exactgrasp.errors.require`.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import socket
import time
import uuid
import warnings
from collections import deque
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.backends import Backend
from exactgrasp.backends.base import thread_limit
from exactgrasp.backends.registry import shared_backend
from exactgrasp.batch.manifest import ManifestRow
from exactgrasp.batch.threads import THREAD_ENV, limit_threads
from exactgrasp.descriptor import compute_descriptor
from exactgrasp.diagnostics import ignores_third_party_warnings
from exactgrasp.errors import BatchError, require
from exactgrasp.geometry.objects import box
from exactgrasp.grasp import Grasp
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.hand import Hand
from exactgrasp.hands.prepared import LINK_SOLIDS
from exactgrasp.paths.sampler import PathSampler
from exactgrasp.version import __version__

__all__ = [
    "THREAD_ENV",
    "WORKER_CONFIG",
    "cluster_environment",
    "compute_rows",
    "default_workers",
    "open_pool",
    "warm_up",
]

log = logging.getLogger("exactgrasp.batch")

#: Dask settings of the local cluster (its scheduler, nannies and workers). The statistical
#: profiler samples every thread's stack every 10 ms: off, a row costs in a worker what it costs
#: in this process. The event loops' tick (20 ms), the nannies' memory check (100 ms) and the
#: system monitor (500 ms) wake every process of the cluster: at dask's defaults an idle
#: two-worker cluster takes a tenth of a core from the rows, at these a fiftieth
#: (docs/performance.md, "Batches"). A saturation of 1 hands a worker its next task when it
#: finishes one, not one ahead: the last tasks go to whichever worker is free.
WORKER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "500ms",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.scheduler.worker-saturation": 1.0,
}


def cluster_environment() -> dict[str, str]:
    """The environment of a cluster's processes started by hand (``dask scheduler``,
    ``dask worker``): `THREAD_ENV` and `WORKER_CONFIG` as dask reads it from variables.

    Returns
    -------
    dict of str to str
        ``{"OMP_NUM_THREADS": "1", ..., "DASK_DISTRIBUTED__ADMIN__TICK__INTERVAL": "500ms",
        ...}``; ``docs/batch.md`` lists the same exports.
    """
    config = {
        "DASK_" + key.upper().replace(".", "__").replace("-", "_"): str(value)
        for key, value in WORKER_CONFIG.items()
    }
    return {**THREAD_ENV, **config}


# -- on the workers -----------------------------------------------------------------------------


def _worker_backend(spec: str | Backend) -> Backend:
    # A name: one instance per worker process. An instance: the copy a task brought, which
    # shares the caches of the worker's earlier copies (`Backend.__setstate__`). Either way its
    # hand grids, object points and intersectors serve every later grasp in this process.
    return shared_backend(spec)


def _load_grasp(row: ManifestRow, base_dir: Path, overrides: dict) -> Grasp:
    if row.problem is not None:
        raise BatchError(row.problem)
    if isinstance(row.grasp, str):
        path = Path(row.grasp)
        return Grasp.from_file(path if path.is_absolute() else base_dir / path, **overrides)
    data = {"name": str(row.id), **row.grasp}
    source = f"inline grasp of id {row.id!r}"
    return Grasp.from_dict(data, base_dir=base_dir, source=source, **overrides)


@ignores_third_party_warnings
def compute_rows(
    rows: list[ManifestRow],
    base_dir: str,
    backend: str | Backend,
    sampler_params: dict,
    overrides: dict | None = None,
    expected: list | None = None,
    single_thread: bool = True,
) -> dict[str, Any]:
    """Descriptors of some manifest rows; the task run on a worker.

    Parameters
    ----------
    rows : list of ManifestRow
    base_dir : str
        Folder relative grasp paths are resolved against (the manifest's).
    backend : str or Backend
        A registered name (the library defaults; one instance per worker process) or a
        configured instance (used as it is).
    sampler_params : dict
        `PathSampler.params`.
    overrides : dict, optional
        `Grasp.from_file` overrides of what the grasp files say (``units``, ``repair``,
        ``on_limit``).
    expected : [str, dict], optional
        The exactgrasp version and backend parameters of the run; rows fail when this worker's
        differ.
    single_thread : bool
        Compute each row on one thread, BLAS and manifold3d included
        (`exactgrasp.batch.threads`): a worker has one thread per core it may use. False
        leaves backends given ``n_jobs=None`` every core.

    Returns
    -------
    dict
        ``results``: one dict per row (``id``, ``row``, ``values`` shape (n_paths * n_steps,)
        or None, ``metadata`` JSON text or None, ``error``, ``message``); ``seconds``,
        ``cpu_seconds`` (this process's, every thread, a dask worker's own included) and
        ``thread_cpu_seconds`` (the calling thread's): their ratio is the threads' worth of
        CPU the rows used, which the machine's load hardly changes; ``worker``;
        ``links_prepared``: hand links this call made solids of
        (`exactgrasp.hands.prepared`; 0 when every hand was seen before in this process).
    """
    if single_thread:
        limit_threads()
    start, cpu_start, thread_start = time.perf_counter(), time.process_time(), time.thread_time()
    builds = LINK_SOLIDS.builds
    sampler = PathSampler.from_params(sampler_params)
    engine = _worker_backend(backend)
    mismatch = None
    have = json.loads(json.dumps([__version__, engine.params]))
    if expected is not None and have != expected:
        # Workers importing other code than the client would mix results under one run.json.
        mismatch = (
            f"this worker runs exactgrasp {have[0]} with {engine.name} parameters {have[1]}, "
            f"the run expects {expected[0]} with {expected[1]}; install the same exactgrasp "
            "on the client and every worker"
        )
    results = []
    for row in rows:
        result = {"id": row.id, "row": row.index, "values": None, "metadata": None}
        try:
            if mismatch:
                raise BatchError(mismatch)
            grasp = _load_grasp(row, Path(base_dir), overrides or {})
            with thread_limit(1 if single_thread else None):
                descriptor = compute_descriptor(grasp, sampler, engine, progress=False)
            # Timings differ run to run; the rest of the metadata is a function of the input.
            metadata = {k: v for k, v in descriptor.metadata.items() if k != "seconds"}
            result["values"] = descriptor.values.ravel()
            result["metadata"] = json.dumps(metadata, sort_keys=True)
            result.update(error=None, message=None)
        except Exception as exc:  # one bad grasp is reported and the batch goes on
            result.update(error=type(exc).__name__, message=str(exc) or repr(exc))
        results.append(result)
    return {
        "results": results,
        "seconds": time.perf_counter() - start,
        "cpu_seconds": time.process_time() - cpu_start,
        "thread_cpu_seconds": time.thread_time() - thread_start,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        "links_prepared": LINK_SOLIDS.builds - builds,
    }


def warm_up(backend: str | Backend) -> str:
    """Ready this worker process before any row: threads limited (`limit_threads`), MuJoCo
    imported, the backend built, its compiled kernels loaded.

    The kernels load by computing one pose of a small made-up grasp (a box hand, a box
    object), whose hand is no dataset's: the hands the rows use are still prepared, and
    counted, by the rows.

    Parameters
    ----------
    backend : str or Backend

    Returns
    -------
    str
        This worker, ``host:pid``.
    """
    limit_threads()
    with contextlib.suppress(ImportError):  # without it, the rows that need it say so
        import mujoco  # noqa: F401  (what compiles MJCF and URDF hands: 0.1-0.2 s to import)
    engine = _worker_backend(backend)
    hand = Hand.from_meshes([box((0.1, 0.1, 0.04))], frame=HandFrame.identity())
    pose = np.eye(4)
    pose[2, 3] = 0.034  # the object's bottom 1 mm into the hand's top
    grasp = Grasp(hand, box((0.03, 0.03, 0.03)), pose, name="warm-up")
    # What the diagnostics would say of a made-up grasp is nobody's concern.
    with thread_limit(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        compute_descriptor(grasp, PathSampler(1, 1, 1, n_steps=1), engine, progress=False)
    return f"{socket.gethostname()}:{os.getpid()}"


# -- pools: in this process, or on dask.distributed --------------------------------------------


class _SerialPool:
    """Tasks run here, one at a time, when asked for results (for debugging and tiny runs)."""

    workers = 0
    window = 1

    def __init__(self):
        self._queue: deque = deque()

    def warm(self, backend: str | Backend) -> None:
        """Nothing to ready: the rows run here."""

    def submit(self, chunk: tuple, args: tuple) -> None:
        self._queue.append((chunk, args))

    @property
    def in_flight(self) -> int:
        return len(self._queue)

    def completed(self):
        while self._queue:
            chunk, args = self._queue.popleft()
            try:
                yield chunk, compute_rows(*args, single_thread=False), None
            except Exception as exc:
                yield chunk, None, exc


class _DaskPool:
    """Tasks on a dask.distributed cluster, a bounded number in flight."""

    def __init__(self, client: Any):
        from distributed import as_completed

        self.client = client
        self.workers = max(sum(client.nthreads().values()), 1)
        # Enough queued work to keep every worker busy while results come back.
        self.window = 2 * self.workers + 2
        self._futures = as_completed()
        self._chunks: dict[str, tuple] = {}
        self._token = uuid.uuid4().hex[:8]
        self._submitted = 0

    def submit(self, chunk: tuple, args: tuple) -> None:
        part, rows = chunk
        # Unique per submission: a part has several tasks, and a failed task comes back as
        # single rows.
        self._submitted += 1
        first, last = rows[0].index, rows[-1].index
        key = f"exactgrasp-batch-{self._token}-{self._submitted}-part{part}-rows{first}-{last}"
        future = self.client.submit(compute_rows, *args, key=key, pure=False, retries=0)
        self._chunks[future.key] = chunk
        self._futures.add(future)

    @property
    def in_flight(self) -> int:
        return len(self._chunks)

    def warm(self, backend: str | Backend) -> None:
        """`warm_up` on every worker there now, all at once, before any row is handed out:
        a worker still importing would otherwise sit on the tasks given to it."""
        workers = list(self.client.scheduler_info()["workers"])
        futures = [
            self.client.submit(
                warm_up, backend, key=f"exactgrasp-warm-{self._token}-{n}", pure=False,
                workers=[address], allow_other_workers=False,
            )
            for n, address in enumerate(workers)
        ]  # fmt: skip
        for future in futures:
            try:
                future.result()
            except Exception as exc:  # the rows will say what is wrong, row by row
                log.warning("warming a worker up failed: %s", exc)

    def completed(self):
        for future in self._futures:
            chunk = self._chunks.pop(future.key)
            try:
                outcome, error = future.result(), None
            except Exception as exc:
                outcome, error = None, exc
            future.release()
            yield chunk, outcome, error


@contextlib.contextmanager
def open_pool(workers: int | None, scheduler: str | None) -> Iterator[Any]:
    """The pool for ``workers`` / ``scheduler``, closed (cluster included) on the way out."""
    if scheduler is None and workers == 0:
        yield _SerialPool()
        return
    require("distributed", "exactgrasp batch", "distributed", "batch")
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        with Client(scheduler) as client:
            yield _DaskPool(client)
        return
    # The nannies hand this process's dask settings to the worker processes they start.
    with dask.config.set(WORKER_CONFIG):
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            # Any free port: a fixed one (8787) clashes with other clusters on the machine.
            dashboard_address=":0",
            silence_logs=logging.ERROR,
            env=THREAD_ENV,
        )
    with cluster, Client(cluster) as client:
        yield _DaskPool(client)


def default_workers() -> int:
    """The cores this process may use (at least 1)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1
