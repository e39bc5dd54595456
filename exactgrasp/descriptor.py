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

from exactgrasp.backends import Backend
from exactgrasp.backends.base import repeated_poses
from exactgrasp.backends.defaults import DEFAULT_BACKEND
from exactgrasp.backends.registry import as_backend
from exactgrasp.diagnostics import check_descriptor
from exactgrasp.errors import DescriptorError
from exactgrasp.grasp import Grasp
from exactgrasp.paths.presets import as_sampler
from exactgrasp.paths.sampler import PathSampler
from exactgrasp.progress import progress_bar

DISTANCE_KINDS = ("l2", "l2_diff", "cbrt")


class Descriptor:
    """A grasp descriptor.

    Parameters
    ----------
    values : array_like, shape (n_paths, n_steps)
        Intersection volume / hand volume at each pose (dimensionless, >= 0).
    metadata : dict
        How it was made: ``sampler``, ``backend``, ``backend_params``, ``version``,
        ``hand_hash``, ``object_hash``, ``grasp``, ``hand_volume``, ``seconds`` (wall
        seconds), and the checks of `exactgrasp.diagnostics.check_descriptor`
        (``max_value``, ``volume_ratio``, ``warnings``, ...). Files written before the kernels
        were all compiled ahead of time may also hold ``compile_seconds`` (of ``seconds``,
        those spent compiling kernels); it is kept as read, and nothing uses it.

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
    """Backend volumes for (..., 4, 4) poses, each distinct pose computed once, with a bar.

    Poses equal to rounding (`backends.base.repeated_poses`: the balanced preset repeats a
    quarter of its poses) go to the backend once, all in one
    `Backend.volumes_with_progress` call that feeds the bar; the backend checks them (a
    sampler's poses are rigid by construction).

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2], canonical volume units
    """
    poses = np.asarray(poses, dtype=np.float64)
    flat = poses.reshape(-1, 4, 4)
    first, back = np.unique(repeated_poses(flat), return_inverse=True)
    if len(first) < len(flat):  # the bar counts the poses computed: say why it counts fewer
        description += f" ({len(first):,} distinct of {len(flat):,}: repeats computed once)"
    with progress_bar(total=len(first), desc=description, enable=progress) as bar:
        advance = None if bar.disable else bar.update
        volumes = backend.volumes_with_progress(grasp, flat[first], advance)
    volumes = np.asarray(volumes, dtype=np.float64)
    if volumes.shape != (len(first),):
        raise DescriptorError(
            f"backend {backend.name!r} returned volumes of shape {volumes.shape} for "
            f"{len(first)} poses; this is a bug in the backend, please report it."
        )
    return volumes[back.reshape(-1)].reshape(poses.shape[:-2])


def compute_descriptor(
    grasp: Grasp,
    sampler: PathSampler | str | dict | None = None,
    backend: Backend | str = DEFAULT_BACKEND,
    progress: bool | None = None,
) -> Descriptor:
    """The paper's descriptor of a grasp.

    Parameters
    ----------
    grasp : Grasp
    sampler : PathSampler or str or dict, optional
        Anything `exactgrasp.paths.as_sampler` takes; default: the ``"balanced"`` preset.
    backend : str or Backend
        A registered name with the library defaults (``"voxel"``, the default, the paper's
        estimator; ``"exact"``) or a configured instance, e.g.
        ``ExactBackend(broadphase=None, n_jobs=1)``.
    progress : bool, optional
        Show a progress bar (True) or nothing (False); default: a bar when stderr is a
        terminal, else a plain line at most every 5 s of a long call
        (`exactgrasp.progress.ProgressLog`).

    Returns
    -------
    Descriptor
        ``values[p, k]`` = volume(hand ∩ object moved to pose k of path p) / volume(hand).
    """
    from exactgrasp.version import __version__

    sampler = as_sampler(sampler)
    backend = as_backend(backend)
    start = time.perf_counter()
    volumes = compute_volumes(grasp, sampler.poses(), backend, progress, f"{backend.name} poses")
    # The backend's own union where it has one (the exact backend's), not a second one.
    hand_volume = float(backend.hand_volume(grasp))
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
        "hand_volume_m3": hand_volume / grasp.frame.scale**3,
        "frame": grasp.frame.to_dict(),
        "seconds": seconds,
    }
    values = volumes / hand_volume
    # Warn once about suspicious grasps and record the checks (docs/diagnostics.md).
    metadata.update(check_descriptor(grasp, values, backend, metadata["hand_volume_m3"]))
    return Descriptor(values, metadata)


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
    if kind == "cbrt":
        return np.cbrt(d.values).ravel()
    raise DescriptorError(f"distance kind {kind!r} is unknown; use one of {DISTANCE_KINDS}.")


def distance(a: Descriptor, b: Descriptor, kind: str = "l2") -> float:
    """Distance between two descriptors of the same sampler.

    Parameters
    ----------
    a, b : Descriptor
    kind : {"l2", "l2_diff", "cbrt"}
        ``"l2"``: Euclidean norm of the difference of the values (the paper's main choice).
        ``"l2_diff"``: Euclidean norm of the difference of the step-to-step changes along each
        path. ``"cbrt"``: Euclidean norm of the difference of the values' cube roots, the
        distance the report "What the descriptor tells you" recommends
        (``docs/descriptor-meaning.md``).

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
    kind : {"l2", "l2_diff", "cbrt"}

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
