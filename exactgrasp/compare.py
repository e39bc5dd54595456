"""Pose-by-pose comparison of backends on one grasp: what the estimate gets wrong."""

from __future__ import annotations

import csv
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.backends import Backend
from exactgrasp.backends.defaults import COMPARED_BACKENDS
from exactgrasp.backends.registry import as_backend
from exactgrasp.descriptor import compute_volumes
from exactgrasp.errors import ExactGraspError
from exactgrasp.grasp import Grasp
from exactgrasp.paths.presets import as_sampler
from exactgrasp.paths.sampler import PathSampler

#: Reference values below this fraction of the hand volume count as zero when forming
#: relative errors (a ratio to a near-zero volume says nothing about the estimator).
RELATIVE_FLOOR = 1e-4


#: The legend `Comparison.summary_text` prints under its table.
COLUMNS_TEXT = f"""\
columns, each backend against {{reference}} over the same poses:
  |rel|        |value - reference| / reference, over the poses whose reference value
               exceeds {RELATIVE_FLOOR:g} (descriptor units): median, 95th percentile, max
  mean signed  mean of value - reference over every pose, in descriptor units (volume /
               hand volume); below 0: this backend reads less than {{reference}} on average
  corr         Pearson correlation of the values with {{reference}}'s, every pose
  FP           poses where {{reference}} reads 0 and this backend more (an overlap not there)
  FN           poses where {{reference}} reads more than 0 and this backend 0 (one missed)"""


@dataclass
class Comparison:
    """Result of `compare_backends`.

    Attributes
    ----------
    table : dict of str to numpy.ndarray
        One row per pose (``n_paths * n_steps`` rows), columns: ``path``, ``step``, ``t``,
        ``kind``, ``direction_{x,y,z}``, ``axis_{x,y,z}``, ``amount`` (rad), then for each
        backend ``value_<name>`` (intersection / hand volume), and for each non-reference
        backend ``diff_<name>`` (value minus the reference's) and ``rel_<name>`` (diff over
        the reference value, the reference floored at `RELATIVE_FLOOR`).
    summary : dict of str to dict
        Per non-reference backend: ``median_abs_rel``, ``p95_abs_rel``, ``max_abs_rel``
        (over poses whose reference value exceeds the floor), ``mean_signed_error``
        (descriptor units, all poses), ``mean_signed_rel``, ``correlation`` (Pearson, all
        poses), ``false_positive_poses`` (reference 0, estimate > 0), ``false_negative_poses``,
        ``n_poses``, ``n_compared``.
    seconds : dict of str to float
        Wall seconds each backend took to compute.
    reference : str
        The backend the others are compared with (the last one given).
    backends : list of str
        The backends' labels, in the order given.
    """

    table: dict[str, np.ndarray]
    summary: dict[str, dict[str, float]]
    seconds: dict[str, float]
    reference: str
    backends: list[str] = field(default_factory=list)

    def summary_text(self) -> str:
        """A plain-text table of the summary."""
        lines = [f"reference backend: {self.reference} ({self.seconds[self.reference]:.2f} s)"]
        header = (
            f"{'backend':>10} {'seconds':>8} {'median|rel|':>12} {'p95|rel|':>10} "
            f"{'max|rel|':>10} {'mean signed':>12} {'corr':>8} {'FP':>5} {'FN':>5}"
        )
        lines.append(header)
        for name, s in self.summary.items():
            lines.append(
                f"{name:>10} {self.seconds[name]:8.2f} {s['median_abs_rel']:12.4g} "
                f"{s['p95_abs_rel']:10.4g} {s['max_abs_rel']:10.4g} "
                f"{s['mean_signed_error']:12.4g} {s['correlation']:8.4f} "
                f"{s['false_positive_poses']:5d} {s['false_negative_poses']:5d}"
            )
        lines.extend(COLUMNS_TEXT.format(reference=self.reference).splitlines())
        return "\n".join(lines)

    def to_pandas(self):
        """The per-pose table as a pandas DataFrame (needs pandas)."""
        from exactgrasp.errors import require

        pandas = require("pandas", "Comparison.to_pandas", extra="all")
        return pandas.DataFrame(self.table)


def _summary(values: np.ndarray, reference: np.ndarray) -> dict[str, Any]:
    diff = values - reference
    compared = reference > RELATIVE_FLOOR
    rel = diff[compared] / reference[compared]
    abs_rel = np.abs(rel)
    if values.std() > 0 and reference.std() > 0:
        correlation = float(np.corrcoef(values, reference)[0, 1])
    else:
        correlation = 1.0 if np.array_equal(values, reference) else 0.0
    return {
        "median_abs_rel": float(np.median(abs_rel)) if rel.size else 0.0,
        "p95_abs_rel": float(np.percentile(abs_rel, 95)) if rel.size else 0.0,
        "max_abs_rel": float(abs_rel.max()) if rel.size else 0.0,
        "mean_signed_error": float(diff.mean()),
        "mean_signed_rel": float(rel.mean()) if rel.size else 0.0,
        "correlation": correlation,
        "false_positive_poses": int(np.sum((reference == 0) & (values > 0))),
        "false_negative_poses": int(np.sum((reference > 0) & (values == 0))),
        "n_poses": int(values.size),
        "n_compared": int(compared.sum()),
    }


def compare_backends(
    grasp: Grasp,
    sampler: PathSampler | str | dict | None = None,
    backends: Sequence[str | Backend] = COMPARED_BACKENDS,
    progress: bool | None = None,
) -> Comparison:
    """Run several backends on the same poses and compare them pose by pose.

    Parameters
    ----------
    grasp : Grasp
    sampler : PathSampler or str or dict, optional
        Anything `exactgrasp.paths.as_sampler` takes; default: the ``"balanced"`` preset.
    backends : sequence of str or Backend
        At least two, each a registered name (library defaults) or a configured instance;
        the LAST is the reference (e.g. ``("voxel", ExactBackend(broadphase=None))``).
    progress : bool, optional

    Returns
    -------
    Comparison
    """
    if len(backends) < 2:
        raise ExactGraspError(
            f"compare_backends needs at least two backends, got {list(backends)}; e.g. "
            "backends=('voxel', 'exact')."
        )
    sampler = as_sampler(sampler)
    instances = [as_backend(b) for b in backends]
    names = [b.name for b in instances]
    labels = [f"{n}{i}" if names.count(n) > 1 else n for i, n in enumerate(names)]
    poses = sampler.poses()
    volumes: dict[str, np.ndarray] = {}
    seconds: dict[str, float] = {}
    for label, backend in zip(labels, instances, strict=True):
        start = time.perf_counter()
        volumes[label] = compute_volumes(grasp, poses, backend, progress, f"{label} poses")
        seconds[label] = time.perf_counter() - start
    # One denominator for every backend: the reference's hand volume (its own union, if any).
    hand_volume = float(instances[-1].hand_volume(grasp))
    values = {label: v.ravel() / hand_volume for label, v in volumes.items()}

    table = sampler.paths
    n_paths, n_steps = sampler.n_paths, sampler.n_steps
    path_index = np.repeat(np.arange(n_paths), n_steps)
    columns: dict[str, np.ndarray] = {
        "path": path_index,
        "step": np.tile(np.arange(n_steps), n_paths),
        "t": np.tile(sampler.times, n_paths),
        "kind": table.kind[path_index],
    }
    for i, axis in enumerate("xyz"):
        columns[f"direction_{axis}"] = table.direction[path_index, i]
    for i, axis in enumerate("xyz"):
        columns[f"axis_{axis}"] = table.axis[path_index, i]
    columns["amount"] = table.amount[path_index]
    reference = labels[-1]
    ref = values[reference]
    for label in labels:
        columns[f"value_{label}"] = values[label]
    summary = {}
    for label in labels[:-1]:
        columns[f"diff_{label}"] = values[label] - ref
        columns[f"rel_{label}"] = (values[label] - ref) / np.maximum(ref, RELATIVE_FLOOR)
        summary[label] = _summary(values[label], ref)
    return Comparison(columns, summary, seconds, reference, labels)


def write_table(table: dict[str, np.ndarray], path: str | os.PathLike) -> Path:
    """Write a per-pose table as CSV (``.csv``) or Parquet (``.parquet``, needs pyarrow).

    Returns
    -------
    pathlib.Path
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".parquet":
        from exactgrasp.errors import require

        pa = require("pyarrow", "writing Parquet tables", extra="batch")
        require("pyarrow.parquet", "writing Parquet tables", package="pyarrow", extra="batch")
        pa.parquet.write_table(pa.table({k: np.asarray(v) for k, v in table.items()}), path)
        return path
    if path.suffix != ".csv":
        raise ExactGraspError(f"{path}: write a .csv or .parquet table (got {path.suffix!r}).")
    names = list(table)
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(names)
        columns = [np.asarray(table[n]) for n in names]
        for row in zip(*columns, strict=True):
            writer.writerow([repr(float(x)) if isinstance(x, np.floating) else x for x in row])
    return path
