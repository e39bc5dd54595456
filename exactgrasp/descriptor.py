"""Descriptors: intersection volume over hand volume along every path, and their distances."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.distance import pdist, squareform

from exactgrasp.backends import Backend, get_backend
from exactgrasp.backends.defaults import DEFAULT_BACKEND
from exactgrasp.errors import DescriptorError
from exactgrasp.grasp import Grasp
from exactgrasp.paths.presets import as_sampler
from exactgrasp.paths.sampler import PathSampler
from exactgrasp.progress import progress_bar

DISTANCE_KINDS = ("l2", "l2_diff")


class Descriptor:
    """A grasp descriptor.

    Parameters
    ----------
    values : array_like, shape (n_paths, n_steps)
        Intersection volume / hand volume at each pose (dimensionless, >= 0).
    metadata : dict
        How it was made: ``sampler``, ``backend``, ``backend_params``, ``version``,
        ``hand_hash``, ``object_hash``, ``grasp``, ``hand_volume``, ``seconds``, ...

    Attributes
    ----------
    values : numpy.ndarray, shape (n_paths, n_steps), float64
    metadata : dict
    """

    def __init__(self, values: Any, metadata: dict | None = None):
        values = np.asarray(values, dtype=np.float64)
        if values.ndim != 2:
            raise DescriptorError(
                f"values must have shape (n_paths, n_steps), got {values.shape}."
            )
        if not np.all(np.isfinite(values)):
            raise DescriptorError("values contain NaN or infinite entries.")
        self.values = values
        self.metadata = dict(metadata or {})

    @property
    def shape(self) -> tuple[int, int]:
        """``(n_paths, n_steps)``."""
        return self.values.shape

    @property
    def sampler(self) -> PathSampler | None:
        """The sampler that made it (from the metadata), or None."""
        params = self.metadata.get("sampler")
        return PathSampler.from_params(params) if params else None

    def save(self, path: str | os.PathLike) -> Path:
        """Write ``.npz``: the values and the metadata as JSON text.

        Returns
        -------
        pathlib.Path
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as handle:
            np.savez(
                handle,
                values=self.values,
                metadata=np.array(json.dumps(self.metadata, sort_keys=True)),
            )
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> Descriptor:
        """Read a file written by `save`."""
        path = Path(path)
        if not path.exists():
            raise DescriptorError(f"{path}: no such descriptor file.")
        try:
            with np.load(path, allow_pickle=False) as data:
                values = data["values"]
                metadata = json.loads(str(data["metadata"]))
        except (KeyError, ValueError, OSError) as exc:
            raise DescriptorError(
                f"{path}: not a descriptor file written by Descriptor.save ({exc})."
            ) from exc
        return cls(values, metadata)

    def __repr__(self) -> str:
        backend = self.metadata.get("backend", "?")
        return f"Descriptor({self.shape[0]} paths x {self.shape[1]} steps, backend={backend!r})"


def compute_volumes(
    grasp: Grasp,
    poses: np.ndarray,
    backend: Backend,
    progress: bool | None = None,
    description: str = "poses",
) -> np.ndarray:
    """Backend volumes for (n_paths, n_steps, 4, 4) poses, in chunks of paths for a progress bar.

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2], canonical volume units
    """
    n_paths = poses.shape[0]
    chunk = max(1, n_paths // 20)
    out = np.empty(poses.shape[:-2])
    with progress_bar(
        total=int(np.prod(poses.shape[:-2])), desc=description, enable=progress
    ) as bar:
        for start in range(0, n_paths, chunk):
            block = poses[start : start + chunk]
            out[start : start + chunk] = backend.volumes(grasp, block)
            bar.update(int(np.prod(block.shape[:-2])))
    return out


def compute_descriptor(
    grasp: Grasp,
    sampler: PathSampler | str | dict | None = None,
    backend: Backend | str = DEFAULT_BACKEND,
    progress: bool | None = None,
    **backend_params: Any,
) -> Descriptor:
    """The paper's descriptor of a grasp.

    Parameters
    ----------
    grasp : Grasp
    sampler : PathSampler or str or dict, optional
        Anything `exactgrasp.paths.as_sampler` takes; default: the ``"balanced"`` preset.
    backend : str or Backend
        ``"voxel"`` (default, the paper's estimator) or ``"exact"``.
    progress : bool, optional
        Show a progress bar; default: only when stderr is a terminal.
    **backend_params
        Passed to `get_backend` when ``backend`` is a name.

    Returns
    -------
    Descriptor
        ``values[p, k]`` = volume(hand ∩ object moved to pose k of path p) / volume(hand).
    """
    from exactgrasp.version import __version__

    sampler = as_sampler(sampler)
    backend = get_backend(backend, **backend_params)
    start = time.perf_counter()
    volumes = compute_volumes(grasp, sampler.poses(), backend, progress, f"{backend.name} poses")
    hand_volume = grasp.canonical_hand_volume
    if not np.all(np.isfinite(volumes)) or np.any(volumes < 0):
        bad = int(np.sum(~np.isfinite(volumes) | (volumes < 0)))
        raise DescriptorError(
            f"backend {backend.name!r} returned {bad} invalid (NaN or negative) volumes for "
            f"grasp {grasp.name!r}; this is a bug in the backend, please report it."
        )
    seconds = time.perf_counter() - start
    metadata = {
        "grasp": grasp.name,
        "sampler": sampler.params,
        "backend": backend.name,
        "backend_params": backend.params,
        "version": __version__,
        "hand_hash": grasp.hand_key,
        "object_hash": grasp.object.hash,
        "geometry_hash": grasp.geometry_key,
        "hand_volume_canonical": hand_volume,
        "hand_volume_m3": grasp.hand.volume,
        "frame": grasp.frame.to_dict(),
        "seconds": seconds,
    }
    return Descriptor(volumes / hand_volume, metadata)


def _check_comparable(a: Descriptor, b: Descriptor) -> None:
    if a.shape != b.shape:
        raise DescriptorError(
            f"descriptors of shapes {a.shape} and {b.shape} are not comparable; compute both "
            "with the same PathSampler."
        )
    sa, sb = a.metadata.get("sampler"), b.metadata.get("sampler")
    if sa and sb and sa != sb:
        raise DescriptorError(
            f"descriptors come from different samplers ({sa} vs {sb}); their paths do not "
            "correspond, so they are not comparable."
        )


def _features(d: Descriptor, kind: str) -> np.ndarray:
    if kind == "l2":
        return d.values.ravel()
    if kind == "l2_diff":
        # Change along each path, step to step (the origin is not a sample, so n_steps - 1).
        return np.diff(d.values, axis=1).ravel()
    raise DescriptorError(f"distance kind {kind!r} is unknown; use one of {DISTANCE_KINDS}.")


def distance(a: Descriptor, b: Descriptor, kind: str = "l2") -> float:
    """Distance between two descriptors of the same sampler.

    Parameters
    ----------
    a, b : Descriptor
    kind : {"l2", "l2_diff"}
        ``"l2"``: Euclidean norm of the difference of the values (the paper's main choice).
        ``"l2_diff"``: Euclidean norm of the difference of the step-to-step changes along each
        path.

    Returns
    -------
    float
    """
    _check_comparable(a, b)
    return float(np.linalg.norm(_features(a, kind) - _features(b, kind)))


def pairwise_distances(descriptors: Sequence[Descriptor], kind: str = "l2") -> np.ndarray:
    """All pairwise distances.

    Parameters
    ----------
    descriptors : sequence of Descriptor, length n
    kind : {"l2", "l2_diff"}

    Returns
    -------
    numpy.ndarray, shape (n, n)
        Symmetric, zero diagonal.
    """
    descriptors = list(descriptors)
    for other in descriptors[1:]:
        _check_comparable(descriptors[0], other)
    if not descriptors:
        return np.zeros((0, 0))
    features = np.stack([_features(d, kind) for d in descriptors])
    return squareform(pdist(features, metric="euclidean"))
