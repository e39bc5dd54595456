"""Winding numbers (numba): of one point (`winding_number`) and of every node of a lattice
(`winding_inside_lattice`).

The point routine sums the solid angles of the triangles (van Oosterom and Strackee), O(faces)
per point; the lattice routine sweeps columns of nodes and gives exact integer winding numbers
of all nodes at once, O(crossings), with a symbolic perturbation on shared edges. Callers round
as they need (``round(w) & 1``, ``abs(w) > 0.5``).
"""

from __future__ import annotations

import numpy as np

from exactgrasp.compiling import inner, kernel

__all__ = ["winding_inside_lattice", "winding_number"]


@kernel(nogil=True, error_model="numpy")
def winding_number(x, V, F):
    """Generalised winding number of point x with respect to a closed mesh (not rounded)."""
    # Scalar loads: a vector temporary per corner would allocate three arrays per triangle.
    x0, x1, x2 = x[0], x[1], x[2]
    total = 0.0
    for f in range(F.shape[0]):
        i, j, k = F[f, 0], F[f, 1], F[f, 2]
        a0, a1, a2 = V[i, 0] - x0, V[i, 1] - x1, V[i, 2] - x2
        b0, b1, b2 = V[j, 0] - x0, V[j, 1] - x1, V[j, 2] - x2
        c0, c1, c2 = V[k, 0] - x0, V[k, 1] - x1, V[k, 2] - x2
        la = np.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        lb = np.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        lc = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        num = a0 * (b1 * c2 - b2 * c1)
        num += a1 * (b2 * c0 - b0 * c2)
        num += a2 * (b0 * c1 - b1 * c0)
        ab = a0 * b0 + a1 * b1 + a2 * b2
        bc = b0 * c0 + b1 * c1 + b2 * c2
        ca = c0 * a0 + c1 * a1 + c2 * a2
        den = la * lb * lc + ab * lc + bc * la + ca * lb
        total += 2.0 * np.arctan2(num, den)
    return total / (4.0 * np.pi)


@inner()
def _edge_side(px, py, ax, ay, bx, by):
    """Side (+1 left, -1 right) of point p for the directed edge a->b, never 0 for a != b.

    The edge is evaluated in one fixed vertex order whichever way it is traversed, so the two
    triangles that share it get exactly opposite answers.
    """
    flip = 1
    if ax > bx or (ax == bx and ay > by):
        ax, ay, bx, by = bx, by, ax, ay
        flip = -1
    dx = bx - ax
    dy = by - ay
    value = dx * (py - ay) - dy * (px - ax)
    if value > 0.0:
        return flip
    if value < 0.0:
        return -flip
    # Exactly on the edge's line: decide as if p were moved by (eps, eps**2).
    if dy != 0.0:
        return -flip if dy > 0.0 else flip
    if dx != 0.0:
        return flip if dx > 0.0 else -flip
    return 0


@inner()
def _edge_value(px, py, ax, ay, bx, by):
    """Twice the signed area of (a, b, p), in the same fixed vertex order as `_edge_side`."""
    if ax > bx or (ax == bx and ay > by):
        return -((ax - bx) * (py - by) - (ay - by) * (px - bx))
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


@inner()
def _column_crossings(triangles, nx, ny, count_only, starts, fill, heights, signs):
    """Visit every (column, triangle) crossing; count them or write height and sign."""
    for t in range(triangles.shape[0]):
        ax, ay, az = triangles[t, 0, 0], triangles[t, 0, 1], triangles[t, 0, 2]
        bx, by, bz = triangles[t, 1, 0], triangles[t, 1, 1], triangles[t, 1, 2]
        cx, cy, cz = triangles[t, 2, 0], triangles[t, 2, 1], triangles[t, 2, 2]
        i0 = max(0, int(np.ceil(min(ax, bx, cx))))
        i1 = min(nx - 1, int(np.floor(max(ax, bx, cx))))
        j0 = max(0, int(np.ceil(min(ay, by, cy))))
        j1 = min(ny - 1, int(np.floor(max(ay, by, cy))))
        for i in range(i0, i1 + 1):
            px = float(i)
            for j in range(j0, j1 + 1):
                py = float(j)
                s_ab = _edge_side(px, py, ax, ay, bx, by)
                if s_ab == 0:
                    continue
                if _edge_side(px, py, bx, by, cx, cy) != s_ab:
                    continue
                if _edge_side(px, py, cx, cy, ax, ay) != s_ab:
                    continue
                column = i * ny + j
                if count_only:
                    starts[column + 1] += 1
                    continue
                # Barycentric weights all share one sign, so the height stays between the
                # corners' heights even for slivers.
                wa = _edge_value(px, py, bx, by, cx, cy)
                wb = _edge_value(px, py, cx, cy, ax, ay)
                wc = _edge_value(px, py, ax, ay, bx, by)
                total = wa + wb + wc
                slot = starts[column] + fill[column]
                fill[column] += 1
                heights[slot] = (wa * az + wb * bz + wc * cz) / total
                # Counter-clockwise in xy means the outward normal points up (+z).
                signs[slot] = s_ab


@inner()
def _crossings_by_column(triangles, nx, ny):
    """Every (column, triangle) crossing: column c's heights and signs are
    ``heights[starts[c]:starts[c + 1]]`` and ``signs[...]``, in no order."""
    starts = np.zeros(nx * ny + 1, np.int64)
    fill = np.zeros(nx * ny, np.int64)
    empty_f = np.zeros(0, np.float64)
    empty_i = np.zeros(0, np.int8)
    _column_crossings(triangles, nx, ny, True, starts, fill, empty_f, empty_i)
    for c in range(nx * ny):
        starts[c + 1] += starts[c]
    heights = np.empty(starts[-1], np.float64)
    signs = np.empty(starts[-1], np.int8)
    _column_crossings(triangles, nx, ny, False, starts, fill, heights, signs)
    return starts, heights, signs


@kernel()
def winding_inside_lattice(triangles, nx, ny, nz):
    """Nodes (in index coordinates) whose winding number is at least 1, as uint8."""
    starts, heights, signs = _crossings_by_column(triangles, nx, ny)
    inside = np.zeros((nx, ny, nz), np.uint8)
    for c in range(nx * ny):
        lo, hi = starts[c], starts[c + 1]
        if hi == lo:
            continue
        # Insertion sort: a column crosses the surface a few times, and numba's sorts cost
        # seconds to compile.
        order = np.empty(hi - lo, np.int64)
        for m in range(hi - lo):
            x = heights[lo + m]
            q = m
            while q > 0 and heights[lo + order[q - 1]] > x:
                order[q] = order[q - 1]
                q -= 1
            order[q] = m
        i, j = c // ny, c % ny
        # Sweep down from the top: the winding number of a node is the sum of the signs of
        # the crossings above it.
        winding = 0
        pointer = hi - lo - 1
        for k in range(nz - 1, -1, -1):
            while pointer >= 0 and heights[lo + order[pointer]] > k:
                winding += signs[lo + order[pointer]]
                pointer -= 1
            if winding >= 1:
                inside[i, j, k] = 1
    return inside
