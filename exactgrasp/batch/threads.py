"""Worker processes that use exactly their share of the cores, whatever library starts threads.

A batch worker runs one task per thread it was given, and each task computes on one thread;
every library that keeps a thread pool of its own must then use one thread per task too:

* the exact and voxel kernels (Cython, compiled with the package): Python threads, as many as
  `exactgrasp.backends.base.thread_limit` allows around each row;
* BLAS and OpenMP (numpy, scipy): `OMP_NUM_THREADS`, `OPENBLAS_NUM_THREADS`,
  `MKL_NUM_THREADS`, read when those libraries load, so set before the worker starts
  (`THREAD_ENV`, given to the local cluster's workers; see ``docs/batch.md`` for ``dask
  worker``);
* manifold3d (the hand's and the object's booleans): TBB built into the wheel, which reads no
  environment variable; it sizes its pool from the CPUs the process's main thread may use at
  its first parallel call and keeps that size. `limit_threads` narrows the CPUs of that thread
  and of the calling one to one CPU for that call and restores them, so TBB starts no helper
  threads and every boolean runs on the thread that asked for it, on any CPU the OS picks;
* coal (the exact backend's broad phase): no threads of its own (its library links neither
  OpenMP nor TBB).

``tests/test_batch_scaling.py`` measures a worker's CPU time over its wall time against the
limit.
"""

from __future__ import annotations

import os
import threading

from exactgrasp.geometry.manifold import start_thread_pool

__all__ = ["THREAD_ENV", "limit_threads", "threads_limited"]

#: Set in local worker processes before they start (and by `limit_threads` for libraries not
#: loaded yet): one thread per task for OpenMP and BLAS.
THREAD_ENV = {
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
}

_LOCK = threading.Lock()
_LIMITED: list[bool] = []


def threads_limited() -> bool:
    """True once `limit_threads` has sized manifold3d's pool in this process."""
    return bool(_LIMITED)


def limit_threads() -> bool:
    """Size manifold3d's (TBB's) pool to one thread per calling thread, once per process.

    Call it before this process's first boolean. Later calls do nothing.

    Returns
    -------
    bool
        True when the pool was sized here; False when it had been already, or when this
        platform cannot narrow a thread's CPUs (not Linux; the pool then has every core).
    """
    with _LOCK:
        if _LIMITED:
            return False
        _LIMITED.append(True)
        for name, value in THREAD_ENV.items():
            os.environ.setdefault(name, value)
        if not hasattr(os, "sched_setaffinity"):
            return False
        # TBB reads the CPUs of the process's main thread (its id is the process's), and a
        # dask worker calls from a thread of its own: narrow both for the call.
        threads = sorted({0, os.getpid()})
        saved = [(thread, os.sched_getaffinity(thread)) for thread in threads]
        one = {min(saved[0][1])}
        try:
            for thread, _ in saved:
                os.sched_setaffinity(thread, one)
            start_thread_pool()
        finally:
            for thread, cpus in saved:
                os.sched_setaffinity(thread, cpus)
        return True
