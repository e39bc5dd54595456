"""Fuzz run of exactness on solids whose surfaces touch themselves, against CGAL's exact
arrangement (libigl's GPL module, the dev extra: a test-only reference).

The family of ``tests/touching_meshes.py`` (edges of four and six faces, cavities touching the
outer shell at an edge and at a vertex, an island in such a cavity on the same edge, shells
touching along a face), each as built, under an exact signed permutation, scaled by 1e-3 and
by 1e3, and 500-1000 units from the origin; boxes whose faces pass exactly through or along
the special edge, moved along it by dyadic steps, and an icosphere at random poses around it.
A pose mismatches when ``|volume - CGAL|`` exceeds ``1e-9 max(CGAL, 1e-6 solid's volume)``
plus the bound of libigl's rounding of CGAL's output vertices (the scene is first moved by an
exact integer translation to near the origin, so that this bound is of the scene's size). The
poses where that bound exceeds the rule's tolerance are counted, as are refused scenes
(`UncertainPoseError` for a pose, `MeshError` for a solid that manifold3d cannot read back
faithfully).

    python benchmarks/fuzz_touching.py [--balls 60]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.test_exactness import fuzz  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--balls", type=int, default=60, help="ball poses per scene")
    args = parser.parse_args()
    t0 = time.perf_counter()
    compared, mismatches, unmeasured, refused = fuzz(every=1, n_ball=args.balls)
    print(f"poses compared with CGAL: {compared}")
    print(f"mismatches beyond 1e-9 relative (floor 1e-6 of the solid): {len(mismatches)}")
    for label, i, got, want in mismatches:
        print(f"  {label}, pose {i}: {got!r} against {want!r}")
    print(f"poses where CGAL's output rounding exceeds the tolerance: {unmeasured}")
    print(f"refused scenes: {len(refused)}")
    for label, text in refused:
        print(f"  {label}: {text}")
    print(f"seconds: {time.perf_counter() - t0:.0f}")


if __name__ == "__main__":
    main()
