"""Descriptors computed once: one ``.npz`` per (grasp geometry, backend, parameters, sampler).

The file name is a hash of everything that determines the values, so a re-run, or a run that
was interrupted, picks up what is already there, and a changed setting never reads a stale
file.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from pathlib import Path
from typing import Any

from exactgrasp.backends import Backend
from exactgrasp.backends.registry import shared_backend
from exactgrasp.descriptor import Descriptor, compute_descriptor
from exactgrasp.grasp import Grasp
from exactgrasp.paths.sampler import PathSampler

#: Backend parameters that change how fast, not what, a backend computes: not part of the key.
SPEED_ONLY = frozenset({"n_jobs"})


class DescriptorCache:
    """Compute descriptors through a folder of cached ``.npz`` files.

    Parameters
    ----------
    folder : pathlib.Path
    log : callable, optional
        Receives one line per computed descriptor.

    Attributes
    ----------
    computed, loaded : int
        How many descriptors were computed and read back in this run.
    compute_seconds : dict of str to float
        Per backend, the time it took to compute every distinct descriptor this run used
        (whether computed now or read from the cache): the run's cost from an empty cache.
    """

    def __init__(self, folder: Path, log=None):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.log = log or (lambda line: None)
        self.computed = 0
        self.loaded = 0
        self.compute_seconds: dict[str, float] = {}
        self._used: set[Path] = set()

    def backend(self, name: str | Backend, **params: Any) -> Backend:
        """One backend instance per (name, parameters) in this process
        (`exactgrasp.backends.registry.shared_backend`), so hand grids and object points that
        backends cache per geometry are reused across grasps."""
        return shared_backend(name, **params)

    def path(self, grasp: Grasp, backend: Backend, sampler: PathSampler) -> Path:
        """Where the descriptor of this grasp, backend and sampler lives."""
        params = {k: v for k, v in backend.params.items() if k not in SPEED_ONLY}
        text = json.dumps(
            [grasp.geometry_key, backend.name, params, sampler.params], sort_keys=True
        )
        digest = hashlib.sha256(text.encode()).hexdigest()[:20]
        stem = re.sub(r"[^A-Za-z0-9_.-]+", "-", grasp.name)[:60]
        return self.folder / backend.name / f"{stem}.{digest}.npz"

    def descriptor(
        self, grasp: Grasp, sampler: PathSampler, backend: str | Backend, **params: Any
    ) -> Descriptor:
        """The descriptor, from the cache or computed (and then cached).

        Parameters
        ----------
        grasp : Grasp
        sampler : PathSampler
        backend : str or Backend
        **params
            Backend parameters, with a name only.

        Returns
        -------
        Descriptor
            ``metadata["seconds"]`` is the time it took when it was computed.
        """
        instance = self.backend(backend, **params)
        backend = instance.name
        path = self.path(grasp, instance, sampler)
        if path.exists():
            self.loaded += 1
            descriptor = Descriptor.load(path)
            self._count(path, backend, descriptor)
            return descriptor
        start = time.perf_counter()
        descriptor = compute_descriptor(grasp, sampler, backend=instance, progress=False)
        self.computed += 1
        self._count(path, backend, descriptor)
        self.log(
            f"  {backend:5s} {grasp.name:45s} {sampler.n_poses:6d} poses "
            f"{time.perf_counter() - start:7.2f} s"
        )
        descriptor.save(path)
        return descriptor

    def _count(self, path: Path, backend: str, descriptor: Descriptor) -> None:
        if path not in self._used:
            self._used.add(path)
            seconds = float(descriptor.metadata.get("seconds", 0.0))
            self.compute_seconds[backend] = self.compute_seconds.get(backend, 0.0) + seconds
