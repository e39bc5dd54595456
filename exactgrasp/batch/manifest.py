"""Batch manifests: reading and checking the list of grasps before any work starts.

A manifest is ``.jsonl`` (one JSON object a line) or ``.parquet`` (columns ``id`` and
``grasp``); each row names a grasp file relative to the manifest's folder, or holds an inline
grasp. See ``docs/batch.md``.

pyarrow loads only through `exactgrasp.errors.require`, for Parquet manifests.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.errors import BatchError, require

__all__ = ["DEFAULT_PART_SIZE", "Manifest", "ManifestRow", "read_manifest"]

#: Rows of the manifest per part, the unit a run writes and resumes (`run_batch`'s default).
DEFAULT_PART_SIZE = 32


@dataclass(frozen=True)
class ManifestRow:
    """One manifest row.

    Attributes
    ----------
    index : int
        0-based position among the manifest's rows (the ``row`` of ``errors.jsonl``).
    id : str
    grasp : str or dict or None
        Path of a grasp file (relative to the manifest's folder) or an inline grasp dict.
    problem : str or None
        What is wrong with the row's ``grasp`` entry; the row is then reported as failed.
    """

    index: int
    id: str
    grasp: str | dict | None
    problem: str | None = None


@dataclass(frozen=True)
class Manifest:
    """A validated manifest: unique ids, rows in file order."""

    path: Path
    rows: list[ManifestRow]
    sha256: str

    @property
    def base_dir(self) -> Path:
        """Folder that relative grasp paths are resolved against."""
        return self.path.resolve().parent


def _row_grasp(value: Any) -> tuple[str | dict | None, str | None]:
    """The grasp entry of a row and, when unusable, why."""
    if isinstance(value, str) and value.lstrip().startswith("{"):
        try:
            value = json.loads(value)
        except json.JSONDecodeError as exc:
            return None, f"inline grasp is not valid JSON ({exc})"
    if isinstance(value, dict):
        return value, None
    if isinstance(value, str) and value.strip():
        return value, None
    if value is None:
        return None, "the row has no 'grasp' (a grasp file path or an inline grasp object)"
    return None, f"'grasp' must be a file path or a grasp object, got {type(value).__name__}"


def _row_id(value: Any, where: str) -> str:
    # bool is an int subclass, but True as an id is almost surely a mistake.
    if isinstance(value, bool) or not isinstance(value, str | int | np.integer):
        kind = "missing" if value is None else f"a {type(value).__name__}"
        raise BatchError(f"{where}: 'id' is {kind}; every row needs a string or integer id.")
    text = str(value)
    if not text.strip():
        raise BatchError(f"{where}: 'id' is empty; every row needs a non-empty id.")
    return text


def _jsonl_records(path: Path) -> Iterator[tuple[str, dict]]:
    with open(path, encoding="utf-8") as handle:
        for line_number, line in enumerate(handle, start=1):
            if not line.strip():
                continue
            where = f"{path}: line {line_number}"
            try:
                record = json.loads(line)
            except json.JSONDecodeError as exc:
                raise BatchError(f"{where}: not valid JSON ({exc}).") from exc
            if not isinstance(record, dict):
                raise BatchError(f"{where}: expected a JSON object with 'id' and 'grasp'.")
            yield where, record


def _parquet_records(path: Path) -> Iterator[tuple[str, dict]]:
    pq = require("pyarrow.parquet", "exactgrasp batch", "pyarrow", "batch")
    try:
        table = pq.read_table(path)
    except Exception as exc:
        raise BatchError(f"{path}: not a readable Parquet file ({exc}).") from exc
    missing = {"id", "grasp"} - set(table.column_names)
    if missing:
        raise BatchError(
            f"{path}: Parquet manifests need columns 'id' and 'grasp'; missing {sorted(missing)}."
        )
    ids = table.column("id").to_pylist()
    grasps = table.column("grasp").to_pylist()
    for number, (row_id, grasp) in enumerate(zip(ids, grasps, strict=True), start=1):
        yield f"{path}: row {number}", {"id": row_id, "grasp": grasp}


def read_manifest(path: str | os.PathLike) -> Manifest:
    """Read and check a manifest before any work starts.

    Parameters
    ----------
    path : path-like
        ``.jsonl`` (one JSON object a line) or ``.parquet``; each row has ``id`` and ``grasp``
        (a grasp file path relative to the manifest, or an inline grasp; in Parquet, JSON text).

    Returns
    -------
    Manifest

    Raises
    ------
    BatchError
        A missing, empty or duplicate id (naming the line or row), unreadable JSON, no rows.
    """
    path = Path(path)
    if not path.is_file():
        raise BatchError(f"{path}: no such manifest file.")
    suffix = path.suffix.lower()
    if suffix in (".jsonl", ".ndjson", ".json"):
        records = _jsonl_records(path)
    elif suffix in (".parquet", ".pq"):
        records = _parquet_records(path)
    else:
        raise BatchError(
            f"{path}: unknown manifest type {suffix!r}; use .jsonl (one JSON object a line) or "
            ".parquet (columns 'id' and 'grasp')."
        )
    rows: list[ManifestRow] = []
    first_seen: dict[str, str] = {}
    digest = hashlib.sha256()
    for where, record in records:
        row_id = _row_id(record.get("id"), where)
        if row_id in first_seen:
            raise BatchError(
                f"{where}: duplicate id {row_id!r} (first at {first_seen[row_id]}); ids must be "
                "unique."
            )
        first_seen[row_id] = where.rpartition(": ")[2]
        raw = record.get("grasp")
        grasp, problem = _row_grasp(raw)
        rows.append(ManifestRow(len(rows), row_id, grasp, problem))
        # The hash covers what the workers see, so reformatting the file does not change it.
        entry = {"id": row_id, "grasp": grasp if problem is None else repr(raw)}
        digest.update(json.dumps(entry, sort_keys=True).encode() + b"\n")
    if not rows:
        raise BatchError(f"{path}: the manifest has no rows.")
    return Manifest(path, rows, digest.hexdigest())
