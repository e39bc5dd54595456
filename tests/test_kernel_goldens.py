"""The winding-number and voxel kernels give, to the bit, the results the numba kernels gave.

``tests/kernel_goldens/numba_kernels.npz`` holds fuzzed inputs (closed, self-crossing and open
meshes; lattices whose rays pass exactly through vertices, edges and faces; dart-throwing
candidates; a hand grid, an object's points and 400 poses, some across the grid's border and
some far) and the results of the numba kernels of commit 98cb945 on them, recorded by
``tests/kernel_goldens/record.py``. Floats are compared by their bytes: a sign of zero or the
last bit of a winding number differing fails.
"""

from __future__ import annotations

import importlib.util
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from exactgrasp.backends.voxel.kernel import count_inside
from exactgrasp.backends.voxel.points import dart_throw
from exactgrasp.geometry.winding import (
    winding_inside_lattice,
    winding_number,
)

HERE = Path(__file__).resolve().parent / "kernel_goldens"
GOLDEN = dict(np.load(HERE / "numba_kernels.npz"))


def cases(kind: str) -> list[str]:
    """The case names of one kernel (``winding``, ``lattice``, ``dart``)."""
    return sorted({key.split("/")[1] for key in GOLDEN if key.startswith(kind + "/")})


def assert_same_bits(got, want) -> None:
    got = np.asarray(got)
    assert got.dtype == want.dtype and got.shape == want.shape, (got.dtype, got.shape)
    if got.dtype.kind == "f":
        mismatch = np.flatnonzero(got.view(np.uint8) != want.view(np.uint8))
        assert not len(mismatch), f"{len(mismatch)} bytes differ, e.g. {got.ravel()[:4]}"
    else:
        np.testing.assert_array_equal(got, want)


def test_the_recorded_cases_are_not_trivial():
    assert cases("winding") == ["boxes", "crumpled", "open", "sphere"]
    assert len(cases("lattice")) == 6 and len(cases("dart")) == 5
    inside = GOLDEN["winding/sphere/result"]
    assert inside[0] == 1.0 and np.count_nonzero(np.round(inside) == 1) == 63
    # The box [1, 6] x [1, 5] x [1, 7]: a node on a face counts on one side only.
    box = np.argwhere(GOLDEN["lattice/integer_box/result"])
    assert len(box) == 120 and box.min(axis=0).tolist() == [1, 1, 1]
    assert box.max(axis=0).tolist() == [5, 4, 6]
    assert tuple(GOLDEN["lattice/crumpled/range"]) == (-2, 1)
    assert len(GOLDEN["dart/cube/result"]) == 694 and list(GOLDEN["dart/repeated/result"]) == [0]
    counts = GOLDEN["count/result"]
    assert np.count_nonzero(counts.sum(axis=1)) == 233
    assert counts.max(axis=0).tolist() == [880, 280]
    assert not counts[-5:].any()  # the far poses


@pytest.mark.parametrize("case", cases("winding"))
def test_winding_numbers(case):
    V, F = GOLDEN[f"winding/{case}/V"], GOLDEN[f"winding/{case}/F"]
    got = np.array([winding_number(p, V, F) for p in GOLDEN[f"winding/{case}/points"]])
    assert_same_bits(got, GOLDEN[f"winding/{case}/result"])


def test_winding_number_takes_any_layout_and_index_type():
    V, F = GOLDEN["winding/crumpled/V"], GOLDEN["winding/crumpled/F"]
    points, want = GOLDEN["winding/crumpled/points"], GOLDEN["winding/crumpled/result"]
    wide = np.zeros((len(V), 6))
    wide[:, ::2] = V
    frozen = V.copy()
    frozen.flags.writeable = False
    layouts = [(wide[:, ::2], F), (frozen, F.astype(np.int32)), (V, F.astype(np.uint32))]
    for verts, faces in layouts:
        got = np.array([winding_number(p, verts, faces) for p in points.T.copy().T[:40]])
        assert_same_bits(got, want[:40])


@pytest.mark.parametrize("case", cases("lattice"))
def test_lattice_winding_numbers(case):
    triangles = GOLDEN[f"lattice/{case}/triangles"]
    nx, ny, nz = (int(n) for n in GOLDEN[f"lattice/{case}/shape"])
    inside = winding_inside_lattice(triangles, nx, ny, nz)
    assert_same_bits(inside, GOLDEN[f"lattice/{case}/result"])


@pytest.mark.parametrize("case", cases("dart"))
def test_dart_throwing(case):
    points, spacing = GOLDEN[f"dart/{case}/points"], float(GOLDEN[f"dart/{case}/spacing"])
    assert_same_bits(dart_throw(points, spacing), GOLDEN[f"dart/{case}/result"])


def variants() -> list:
    """The counting kernels built here: the one `kernel` picked, and both compiled builds
    (the plain one and, on an x86-64 CPU with AVX2, the AVX2 one) where they exist."""
    found = [count_inside]
    try:
        from exactgrasp.backends.voxel import _kernel
    except ImportError:  # the numba kernels: one variant
        return found
    found.append(_kernel.count_inside)
    if _kernel.cpu_has_avx2():
        from exactgrasp.backends.voxel import _kernel_avx2

        found.append(_kernel_avx2.count_inside)
    return found


def _count(kernel, tiles_key: str, shift_key: str, pieces: int) -> np.ndarray:
    """The counts of every pose, the poses split into `pieces` counted on as many threads."""
    a = {key.split("/", 1)[1]: value for key, value in GOLDEN.items() if key.startswith("count/")}
    counts = np.zeros((len(a["linear"]), 2), np.int64)

    def run(first: int, last: int) -> None:
        kernel(
            a["linear"], a["offset"], a["coords"], int(a["n_interior"]), float(a["extent"]),
            a["boxes"], a["ranges"], int(a["n_roots"]), int(a["first_leaf"]), a["codes"],
            a[tiles_key], int(a[shift_key]), first, last, counts,
        )  # fmt: skip

    edges = np.linspace(0, len(counts), pieces + 1).astype(int)
    with ThreadPoolExecutor(pieces) as pool:
        list(pool.map(run, edges[:-1], edges[1:]))
    return counts


@pytest.mark.parametrize("pieces", [1, 3])
@pytest.mark.parametrize("tiles", ["", "coarse/"])
@pytest.mark.parametrize("variant", range(len(variants())))
def test_counts(variant, tiles, pieces):
    got = _count(variants()[variant], tiles + "tiles", tiles + "shift", pieces)
    assert_same_bits(got, GOLDEN["count/" + tiles + "result"])


def test_the_recording_script_makes_the_stored_inputs():
    """The inputs are the script's, so a case can be added to it and recorded again."""
    spec = importlib.util.spec_from_file_location("kernel_record", HERE / "record.py")
    record = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(record)
    made = record.inputs()
    stored = {k for k in GOLDEN if not k.endswith(("/result", "/range"))}
    assert set(made) == stored
    for key in ("winding/open/points", "dart/long/points", "count/linear", "count/tiles"):
        assert_same_bits(made[key], GOLDEN[key])
