"""Distances between descriptors within the paper's framework, and over starting configurations.

Every distance is the Euclidean norm of the difference of a per-descriptor feature vector:

- ``"l2"``: the values themselves (the paper's main choice).
- ``"l2_diff"``: the step-to-step changes along each path (the paper's second choice).
- ``"cbrt"``: the cube roots of the values. A volume grows like the cube of how far the
  object has moved into the hand, so the cube root is a length (the side of a cube of that
  volume, in units of the hand's own cube side); it weighs a first touch like a deep overlap
  of the same depth change, where the plain values let a few deep poses dominate.
- ``"escape"``: per path, the time at which the intersection first passes a threshold (a
  fraction of the hand volume), interpolated linearly between steps from zero at the start;
  a path that never passes it gets one step past the end. This is the per-path summary in the
  spirit of the authors' code: how far along each path the object gets before it is stopped.

A distance "over starting configurations" is the smallest of these norms between one grasp's
descriptor and the other's descriptors along the paths seen through each symmetry of the hand
(`exactgrasp.evaluation.symmetry`), taken both ways so that it stays symmetric.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.distance import cdist

from exactgrasp.backends import Backend
from exactgrasp.descriptor import Descriptor, compute_volumes
from exactgrasp.errors import EvaluationError
from exactgrasp.evaluation.names import DISTANCES
from exactgrasp.evaluation.symmetry import symmetric_poses
from exactgrasp.grasp import Grasp
from exactgrasp.paths.sampler import PathSampler

__all__ = [
    "DEFAULT_THRESHOLD",
    "DISTANCES",
    "RECOMMENDED_DISTANCE",
    "configuration_values",
    "distance_matrix",
    "escape_times",
    "features",
    "parse_distance",
]

#: The descriptor distances by name.
#: The distance the report "What the descriptor tells you" chooses by its rule
#: (`exactgrasp.evaluation.study.choose_default`); also ``exactgrasp.distance(a, b, "cbrt")``.
RECOMMENDED_DISTANCE = "cbrt"
#: The ``"escape"`` distance's default threshold, as a fraction of the hand volume.
DEFAULT_THRESHOLD = 0.01


def parse_distance(spec: str) -> tuple[str, float | None]:
    """``"escape:0.01"`` -> ``("escape", 0.01)``; ``"l2"`` -> ``("l2", None)``."""
    kind, _, arg = str(spec).partition(":")
    if kind not in DISTANCES:
        raise EvaluationError(f"distance {spec!r} is unknown; use one of {DISTANCES}.")
    if kind != "escape":
        if arg:
            raise EvaluationError(f"distance {kind!r} takes no parameter, got {spec!r}.")
        return kind, None
    try:
        threshold = float(arg) if arg else DEFAULT_THRESHOLD
    except ValueError:
        raise EvaluationError(
            f"distance {spec!r}: the threshold after ':' must be a number, e.g. escape:0.01."
        ) from None
    if not threshold > 0:
        raise EvaluationError(f"distance {spec!r}: the threshold must be positive.")
    return kind, threshold


def escape_times(values: np.ndarray, times: np.ndarray, threshold: float) -> np.ndarray:
    """Time along each path at which the value first exceeds ``threshold``.

    Parameters
    ----------
    values : numpy.ndarray, shape (..., n_paths, n_steps)
    times : numpy.ndarray, shape (n_steps,)
        Increasing step times in (0, 1] (`PathSampler.times`).
    threshold : float
        Fraction of the hand volume.

    Returns
    -------
    numpy.ndarray, shape (..., n_paths)
        Linear interpolation between the steps, starting from value 0 at time 0; one step
        past the last time where the threshold is never passed.
    """
    values = np.asarray(values, dtype=np.float64)
    t = np.concatenate([[0.0], np.asarray(times, dtype=np.float64)])
    v = np.concatenate([np.zeros((*values.shape[:-1], 1)), values], axis=-1)
    above = v > threshold
    above[..., 0] = False
    first = np.argmax(above, axis=-1)
    never = ~above.any(axis=-1)
    k = np.maximum(first, 1)
    v0 = np.take_along_axis(v, (k - 1)[..., None], -1)[..., 0]
    v1 = np.take_along_axis(v, k[..., None], -1)[..., 0]
    fraction = np.clip((threshold - v0) / np.where(v1 > v0, v1 - v0, 1.0), 0.0, 1.0)
    crossing = t[k - 1] + fraction * (t[k] - t[k - 1])
    past_end = t[-1] + (t[-1] - t[-2])
    return np.where(never, past_end, crossing)


def features(values: np.ndarray, kind: str, times: np.ndarray, threshold: float | None = None):
    """The feature vector whose Euclidean distance is the descriptor distance ``kind``.

    Parameters
    ----------
    values : numpy.ndarray, shape (..., n_paths, n_steps)
    kind : {"l2", "l2_diff", "cbrt", "escape"}
    times : numpy.ndarray, shape (n_steps,)
    threshold : float, optional
        For ``"escape"`` (default `DEFAULT_THRESHOLD`).

    Returns
    -------
    numpy.ndarray, shape (..., n_features)
    """
    values = np.asarray(values, dtype=np.float64)
    lead = values.shape[:-2]
    if kind == "l2":
        out = values
    elif kind == "l2_diff":
        out = np.diff(values, axis=-1)
    elif kind == "cbrt":
        out = np.cbrt(values)
    elif kind == "escape":
        out = escape_times(values, times, DEFAULT_THRESHOLD if threshold is None else threshold)
    else:
        raise EvaluationError(f"distance {kind!r} is unknown; use one of {DISTANCES}.")
    return out.reshape((*lead, -1))


def distance_matrix(
    stacks: list[np.ndarray], spec: str, times: np.ndarray, use_configurations: bool = True
) -> np.ndarray:
    """All pairwise distances, the minimum over starting configurations when given.

    Parameters
    ----------
    stacks : list of numpy.ndarray, each shape (n_configs, n_paths, n_steps)
        Per grasp, its descriptor values first, then those along the paths seen through each
        symmetry (`configuration_values`); all of one shape.
    spec : str
        A distance name, ``"escape:THRESHOLD"`` for another threshold.
    times : numpy.ndarray, shape (n_steps,)
    use_configurations : bool
        False: the plain distance of the first entries.

    Returns
    -------
    numpy.ndarray, shape (n, n)
        Symmetric, zero diagonal.
    """
    kind, threshold = parse_distance(spec)
    shapes = {np.shape(s) for s in stacks}
    if len(shapes) != 1:
        raise EvaluationError(
            f"descriptors of different shapes {sorted(shapes)} are not comparable; compute "
            "them all with the same sampler and the same symmetries."
        )
    f = features(np.stack(stacks), kind, times, threshold)  # (n, n_configs, n_features)
    plain = f[:, 0]
    matrix = cdist(plain, plain)
    if use_configurations:
        for c in range(1, f.shape[1]):
            matrix = np.minimum(matrix, cdist(plain, f[:, c]))
        matrix = np.minimum(matrix, matrix.T)
    np.fill_diagonal(matrix, 0.0)
    return matrix


def configuration_values(
    grasp: Grasp,
    descriptor: Descriptor,
    sampler: PathSampler,
    backend: Backend,
    symmetries: list[tuple[str, np.ndarray]],
    cached: Any = None,
) -> np.ndarray:
    """The descriptor and its values along the paths seen through each symmetry.

    Parameters
    ----------
    grasp : Grasp
    descriptor : Descriptor
        The grasp's descriptor with this sampler and backend.
    sampler : PathSampler
    backend : Backend
    symmetries : list of (str, numpy.ndarray (3, 3))
        From `exactgrasp.evaluation.symmetry.as_symmetries`.
    cached : callable, optional
        ``cached(name, compute)`` returns stored values for a symmetry name or calls
        ``compute()`` and stores its result.

    Returns
    -------
    numpy.ndarray, shape (1 + len(symmetries), n_paths, n_steps)
    """
    hand_volume = descriptor.metadata.get("hand_volume_canonical")
    if hand_volume is None:
        hand_volume = float(backend.hand_volume(grasp))
    out = [descriptor.values]
    for name, matrix in symmetries:

        def compute(matrix=matrix):
            poses = symmetric_poses(sampler.poses(), matrix)
            return compute_volumes(grasp, poses, backend, progress=False) / hand_volume

        out.append(compute() if cached is None else cached(name, compute))
    return np.stack(out)
