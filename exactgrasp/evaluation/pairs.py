"""Labelled pairs of grasps: made from group labels, or read from a CSV file.

A CSV of pairs has a header and the columns ``a``, ``b`` and ``label``, and optionally
``group``. ``a`` and ``b`` name grasps: grasp file paths (relative to the CSV's folder) or,
with a manifest (`exactgrasp.batch.read_manifest`), its ids. ``label`` is ``same`` /
``different`` (also ``1`` / ``0``, ``true`` / ``false``, ``yes`` / ``no``) or a number, a grade
where higher means more alike. ``group`` names the group of the pair for the per-group
breakdown (e.g. the object).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path

import numpy as np

from exactgrasp.batch.manifest import read_manifest
from exactgrasp.errors import EvaluationError

__all__ = ["LabelledPairs", "pairs_from_groups", "read_pairs"]

_WORDS = {
    "same": 1.0,
    "different": 0.0,
    "true": 1.0,
    "false": 0.0,
    "yes": 1.0,
    "no": 0.0,
}


@dataclass
class LabelledPairs:
    """Pairs of grasps with labels.

    Attributes
    ----------
    names : list of str, length n_grasps
        The grasps the pairs refer to (file paths or ids).
    first, second : numpy.ndarray, shape (n_pairs,), int
        Indices into ``names``.
    label : numpy.ndarray, shape (n_pairs,), float
        1 same, 0 different, or grades (higher = more alike).
    pair_group : list of str or None, length n_pairs
        Group of each pair for the breakdown.
    grasp_group : list of str or None, length n_grasps
        Group of each grasp (e.g. its cluster): the breakdown then shows, per group, the pairs
        with a grasp in it, and the bootstrap may resample groups.
    """

    names: list[str]
    first: np.ndarray
    second: np.ndarray
    label: np.ndarray
    pair_group: list[str] | None = None
    grasp_group: list[str] | None = None

    @property
    def n_same(self) -> int:
        """Pairs with the highest label."""
        return int(np.sum(self.label == self.label.max()))

    def __len__(self) -> int:
        return int(self.first.size)


def pairs_from_groups(names: Sequence[str], groups: Sequence[str]) -> LabelledPairs:
    """Every pair of the grasps, "same" when both are in one group.

    Parameters
    ----------
    names : sequence of str, length n
    groups : sequence of str, length n

    Returns
    -------
    LabelledPairs
        ``n (n - 1) / 2`` pairs in ``itertools.combinations`` order.
    """
    names, groups = [str(n) for n in names], [str(g) for g in groups]
    if len(names) != len(groups):
        raise EvaluationError(f"{len(names)} names but {len(groups)} groups; give one each.")
    if len(names) < 2:
        raise EvaluationError("pairs need at least two grasps.")
    both = np.array(list(combinations(range(len(names)), 2)), dtype=np.int64)
    i, j = both[:, 0], both[:, 1]
    label = np.array([groups[a] == groups[b] for a, b in both], dtype=np.float64)
    return LabelledPairs(names, i, j, label, None, groups)


def _label(text: str, where: str) -> float:
    word = text.strip().lower()
    if word in _WORDS:
        return _WORDS[word]
    try:
        value = float(word)
    except ValueError:
        raise EvaluationError(
            f"{where}: label {text!r} is neither same/different (1/0, true/false) nor a grade "
            "number."
        ) from None
    if not np.isfinite(value):
        raise EvaluationError(f"{where}: label {text!r} is not a finite number.")
    return value


def read_pairs(
    path: str | os.PathLike, manifest: str | os.PathLike | None = None
) -> tuple[LabelledPairs, list]:
    """Read a CSV of labelled pairs.

    Parameters
    ----------
    path : path-like
        The CSV (columns ``a``, ``b``, ``label``, optional ``group``).
    manifest : path-like, optional
        A batch manifest whose ids ``a`` and ``b`` name.

    Returns
    -------
    pairs : LabelledPairs
    sources : list, length n_grasps
        For each name, a grasp file path (`pathlib.Path`) or an inline grasp dict of the
        manifest.
    """
    path = Path(path)
    if not path.is_file():
        raise EvaluationError(f"{path}: no such pairs file; give a CSV with columns a,b,label.")
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        raise EvaluationError(f"{path}: no pairs; give a header a,b,label and one pair a line.")
    missing = {"a", "b", "label"} - set(rows[0])
    if missing:
        raise EvaluationError(
            f"{path}: missing column(s) {', '.join(sorted(missing))}; the header must name "
            f"a,b,label (and optionally group), found {', '.join(rows[0])}."
        )
    lookup = {}
    if manifest is not None:
        m = read_manifest(manifest)
        lookup = {
            row.id: (m.base_dir / row.grasp if isinstance(row.grasp, str) else row.grasp)
            for row in m.rows
        }
    index: dict[str, int] = {}
    sources: list = []
    first, second, label, group = [], [], [], []
    for n, row in enumerate(rows, start=2):
        where = f"{path}, line {n}"
        ends = []
        for column in ("a", "b"):
            name = (row[column] or "").strip()
            if not name:
                raise EvaluationError(f"{where}: column {column} is empty; name a grasp.")
            if name not in index:
                if manifest is not None:
                    if name not in lookup:
                        raise EvaluationError(
                            f"{where}: id {name!r} is not in the manifest {manifest}."
                        )
                    sources.append(lookup[name])
                else:
                    file = (path.parent / name).resolve()
                    if not file.is_file():
                        raise EvaluationError(
                            f"{where}: grasp file {name!r} does not exist (paths are relative "
                            f"to {path.parent}); or pass --manifest to name grasps by id."
                        )
                    sources.append(file)
                index[name] = len(index)
            ends.append(index[name])
        if ends[0] == ends[1]:
            raise EvaluationError(f"{where}: a pair of {row['a']!r} with itself.")
        first.append(ends[0])
        second.append(ends[1])
        label.append(_label(row["label"] or "", where))
        group.append((row.get("group") or "").strip())
    pairs = LabelledPairs(
        list(index),
        np.array(first, dtype=np.int64),
        np.array(second, dtype=np.int64),
        np.array(label, dtype=np.float64),
        group if any(group) else None,
        None,
    )
    return pairs, sources
