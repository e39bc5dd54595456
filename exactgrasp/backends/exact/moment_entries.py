"""The moments a call's poses touched, row by row: `MomentEntries`, and how the intersector
puts the kernel's pieces of them together.

The kernel (`_kernel.pose_volumes`) writes, per pose, only the rows of moments (a link's, or with
``faces`` a face's of either mesh) that the pose touched, never the ``L`` rows of every pose:
for faces, a pose meets a few hundred of thousands. A pose's entries lie anywhere in the
arrays, from ``begin`` to ``end``, so that poses run apart (threads, the volume's limit at an
uncertain pose, `extrapolate`) and repeated ones (`backends.base.repeated_poses`) are put
together by their ranges alone, without copying the entries in pose order.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from exactgrasp.backends.exact._entries import vertex_sums
from exactgrasp.backends.exact.tables import CULLED, MOMENT_COLUMNS, MomentTables

__all__ = [
    "MomentEntries",
    "appended",
    "concatenated",
    "dense",
    "empty",
    "finish_sums",
    "from_kernel",
    "placed",
    "spans",
    "taken",
]


class MomentEntries(NamedTuple):
    """Per pose, the rows of moments it touched and their values.

    Pose ``i``'s entries are ``begin[i]`` to ``end[i] - 1``: each a row (of the ``L`` a pose
    has) and its moments ``(∫ n dA, ∫ x × n dA)``, a row at most once per pose; a row not
    listed holds zeros (a pose of volume 0 lists none).
    """

    #: (k,) int64: the first entry of each pose.
    begin: np.ndarray
    #: (k,) int64: one past its last.
    end: np.ndarray
    #: (t,) int64: the entries' rows.
    rows: np.ndarray
    #: (t, `MOMENT_COLUMNS`) float64: their moments.
    values: np.ndarray


def from_kernel(start: np.ndarray, rows: np.ndarray, values: np.ndarray) -> MomentEntries:
    """The entries of `_kernel.pose_volumes`: its ``moment_start`` (k + 1,), ``rows`` and
    ``values``."""
    return MomentEntries(start[:-1], start[1:], rows, values)


def empty(k: int) -> MomentEntries:
    """No entries for ``k`` poses."""
    none = np.zeros(k, np.int64)
    return MomentEntries(none, none.copy(), none[:0], np.zeros((0, MOMENT_COLUMNS)))


def placed(entries: MomentEntries, index: np.ndarray, k: int) -> MomentEntries:
    """``entries`` of poses ``index`` (len(index),) among ``k`` poses, the others none."""
    begin, end = np.zeros(k, np.int64), np.zeros(k, np.int64)
    begin[index], end[index] = entries.begin, entries.end
    return MomentEntries(begin, end, entries.rows, entries.values)


def appended(entries: MomentEntries, rows_by_pose: dict[int, np.ndarray]) -> MomentEntries:
    """``entries`` with the poses of ``rows_by_pose`` (pose -> (L, 6) moments, every row)
    given instead: their rows that are not zero, after the others."""
    if not rows_by_pose:
        return entries
    begin, end = entries.begin.copy(), entries.end.copy()
    rows, values = [entries.rows], [entries.values]
    at = len(entries.rows)
    for pose, moments in rows_by_pose.items():
        live = np.flatnonzero(np.any(moments != 0.0, axis=1))
        begin[pose], end[pose] = at, at + len(live)
        rows.append(live)
        values.append(moments[live])
        at += len(live)
    return MomentEntries(begin, end, np.concatenate(rows), np.concatenate(values))


def concatenated(pieces: list[tuple[np.ndarray, MomentEntries]], k: int) -> MomentEntries:
    """One `MomentEntries` of ``k`` poses from pieces (pose indices (j,), their entries):
    each pose in exactly one piece."""
    if len(pieces) == 1 and np.array_equal(pieces[0][0], np.arange(k)):
        return pieces[0][1]
    begin, end = np.zeros(k, np.int64), np.zeros(k, np.int64)
    at = 0
    for index, entries in pieces:
        begin[index], end[index] = entries.begin + at, entries.end + at
        at += len(entries.rows)
    rows = np.concatenate([e.rows for _, e in pieces] or [np.zeros(0, np.int64)])
    values = np.concatenate([e.values for _, e in pieces] or [np.zeros((0, MOMENT_COLUMNS))])
    return MomentEntries(begin, end, rows, values)


def taken(entries: MomentEntries, index: np.ndarray) -> MomentEntries:
    """The entries of poses ``index`` (j,), in that order (a pose may come more than once)."""
    return MomentEntries(entries.begin[index], entries.end[index], entries.rows, entries.values)


def dense(entries: MomentEntries, n_rows: int, tables: MomentTables) -> np.ndarray:
    """Every row of every pose, (k, ``n_rows``, 6): the entries' values, zeros elsewhere, and
    the entries of the parts whose markers are listed (``tables.part_from``) added."""
    k = len(entries.begin)
    counts = entries.end - entries.begin
    pose = np.repeat(np.arange(k), counts)
    at = spans(entries.begin, counts)
    rows, values = entries.rows[at], entries.values[at]
    out = np.zeros((k, n_rows, MOMENT_COLUMNS))
    plain = rows < n_rows
    out[pose[plain], rows[plain]] = values[plain]
    part = rows[~plain] - tables.part_from[0]
    sizes = tables.part_start[part + 1] - tables.part_start[part]
    entry = spans(tables.part_start[part], sizes)
    where = (np.repeat(pose[~plain], sizes), tables.part_link[entry])
    np.add.at(out, where, tables.part_moments[entry])
    return out


def spans(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """The indices ``starts[i]`` to ``starts[i] + counts[i] - 1`` (int arrays (j,)), for each
    ``i`` in turn."""
    return np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())


def finish_sums(
    sums: tuple, entries: MomentEntries, codes: np.ndarray, first: np.ndarray, back: np.ndarray
) -> None:
    """The vertex derivatives of a call whose kernel summed them itself (`_kernel.pose_volumes`
    with ``sums``): the rows it could not write, written.

    Parameters
    ----------
    sums : (face_gradients.VertexTables, numpy.ndarray, numpy.ndarray)
        The tables and ``out_a`` (k, n_a, 3), ``out_b`` (k, n_b, 3) of the call's k poses,
        the kernel's rows written.
    entries, codes : MomentEntries, numpy.ndarray (j,) int64
        Of the j poses run (repeats run once): entries only where the kernel's rows were put
        aside (the limit at an uncertain pose, the arrangement), and the poses' codes.
    first, back : numpy.ndarray (j,) and (k,) int64
        The row of each pose run (the first of its repeats), and the pose run at each row.
    """
    tables, out_a, out_b = sums
    left = np.flatnonzero((codes == CULLED) | (entries.end > entries.begin))
    if len(left):
        a = np.empty((len(left), *out_a.shape[1:]))
        b = np.empty((len(left), *out_b.shape[1:]))
        vertex_sums(*taken(entries, left), tables, a, b)
        out_a[first[left]], out_b[first[left]] = a, b
    again = np.flatnonzero(first[back] != np.arange(len(back)))
    out_a[again], out_b[again] = out_a[first[back[again]]], out_b[first[back[again]]]
