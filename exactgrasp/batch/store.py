"""Files of a batch run: the run record, the lock, the parts and the consolidated output.

Layout of an output folder (see ``docs/batch.md``)::

    run.json              parameters of the run; a resume with other parameters is refused
    parts/part-NNNNNN.parquet
                          rows [N * part_size, (N + 1) * part_size) of the manifest, written
                          to a temporary name and renamed when complete
    descriptors.parquet   every descriptor computed, in manifest order
    errors.jsonl          one line per failed row: id, row, error type, message
    timings.jsonl         per-part wall times and workers (not deterministic, not compared)

Everything but ``timings.jsonl`` is a function of the manifest and the parameters only, so
the bytes do not depend on the number of workers or on the order parts finish in. Every file
but ``timings.jsonl`` is written through `atomic_target` (temporary name, fsync, rename).
The manifest is read by `exactgrasp.batch.manifest`.

pyarrow loads only through `exactgrasp.errors.require`.
"""

from __future__ import annotations

import contextlib
import json
import os
import uuid
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.batch.manifest import ManifestRow
from exactgrasp.descriptor import Descriptor
from exactgrasp.errors import BatchError, require

FORMAT = "exactgrasp.batch/1"
PARTS_DIR = "parts"
DESCRIPTORS_FILE = "descriptors.parquet"
ERRORS_FILE = "errors.jsonl"
RUN_FILE = "run.json"
TIMINGS_FILE = "timings.jsonl"
LOCK_FILE = ".lock"
TEMP_MARK = ".tmp-"
# zstd is deterministic and much smaller than snappy on the many exact zeros of descriptors.
COMPRESSION = "zstd"


def _pa():
    return require("pyarrow", "exactgrasp batch", "pyarrow", "batch")


# -- atomic writes ------------------------------------------------------------------------------


@contextlib.contextmanager
def atomic_target(path: Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write; on success it is flushed to disk and renamed
    to ``path``, so ``path`` exists whole or not at all. On an error it is removed.

    Parameters
    ----------
    path : pathlib.Path
        The file to create or replace.

    Yields
    ------
    pathlib.Path
        Where to write, named with `TEMP_MARK` so that `remove_temp_files` finds it after a kill.
    """
    temp = path.with_name(f"{path.name}{TEMP_MARK}{uuid.uuid4().hex}")
    try:
        yield temp
        with open(temp, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(temp, path)
    finally:
        temp.unlink(missing_ok=True)


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through `atomic_target`."""
    with atomic_target(path) as temp:
        temp.write_bytes(data)


# -- the run record -----------------------------------------------------------------------------


def check_run_record(out: Path, params: dict[str, Any]) -> None:
    """Write ``run.json``, or check that the one there holds the same parameters.

    Raises
    ------
    BatchError
        The folder holds a run with other parameters (it would mix results).
    """
    path = out / RUN_FILE
    text = json.dumps(params, sort_keys=True, indent=1) + "\n"
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise BatchError(f"{path}: unreadable run record ({exc}); use a new --out.") from exc
        if old != json.loads(text):
            keys = sorted(k for k in set(old) | set(params) if old.get(k) != params.get(k))
            raise BatchError(
                f"{out} holds a run with other parameters (different: {', '.join(keys)}); "
                "resuming would mix results. Use the same command as before, or a new --out."
            )
        return
    write_atomic(path, text.encode())


@contextlib.contextmanager
def run_lock(out: Path) -> Iterator[None]:
    """Hold an exclusive lock on the output folder (released by the OS if the process dies)."""
    try:
        import fcntl
    except ImportError:  # Windows: no advisory locks; one run per folder is up to the user
        yield
        return
    with open(out / LOCK_FILE, "w") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            raise BatchError(
                f"{out} is in use by another exactgrasp batch run; wait for it or use another "
                "--out."
            ) from exc
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def remove_temp_files(out: Path) -> int:
    """Delete half-written files left by a killed run; returns how many."""
    count = 0
    for folder in (out, out / PARTS_DIR):
        if folder.is_dir():
            for path in folder.iterdir():
                if TEMP_MARK in path.name:
                    path.unlink()
                    count += 1
    return count


# -- parts --------------------------------------------------------------------------------------


def part_schema(n_values: int):
    """Arrow schema of a part file: a failed row has null values and a non-null error."""
    pa = _pa()
    return pa.schema(
        [
            ("id", pa.string()),
            ("row", pa.int64()),
            ("values", pa.list_(pa.float64(), n_values)),
            ("metadata", pa.string()),
            ("error", pa.string()),
            ("message", pa.string()),
        ]
    )


def part_path(out: Path, part: int) -> Path:
    return out / PARTS_DIR / f"part-{part:06d}.parquet"


def write_part(out: Path, part: int, results: Sequence[dict], n_values: int) -> Path:
    """Write one part atomically; ``results`` in row order, each with keys ``id``, ``row``,
    ``values`` (shape (n_values,) or None), ``metadata``, ``error``, ``message``."""
    pa = _pa()
    import pyarrow.parquet as pq

    schema = part_schema(n_values)
    flat = [
        np.zeros(n_values) if r["values"] is None else np.asarray(r["values"]) for r in results
    ]
    # Failed rows get a null entry; the zeros only fill the child array's slot, never read.
    values = pa.FixedSizeListArray.from_arrays(
        pa.array(np.concatenate(flat) if flat else np.zeros(0), pa.float64()),
        n_values,
        mask=pa.array([r["values"] is None for r in results], pa.bool_()),
    )
    columns = {name: [r[name] for r in results] for name in schema.names if name != "values"}
    arrays = [
        values if name == "values" else pa.array(columns[name], schema.field(name).type)
        for name in schema.names
    ]
    table = pa.Table.from_arrays(arrays, schema=schema)
    path = part_path(out, part)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_target(path) as temp:
        pq.write_table(table, temp, compression=COMPRESSION)
    return path


def read_part(out: Path, part: int, rows: Sequence[ManifestRow], n_values: int):
    """A part's table if it is complete and belongs to these rows, else None."""
    import pyarrow.parquet as pq

    path = part_path(out, part)
    if not path.exists():
        return None
    try:
        table = pq.read_table(path)
    except Exception:
        return None
    if not table.schema.equals(part_schema(n_values)) or table.num_rows != len(rows):
        return None
    if table.column("id").to_pylist() != [r.id for r in rows]:
        return None
    if table.column("row").to_pylist() != [r.index for r in rows]:
        return None
    return table


# -- the consolidated output --------------------------------------------------------------------


def consolidate(out: Path, n_parts: int, params: dict[str, Any]) -> tuple[int, int]:
    """Join the parts in manifest order into ``descriptors.parquet`` and ``errors.jsonl``.

    Returns
    -------
    (int, int)
        Rows with a descriptor, rows that failed.
    """
    pa = _pa()
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    n_values = params["n_paths"] * params["n_steps"]
    fields = [f for f in part_schema(n_values) if f.name in ("id", "values", "metadata")]
    schema = pa.schema(fields, metadata={"exactgrasp.batch": json.dumps(params, sort_keys=True)})
    done = failed = 0
    error_lines = []
    with (
        atomic_target(out / DESCRIPTORS_FILE) as temp,
        pq.ParquetWriter(temp, schema, compression=COMPRESSION) as writer,
    ):
        for part in range(n_parts):
            table = pq.read_table(part_path(out, part))
            ok = pc.is_null(table.column("error"))
            good = table.filter(ok).select(schema.names)
            if good.num_rows:
                writer.write_table(good)
            done += good.num_rows
            bad = table.filter(pc.invert(ok)).select(["id", "row", "error", "message"])
            for record in bad.to_pylist():
                error_lines.append(json.dumps(record, sort_keys=True) + "\n")
            failed += bad.num_rows
    write_atomic(out / ERRORS_FILE, "".join(error_lines).encode())
    return done, failed


@dataclass(frozen=True)
class BatchDescriptors:
    """The descriptors of a finished batch run, as `read_batch` returns them.

    Unpacks as ``ids, descriptors, metadata = read_batch(out)``; ``descriptors`` is what
    `exactgrasp.pairwise_distances` and `exactgrasp.distance` take.

    Attributes
    ----------
    ids : list of str, length n
        The manifest ids of the rows with a descriptor, in manifest order.
    descriptors : list of Descriptor, length n
        One `exactgrasp.Descriptor` per id, its metadata included (values: views of ``values``).
    metadata : list of dict, length n
        Each descriptor's metadata (without the run-dependent ``seconds``).
    values : numpy.ndarray, shape (n, n_paths, n_steps), float64
        Every descriptor's values in one array: intersection volume / hand volume.
    """

    ids: list[str]
    descriptors: list[Descriptor]
    metadata: list[dict]
    values: np.ndarray

    def __iter__(self) -> Iterator:
        return iter((self.ids, self.descriptors, self.metadata))

    def __len__(self) -> int:
        return len(self.ids)


def read_batch(out: str | os.PathLike) -> BatchDescriptors:
    """Read ``descriptors.parquet`` of a finished run.

    Parameters
    ----------
    out : path-like
        The run's output folder (or the ``descriptors.parquet`` file itself).

    Returns
    -------
    BatchDescriptors
        Unpacks as ``ids, descriptors, metadata``: the ids (list of str, length n), one
        `exactgrasp.Descriptor` per id (what `exactgrasp.pairwise_distances` takes), and each
        descriptor's metadata; ``.values`` holds all values, shape (n, n_paths, n_steps).

    Raises
    ------
    BatchError
        ``out`` holds no ``descriptors.parquet`` (the run has not finished).
    """
    import pyarrow.parquet as pq

    path = Path(out)
    path = path / DESCRIPTORS_FILE if path.is_dir() else path
    if not path.is_file():
        raise BatchError(
            f"{path}: no such file; pass the output folder of a finished batch run (its "
            f"{DESCRIPTORS_FILE} is written when the run ends)."
        )
    table = pq.read_table(path)
    params = json.loads(table.schema.metadata[b"exactgrasp.batch"])
    shape = (table.num_rows, params["n_paths"], params["n_steps"])
    flat = table.column("values").combine_chunks().flatten().to_numpy(zero_copy_only=False)
    values = np.asarray(flat, dtype=np.float64).reshape(shape)
    metadata = [json.loads(m) for m in table.column("metadata").to_pylist()]
    descriptors = [Descriptor(v, m) for v, m in zip(values, metadata, strict=True)]
    return BatchDescriptors(table.column("id").to_pylist(), descriptors, metadata, values)
