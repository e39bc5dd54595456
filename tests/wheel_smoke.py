"""Smoke test of an installed exactgrasp (a wheel in a clean environment): the README's first
voxel descriptor, the built-in Barrett hand half closed on a 6 x 10 x 10 cm box.

Run from any folder but the checkout's (so that the installed package is the one imported)::

    python /path/to/checkout/tests/wheel_smoke.py

Exits 0 and prints ``ok`` when the compiled kernels (the voxel estimator's, the geometry's and
the exact backend's) load from the installed package, the descriptor has the values the
numba kernels gave (sum of its 474 x 9 values 254.50508652741135, 3,942 of them above 0,
largest 0.3229725732911827) to 1e-9 relative, an exact volume is right (two unit cubes half
a unit apart: 0.5) and numba was never imported.
cibuildwheel runs it on every wheel it builds (``[tool.cibuildwheel]`` in pyproject.toml).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

SUM, NONZERO, LARGEST = 254.50508652741135, 3942, 0.3229725732911827


def main() -> int:
    start = time.perf_counter()
    import exactgrasp as eg
    from exactgrasp.backends import _builds
    from exactgrasp.backends.exact import _entries, _stages, _tables, intersector
    from exactgrasp.backends.exact import _kernel as exact_kernel
    from exactgrasp.backends.voxel import _kernel, _points, kernel
    from exactgrasp.geometry import _crossings, _winding

    compiled = (
        _kernel,
        _points,
        _winding,
        _crossings,
        exact_kernel,
        _entries,
        _stages,
        _tables,
        _builds,
    )
    for module in compiled:
        path = Path(module.__file__)
        assert path.suffix in (".so", ".pyd"), path
        assert "site-packages" in path.parts, f"{path}: not the installed package"
    hand = eg.hands.barrett({f"finger_{i}_med_joint": 0.6 for i in (1, 2, 3)})
    pose = np.eye(4)
    pose[:3, 3] = (0.0, 0.0, 0.125)
    grasp = eg.Grasp(hand, eg.objects.box((0.06, 0.1, 0.1)), pose, name="box")
    sampler = eg.PathSampler.preset("balanced")
    d = eg.compute_descriptor(grasp, sampler, backend="voxel", progress=False)
    values = d.values
    assert values.shape == (474, 9), values.shape
    assert np.count_nonzero(values) == NONZERO, np.count_nonzero(values)
    np.testing.assert_allclose(values.sum(), SUM, rtol=1e-9)
    np.testing.assert_allclose(values.max(), LARGEST, rtol=1e-9)
    # The exact backend: two unit cubes, the second half a unit along x: half a unit of volume.
    cube = eg.geometry.primitives.box([0.5, 0.5, 0.5])
    shift = np.eye(4)
    shift[0, 3] = 0.5
    exact = eg.intersection_volume(cube, cube, shift)
    assert abs(exact - 0.5) <= 1e-12, exact
    assert "numba" not in sys.modules, "numba was imported"
    seconds = time.perf_counter() - start
    print(f"ok: exactgrasp {eg.__version__} from {Path(eg.__file__).parent}, ", end="")
    print(f"descriptor {values.shape}, sum {values.sum():.12g}, {seconds:.1f} s in all, ", end="")
    print(f"counting kernel {kernel.count_inside.__module__}, ", end="")
    print(f"exact kernel {intersector.pose_volumes.__module__}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
