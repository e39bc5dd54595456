"""Winding numbers: of one point (`winding_number`) and of every node of a lattice
(`winding_inside_lattice`).

The point routine sums the solid angles of the triangles (van Oosterom and Strackee), O(faces)
per point; the lattice routine sweeps columns of nodes and gives exact integer winding numbers
of all nodes at once, O(crossings), with a symbolic perturbation on shared edges. Callers round
as they need (``round(w) & 1``, ``abs(w) > 0.5``).

The kernels are compiled ahead of time (``_winding.pyx``, built with the package): nothing
compiles at a first call, and they run without the GIL.
"""

from __future__ import annotations

from exactgrasp.geometry._winding import winding_inside_lattice, winding_number

__all__ = ["winding_inside_lattice", "winding_number"]
