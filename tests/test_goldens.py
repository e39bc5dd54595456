"""Regression goldens: descriptors of fixed grasps, small sampler, both backends.

The goldens live in ``tests/goldens/<case>.<backend>.npz`` (19 paths x 3 steps; the built-in
hand on demo objects, and the real Barrett ``noise_grasp0`` and one cereal-box grasp when the
shared data is there). When a default changes on purpose, regenerate them and commit the
result::

    python tests/goldens/regenerate.py [--backend voxel|exact] [--case NAME]

Tolerances (see ``docs/batch.md``): ``rtol=1e-9, atol=1e-12`` on the values for both backends.
The voxel estimator counts points, so equal counts give values equal to rounding; a single
point changing sides moves a value by at least one voxel over the hand volume (about 1e-6 for
the paper's grids), far outside the tolerance. The exact backend's boolean volumes are
double-precision and reproducible to far better than 1e-9 relative.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import exactgrasp as eg

RTOL, ATOL = 1e-9, 1e-12

_spec = importlib.util.spec_from_file_location(
    "golden_regenerate", Path(__file__).parent / "goldens" / "regenerate.py"
)
regenerate = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(regenerate)

REGENERATE = "python tests/goldens/regenerate.py"


@pytest.mark.parametrize("backend", regenerate.BACKENDS)
@pytest.mark.parametrize("case", sorted(regenerate.CASES))
def test_golden(case, backend, request):
    if not regenerate.backend_available(backend):
        pytest.skip(f"the {backend!r} backend is not available here")
    if regenerate.CASES[case][1]:
        request.getfixturevalue("shared_data")  # skips with a reason when absent
    if missing := regenerate.package_missing(case):
        pytest.skip(f"the case's hand needs the package {missing} (exactgrasp[hands])")
    path = regenerate.golden_path(case, backend)
    if not path.exists():
        pytest.fail(f"no golden {path.name}; create it with `{REGENERATE} --backend {backend}`")
    golden = eg.Descriptor.load(path)
    got = regenerate.compute(case, backend)
    meta, want = got.metadata, golden.metadata
    hint = f"if this change is intended, run `{REGENERATE} --backend {backend} --case {case}`"
    assert meta["sampler"] == want["sampler"], hint
    assert meta["backend_params"] == want["backend_params"], f"defaults changed; {hint}"
    np.testing.assert_allclose(
        meta["hand_volume_canonical"], want["hand_volume_canonical"], rtol=RTOL, err_msg=hint
    )
    np.testing.assert_allclose(got.values, golden.values, rtol=RTOL, atol=ATOL, err_msg=hint)


def test_goldens_are_not_trivial():
    # A golden of all zeros would pass against a backend that lost every intersection.
    for path in sorted(regenerate.GOLDEN_DIR.glob("*.npz")):
        values = eg.Descriptor.load(path).values
        assert values.shape == (19, 3), path.name
        assert np.count_nonzero(values) > values.size // 2, path.name
