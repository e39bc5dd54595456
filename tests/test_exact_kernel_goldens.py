"""The compiled exact kernel gives, to the bit, what the numba kernel gave.

``tests/kernel_goldens/numba_exact.npz`` holds, for 377 scenes (the built-in Barrett hand with
the bottle, the box and the cylinder, volumes only and with moments per link and per face;
the hand and box scaled by 1e-3 and 1e3 and far from the origin; a crossing capacity that
overflows; the touching solids of `tests.touching_meshes`), the poses and what the numba
`pose_volumes` of commit 09a1e26 returned: volumes, bounds, codes, statistics and moment
entries (the entries' rows and values as a SHA-256 of their bytes), recorded by
``tests/kernel_goldens/record_exact.py``. The scenes' tables are built again here, so the
compiled grid rasteriser and face terms are checked with them. Floats are compared by their
bytes.
"""

from __future__ import annotations

import importlib
import importlib.util
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from exactgrasp.backends._builds import cpu_has_avx2
from exactgrasp.backends.exact import intersector

HERE = Path(__file__).resolve().parent / "kernel_goldens"
GOLDEN = dict(np.load(HERE / "numba_exact.npz"))


def _record():
    spec = importlib.util.spec_from_file_location("record_exact", HERE / "record_exact.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


RECORD = _record()
SCENES = list(RECORD.scenes())
LABELS = [scene[0] for scene in SCENES]


def _same(got: dict, label: str) -> list[str]:
    """The outputs of one scene that differ from the golden, by name."""
    differ = []
    for key in RECORD.OUTPUTS:
        want = GOLDEN[f"{label}/{key}"]
        value = RECORD.digest(got[key]) if key in RECORD.HASHED else got[key]
        if value.dtype.kind == "f":
            same = value.shape == want.shape and value.tobytes() == want.tobytes()
        else:
            same = np.array_equal(value, want)
        if not same:
            differ.append(key)
    return differ


def test_the_goldens_are_not_trivial():
    codes = np.concatenate([GOLDEN[k] for k in GOLDEN if k.endswith("/codes")])
    volumes = np.concatenate([GOLDEN[k] for k in GOLDEN if k.endswith("/volumes")])
    # Every outcome a pose can have: exact, undecided (left to the limit) and overflowed.
    assert {0, 2, 3} <= set(codes.tolist())
    assert (volumes > 0).sum() > 1000
    assert len(LABELS) - len(GOLDEN["refused"]) == 377


def builds() -> list[str]:
    """The exact kernel's compiled builds here: the baseline one and, on an x86-64 CPU with
    AVX2, the AVX2 one (`exactgrasp.backends._builds`)."""
    names = ["exactgrasp.backends.exact._kernel"]
    if cpu_has_avx2() and importlib.util.find_spec(names[0] + "_avx2") is not None:
        names.append(names[0] + "_avx2")
    return names


def test_the_intersector_runs_the_fastest_build():
    assert intersector.pose_volumes is importlib.import_module(builds()[-1]).pose_volumes


@pytest.mark.parametrize("build", builds())
@pytest.mark.parametrize("chunk", range(8))
def test_the_compiled_kernel_gives_numbas_bits(chunk, build, monkeypatch):
    monkeypatch.setattr(intersector, "pose_volumes", importlib.import_module(build).pose_volumes)
    bad = {}
    for scene in SCENES[chunk::8]:
        label = scene[0]
        got = RECORD.run_kernel(*scene)
        if got is None:
            assert label in GOLDEN["refused"], label
            continue
        np.testing.assert_array_equal(GOLDEN[f"{label}/poses"], scene[3])
        differ = _same(got, label)
        if differ:
            bad[label] = differ
    assert not bad, f"{len(bad)} scenes differ, e.g. {next(iter(bad.items()))}"


def test_threads_give_the_same_bits():
    scenes = [s for s in SCENES if s[0].startswith("barrett/") and "/faces" in s[0]]
    with ThreadPoolExecutor(3) as pool:
        results = list(pool.map(lambda s: RECORD.run_kernel(*s), scenes))
    assert all(not _same(got, s[0]) for got, s in zip(results, scenes, strict=True))


def test_the_compiled_constants_are_the_python_ones():
    # ``_constants.pxd`` writes out the integers of `tables` and the floats of `tolerances`.
    import re

    from exactgrasp.backends.exact import tables, tolerances

    text = (Path(tables.__file__).parent / "_constants.pxd").read_text()
    ints = dict(re.findall(r"^    ([A-Z_0-9]+) = (-?\d+)$", text, re.M))
    floats = dict(re.findall(r"static const double EG_([A-Z_0-9]+) = (\S+);", text))
    want_ints = {k: v for k, v in vars(tables).items() if k.isupper() and type(v) is int}
    want_floats = {k: v for k, v in vars(tolerances).items() if k.isupper() and type(v) is float}
    assert {k: int(v) for k, v in ints.items()} == want_ints
    assert {k: float(v) for k, v in floats.items()} == want_floats
