"""Triangle pairs of a closed mesh that cross or may touch: a grid and certified signs.

Used by `exactgrasp.geometry.shells` to decide how shells relate. Triangle bounding boxes are
binned on a uniform grid of about a triangle's size; each candidate pair gets an edge-triangle
test whose orientation signs are certified by a static error bound (Shewchuk's, see
``_predicates.pxd``): a sign inside the bound is *uncertain*. Within one shell
certain crossings are reported (and, on request, uncertain contacts, neighbours that may fold
onto each other included); between shells an uncertain contact is reported too.
`find_contacts` reports every pair that may meet beyond its shared corners, for the exact cut.

The grid is made here (numpy); its entries and the scan of the pairs are compiled ahead of
time (``_crossings.pyx``, with the single-pair tests of ``_pair_tests.pxd`` and the predicates
of ``_predicates.pxd``, built with the package): nothing compiles at a first call, and the scan
runs without the GIL.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.geometry._crossings import fill_cells, pair_scan

__all__ = ["CROSS", "NO", "UNSURE", "find_contacts", "find_crossings"]

#: Result codes of a pair test: certainly apart, certainly crossing, or uncertain (the
#: kernels' own, ``_pair_tests.pxd``).
NO, CROSS, UNSURE = 0, 1, 2


def _scan(V, F, label, ident, self_contacts: bool, everything: bool):
    """Bin the triangles' bounding boxes on a grid and scan the pairs sharing a cell
    (`exactgrasp.geometry._crossings.pair_scan`)."""
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    if len(F) == 0:
        empty = np.empty(0, np.int64)
        return empty, empty, empty, np.empty((0, 3))
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    lo = np.minimum(np.minimum(a, b), c)
    hi = np.maximum(np.maximum(a, b), c)
    origin = lo.min(0)
    span = float((hi.max(0) - origin).max())
    size = float((hi - lo).max(1).mean())
    h = max(size, span * 1e-6, 1e-300)
    while True:
        # Cells of about a triangle's size: few pairs per cell; coarser while long triangles
        # would fill too many cells.
        n = np.minimum(np.floor((hi.max(0) - origin) / h).astype(np.int64) + 1, 2**20)
        i0 = np.minimum(np.floor((lo - origin) / h).astype(np.int64), n - 1)
        i1 = np.minimum(np.floor((hi - origin) / h).astype(np.int64), n - 1)
        counts = np.prod(i1 - i0 + 1, axis=1)
        if counts.sum() <= 16 * len(F) + 1024 or h >= span:
            break
        h *= 2.0
    # Entries by cell, then lower x (the sweep's order), then triangle: the triangles are
    # numbered in that x order, so that sorting by (cell, number) orders them.
    by_x = np.argsort(lo[:, 0], kind="stable")
    offsets = np.zeros(len(F) + 1, np.int64)
    np.cumsum(counts[by_x], out=offsets[1:])
    keys = np.empty(offsets[-1], np.int64)
    tris = np.empty(offsets[-1], np.int64)
    fill_cells(i0[by_x], i1[by_x], n, offsets, keys, tris)
    keys, tris = _by_cell(keys, tris, len(F))
    tris = by_x[tris]
    label = np.ascontiguousarray(label, dtype=np.int64)
    ident = (
        np.arange(len(V), dtype=np.int64)
        if ident is None
        else np.ascontiguousarray(ident, dtype=np.int64)
    )
    return pair_scan(
        (V, F, ident, label),
        (lo, hi, i0, n, keys, tris),
        self_contacts,
        everything,
    )


def _by_cell(keys: np.ndarray, tris: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """The (cell, triangle) entries sorted by cell, then triangle (< m): one sort of both in
    one integer where it fits (a plain sort is many times a stable argsort's speed)."""
    if len(keys) == 0 or int(keys.max()) < (2**62) // max(m, 1):
        both = np.sort(keys * np.int64(m) + tris)
        return both // m, both % m
    order = np.lexsort((tris, keys))
    return keys[order], tris[order]


def find_crossings(
    vertices: np.ndarray,
    faces: np.ndarray,
    label: np.ndarray,
    *,
    identity: np.ndarray | None = None,
    self_contacts: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pairs of triangles that cross (within a shell) or may touch (between shells).

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
    label : numpy.ndarray, shape (m,), int64
        Shell of every face (`split_shells`).
    identity : numpy.ndarray, shape (n,), int64, optional
        Vertices with equal identity are one point (copies made by
        `exactgrasp.geometry.topology.split_nonmanifold`): triangles meeting only there share
        a corner. Default: every vertex its own.
    self_contacts : bool
        Also report uncertain contacts within one shell: between triangles that share no
        corner (a surface touching itself, or crossing itself exactly through an edge or a
        corner), and between neighbours that may meet beyond the corners they share (a fold
        onto itself).

    Returns
    -------
    t, u : numpy.ndarray, shape (k,), int64
        Face indices of each pair found.
    code : numpy.ndarray, shape (k,), int64
        1: a certain crossing; 2: uncertain contact (between different shells, or within one
        with ``self_contacts``).
    point : numpy.ndarray, shape (k, 3), float64
        A point of a certain crossing (NaN for uncertain contacts), in vertex units.
    """
    return _scan(vertices, faces, label, identity, bool(self_contacts), False)


def find_contacts(
    vertices: np.ndarray, faces: np.ndarray, identity: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of triangles that may meet anywhere but at the corners they share.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64
    faces : numpy.ndarray, shape (m, 3), int64
    identity : numpy.ndarray, shape (n,), int64
        Vertices with equal identity are one point.

    Returns
    -------
    t, u : numpy.ndarray, shape (k,), int64
        Face indices of each pair: the pairs the exact cut
        (`exactgrasp.geometry.exact_cut`) must decide. Pairs left out certainly meet at most
        at their shared corners and along their shared edge.
    """
    label = np.zeros(len(faces), np.int64)
    t, u, _, _ = _scan(vertices, faces, label, identity, True, True)
    return t, u
