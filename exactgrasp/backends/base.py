"""The interface every intersection backend implements, and what backends share: the
rigid-pose check, poses equal to rounding (`repeated_poses`) and the threads that
``n_jobs=None`` means (`default_threads`, `thread_limit`).
"""

from __future__ import annotations

import abc
import contextlib
import json
import os
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from exactgrasp.backends import defaults
from exactgrasp.backends.params import Param
from exactgrasp.cache import LRUCache
from exactgrasp.errors import BackendError
from exactgrasp.geometry.se3 import rigid_defect, rigid_defects

if TYPE_CHECKING:
    from exactgrasp.grasp import Grasp


#: Tolerance of the rigid-motion check of `check_poses`: ``R^T R = I``, ``det R = 1`` and the
#: last row ``0 0 0 1`` must hold to this; products of sampled rotations stay within 1e-14.
RIGID_ATOL = 1e-9


def check_poses(poses: np.ndarray, name: str = "poses") -> np.ndarray:
    """Validate an array of rigid poses.

    Parameters
    ----------
    poses : array_like, shape (..., 4, 4)
        Homogeneous rigid transforms acting on the object in the canonical frame: rotation
        part orthonormal with determinant +1 and last row ``0 0 0 1``, each to `RIGID_ATOL`.
    name : str
        What the caller calls the argument, for messages.

    Returns
    -------
    numpy.ndarray, shape (..., 4, 4), float64
        The same poses as a C-contiguous float64 array.

    Raises
    ------
    BackendError
        For a wrong shape, a non-finite entry, or a pose that is not a rigid motion (a
        reflection, a scale, a shear, a projective last row); the message names the first
        such pose by its index.
    """
    arr = np.ascontiguousarray(poses, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (4, 4):
        raise BackendError(
            f"{name} must have shape (..., 4, 4), got {arr.shape}; "
            "pass PathSampler.poses() or a stack of 4x4 homogeneous matrices."
        )
    finite = np.isfinite(arr).all(axis=(-2, -1))
    if not finite.all():
        raise BackendError(
            f"{_label(name, _first(~finite))} contains NaN or infinite entries; pass finite 4x4 "
            "matrices."
        )
    orthonormality, determinant, last_row = rigid_defects(arr)
    # The first pose failing the first check that any fails: the same order as `rigid_defect`,
    # which words it.
    for bad in (
        last_row > RIGID_ATOL,
        determinant < 0,
        orthonormality > RIGID_ATOL,
        np.abs(determinant - 1.0) > RIGID_ATOL,
    ):
        if bad.any():
            index = _first(bad)
            raise BackendError(
                f"{_label(name, index)} is not a rigid motion: "
                f"{rigid_defect(arr[index], RIGID_ATOL)}. Backends move the "
                f"object rigidly; pass rotations (det +1, orthonormal to {RIGID_ATOL:g}) with a "
                "translation and last row 0 0 0 1, and scale meshes with units=..., not poses."
            )
    return arr


def _first(mask: np.ndarray) -> tuple[int, ...]:
    """Index of the first True entry of `mask` (as a tuple, for messages and indexing)."""
    return tuple(int(i) for i in np.unravel_index(int(np.argmax(mask)), mask.shape))


def _label(name: str, index: tuple[int, ...]) -> str:
    """``poses[3]`` for pose 3 of a stack, ``poses`` for a single pose."""
    return f"{name}[{', '.join(map(str, index))}]" if index else name


#: Poses whose matrices differ by at most this many units in the last place of their largest
#: entry are one pose (see `repeated_poses`).
SAME_POSE_ULPS = 16
#: `repeated_poses` first groups poses on a grid of this many steps per unit, far coarser than
#: `SAME_POSE_ULPS` (a pair split by a grid line is merely computed twice).
POSE_GRID = 2.0**36


def repeated_poses(poses: np.ndarray) -> np.ndarray:
    """For each pose, the index of the first pose equal to it to rounding.

    Two poses are equal to rounding when no entry of their matrices differs by more than
    `SAME_POSE_ULPS` units in the last place of the larger one's largest entry (about 4e-15
    for a rotation and a translation of length up to 1). Moving the object's vertices with
    either pose rounds them by more than the two poses differ, so their exact volumes differ by
    no more than the rounding the kernel already makes. Such repeats are common: a rotation
    by ``a`` about ``w`` is a rotation by ``-a`` about ``-w``, and the balanced preset's four
    axes include both poles, so 1,080 of its 4,266 poses repeat another one to rounding.

    Parameters
    ----------
    poses : numpy.ndarray, shape (n, 4, 4)

    Returns
    -------
    numpy.ndarray, shape (n,), int64
        ``rep[i] <= i``; ``rep[i] == i`` for the first pose of each group.
    """
    n = len(poses)
    rows = poses[:, :3, :].reshape(n, 12)
    # Group on a grid far coarser than the tolerance, then keep only true neighbours.
    _, first, inv = np.unique(
        np.round(rows * POSE_GRID), axis=0, return_index=True, return_inverse=True
    )
    rep = first[inv.reshape(-1)]
    scale = np.maximum(np.abs(rows).max(1), np.abs(rows[rep]).max(1))
    tol = SAME_POSE_ULPS * np.spacing(np.maximum(scale, 1.0))
    same = np.abs(rows - rows[rep]).max(1) <= tol
    return np.where(same, rep, np.arange(n)).astype(np.int64)


def repeat_error(poses: np.ndarray, computed: np.ndarray, area: float, size: float):
    """How far the volume at each pose may be from that of the pose equal to it to rounding
    (`repeated_poses`) whose volume it takes: both surfaces' area times the farthest the two
    poses place a vertex apart; 0 where the two are the same bits.

    Parameters
    ----------
    poses, computed : numpy.ndarray, shape (n, 4, 4)
        Each pose and the pose whose volume it takes.
    area : float
        Both surfaces' areas, summed (squared length units).
    size : float
        Bound on every coordinate of the moved mesh, in its own frame.

    Returns
    -------
    numpy.ndarray, shape (n,)
        Cubed length units.
    """
    diff = np.abs(poses[:, :3, :] - computed[:, :3, :]).max(axis=(1, 2))
    # |ΔR x + Δt| <= 3 max|entry| (|x|_inf + 1) per coordinate, times √3 for a length.
    return area * (3.0 * 3**0.5) * diff * (size + 1.0)


#: Threads ``n_jobs=None`` means in the current context (None: every core); `thread_limit`
#: sets it.
_THREADS: ContextVar[int | None] = ContextVar("exactgrasp_threads", default=None)


def default_threads() -> int:
    """Threads a backend given ``n_jobs=None`` runs: the `thread_limit` in force, else every
    core (``os.cpu_count()``)."""
    limit = _THREADS.get()
    return limit if limit is not None else (os.cpu_count() or 1)


@contextlib.contextmanager
def thread_limit(threads: int | None) -> Iterator[None]:
    """Within the block (this thread, this context), ``n_jobs=None`` means ``threads``.

    A batch worker sets 1: one worker per core already fills the machine. None: every core.
    """
    token = _THREADS.set(None if threads is None else max(1, int(threads)))
    try:
        yield
    finally:
        _THREADS.reset(token)


def resolve_jobs(n_jobs: int | None) -> int:
    """Threads for an ``n_jobs`` option: None -> `default_threads`, -1 -> every core
    (``os.cpu_count()``), else ``n_jobs``."""
    if n_jobs is None:
        return default_threads()
    if n_jobs == -1:
        return os.cpu_count() or 1
    return int(n_jobs)


#: The caches of the backends copied into this process (`Backend.__setstate__`), by class and
#: parameters.
_COPIED_CACHES = LRUCache(defaults.SHARED_CACHE_SIZE)

#: Pieces a backend without a progress hook of its own computes the poses in when a caller
#: follows its progress (`Backend.volumes_with_progress`).
PROGRESS_PIECES = 20


class Backend(abc.ABC):
    """An intersection-volume backend.

    A backend sees only validated geometry (through a `Grasp`) and an array of poses; it knows
    nothing of files, samplers or reports.

    Subclasses take every parameter in the constructor, declare what each may be in
    `parameter_constraints` and check them there with
    `exactgrasp.backends.params.validate_parameters`, and expose them through `params` so that
    descriptors can record how they were made (``type(b)(**b.params)`` rebuilds a backend).
    ``exactgrasp.backends.testing.check_backend`` checks an implementation against this
    contract.
    """

    #: Registry name, e.g. ``"voxel"``.
    name: str = ""
    #: Relative accuracy the backend claims for a volume (None: an estimate, no bound claimed).
    volume_rtol: ClassVar[float | None] = None
    #: What each constructor parameter may be: name -> `Param`.
    parameter_constraints: ClassVar[dict[str, Param]] = {}

    @property
    @abc.abstractmethod
    def params(self) -> dict[str, Any]:
        """Parameters that determine the result (JSON-serialisable)."""

    @abc.abstractmethod
    def volumes(self, grasp: Grasp, poses: np.ndarray) -> np.ndarray:
        """Intersection volume of the hand and the moved object for each pose.

        Parameters
        ----------
        grasp : Grasp
            Hand, object and object pose. The backend uses its canonical-frame geometry
            (`Grasp.canonical_hand_links`, `Grasp.canonical_object_bodies`).
        poses : numpy.ndarray, shape (..., 4, 4)
            Rigid transforms applied to the object in the canonical frame, about the frame's
            origin: a vertex ``x`` of the object moves to ``R @ x + t``.

        Returns
        -------
        numpy.ndarray, shape poses.shape[:-2], float64
            Volume of hand ∩ moved object in canonical units (cubed canonical lengths).
        """

    def volumes_with_progress(
        self, grasp: Grasp, poses: np.ndarray, advance: Callable[[int], Any] | None = None
    ) -> np.ndarray:
        """`volumes`, calling ``advance(k)`` (in the calling thread) as ``k`` more poses are
        done.

        This default computes the poses in `PROGRESS_PIECES` pieces along the first axis when
        ``advance`` is given, in one call otherwise; a backend that can report progress from
        inside one call overrides it.

        Parameters
        ----------
        grasp : Grasp
        poses : numpy.ndarray, shape (n, ..., 4, 4)
        advance : callable, optional
            Called with the number of poses finished since the last call.

        Returns
        -------
        numpy.ndarray, shape poses.shape[:-2], float64
        """
        if advance is None or poses.ndim < 3 or len(poses) <= 1:
            out = self.volumes(grasp, poses)
            if advance is not None:
                advance(int(np.prod(poses.shape[:-2])))
            return out
        step = -(-len(poses) // PROGRESS_PIECES)
        parts = []
        for start in range(0, len(poses), step):
            block = poses[start : start + step]
            parts.append(np.asarray(self.volumes(grasp, block), dtype=np.float64))
            advance(int(np.prod(block.shape[:-2])))
        return np.concatenate(parts)

    def hand_volume(self, grasp: Grasp) -> float:
        """Volume of the grasp's hand (the union of its links), in cubed canonical units: the
        denominator of a descriptor.

        This default is `Grasp.canonical_hand_volume`; a backend that has already built the
        union overrides it to spare a second one.
        """
        return grasp.canonical_hand_volume

    def __getstate__(self) -> dict[str, Any]:
        """The instance without what its caches hold: a copy (a batch task's) carries the
        parameters, and builds its geometry where it runs."""
        return {
            key: LRUCache(value.maxsize) if isinstance(value, LRUCache) else value
            for key, value in self.__dict__.items()
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        """A copy takes the caches of the first copy of the same class and parameters made in
        this process: every task a batch worker runs brings its own copy of the run's
        backend, and the hands and objects they share are then prepared once."""
        self.__dict__.update(state)
        cls = type(self)
        try:
            key = json.dumps([cls.__module__, cls.__qualname__, self.params], sort_keys=True)
        except (TypeError, ValueError):
            return
        caches = {k: v for k, v in self.__dict__.items() if isinstance(v, LRUCache)}
        self.__dict__.update(_COPIED_CACHES.get(key, lambda: caches))

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"{type(self).__name__}({args})"
