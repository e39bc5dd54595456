"""The compiled kernels give, to the bit, the results the numba kernels gave.

``tests/kernel_goldens/numba_kernels.npz`` holds fuzzed inputs (closed, self-crossing and open
meshes; lattices whose rays pass exactly through vertices, edges and faces; dart-throwing
candidates; a hand grid, an object's points and 400 poses, some across the grid's border and
some far) and the results of the numba winding-number and voxel kernels of commit 98cb945 on
them, recorded by ``tests/kernel_goldens/record.py``. ``numba_crossings.npz`` holds meshes
(the tests' solids that touch or cross themselves, as built and moved; triangle soups; the
meshes the intake scans while it resolves them) and what the numba `find_crossings` and
`find_contacts` of commit 473962b returned on them, with the results on the messy-hand
benchmark's palm and the shared data's LEAP Hand link, recorded by
``tests/kernel_goldens/record_crossings.py``. Floats are compared by their bytes: a sign of
zero or the last bit of a winding number or a crossing point differing fails.
"""

from __future__ import annotations

import importlib.util
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from exactgrasp.backends._builds import cpu_has_avx2
from exactgrasp.backends.voxel.kernel import count_inside
from exactgrasp.backends.voxel.points import dart_throw
from exactgrasp.geometry.winding import (
    winding_inside_lattice,
    winding_number,
)

HERE = Path(__file__).resolve().parent / "kernel_goldens"
GOLDEN = dict(np.load(HERE / "numba_kernels.npz"))
CROSSINGS = dict(np.load(HERE / "numba_crossings.npz"))


def script(name: str):
    """A recording script of ``tests/kernel_goldens`` as a module."""
    spec = importlib.util.spec_from_file_location(f"kernel_{name}", HERE / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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
    except ImportError:  # no compiled build here: the one variant `kernel` picked
        return found
    found.append(_kernel.count_inside)
    if cpu_has_avx2():
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
    made = script("record").inputs()
    stored = {k for k in GOLDEN if not k.endswith(("/result", "/range"))}
    assert set(made) == stored
    for key in ("winding/open/points", "dart/long/points", "count/linear", "count/tiles"):
        assert_same_bits(made[key], GOLDEN[key])


# -- crossings ---------------------------------------------------------------------------------

RECORD_CROSSINGS = script("record_crossings")


def meshes(group: str) -> list[str]:
    """The stored meshes of one group (``built``, ``fuzz``, ``intake``)."""
    return sorted(k[:-2] for k in CROSSINGS if k.startswith(group + "/") and k.endswith("/V"))


def assert_same_scans(case: str, V, F, label, ident) -> None:
    got = RECORD_CROSSINGS.scan(V, F, label, ident)
    assert {f"{case}/{k}" for k in got} == {k for k in CROSSINGS if k.startswith(case + "/")} - {
        f"{case}/{k}" for k in ("V", "F", "label", "ident", "sha256")
    }
    for key, value in got.items():
        try:
            assert_same_bits(value, CROSSINGS[f"{case}/{key}"])
        except AssertionError as exc:
            raise AssertionError(f"{case}/{key}: {exc}") from None


def test_the_recorded_crossings_are_not_trivial():
    assert len(meshes("built")) == 41 and len(meshes("fuzz")) == 10
    assert len(meshes("intake")) > 100
    # (pairs apart, certain crossings, uncertain contacts): the soup on a grid has both; turned,
    # fewer of its contacts are seen at all; with its bound overflowing, every sign uncertain.
    codes = {
        f"{case}/{mode}": np.bincount(CROSSINGS[f"{case}/{mode}/code"], minlength=3).tolist()
        for case in ("fuzz/grid", "fuzz/grid_rotated", "fuzz/overflowing_bound", "large/palm")
        for mode in ("crossings", "self")
    }
    assert codes == {
        "fuzz/grid/crossings": [0, 71, 583],
        "fuzz/grid/self": [0, 71, 706],
        "fuzz/grid_rotated/crossings": [0, 71, 507],
        "fuzz/grid_rotated/self": [0, 71, 610],
        "fuzz/overflowing_bound/crossings": [0, 0, 1046],
        "fuzz/overflowing_bound/self": [0, 0, 1180],
        "large/palm/crossings": [0, 1704, 0],
        "large/palm/self": [0, 1704, 0],
    }
    # The palm's 1,704 certain crossings, each with a point; the link's four-face edges.
    palm = CROSSINGS["large/palm/self/point"]
    assert palm.shape == (1704, 3) and np.isfinite(palm).all()
    assert len(CROSSINGS["large/dip_link/self/t"]) == 190


@pytest.mark.parametrize("group", ["built", "fuzz", "intake"])
def test_crossings_and_contacts(group):
    for case in meshes(group):
        arrays = [CROSSINGS[f"{case}/{k}"] for k in ("V", "F", "label", "ident")]
        assert_same_scans(case, *arrays)


@pytest.mark.parametrize("name", ["palm", "dip_link"])
def test_crossings_of_large_meshes(name):
    from tests.conftest import SHARED_DATA

    mesh = (
        RECORD_CROSSINGS.messy_palm() if name == "palm" else RECORD_CROSSINGS.dip_link(SHARED_DATA)
    )
    if mesh is None:
        pytest.skip(f"shared data not found at {SHARED_DATA} (set EXACTGRASP_DATA)")
    arrays = RECORD_CROSSINGS.with_shells(*mesh)
    assert_same_bits(RECORD_CROSSINGS.digest(*arrays.values()), CROSSINGS[f"large/{name}/sha256"])
    assert_same_scans(f"large/{name}", *arrays.values())


def test_crossings_on_threads_at_once():
    """The kernels hold no state between calls: scans on three threads at once agree."""
    cases = meshes("fuzz") + meshes("built")

    def run(case: str) -> None:
        assert_same_scans(case, *(CROSSINGS[f"{case}/{k}"] for k in ("V", "F", "label", "ident")))

    with ThreadPoolExecutor(3) as pool:
        list(pool.map(run, cases * 2))


def test_the_crossing_script_makes_the_stored_meshes():
    made = RECORD_CROSSINGS.inputs()
    stored = {k for k in CROSSINGS if k.startswith(("built/", "fuzz/")) and k.count("/") == 2}
    assert set(made) == stored
    for key in made:
        assert_same_bits(made[key], CROSSINGS[key])


def test_the_scans_entries_are_ordered_alike_packed_in_one_integer_or_not():
    from exactgrasp.geometry.crossings import _by_cell

    rng = np.random.default_rng(11)
    tris = rng.integers(0, 500, 4000)
    for top in (1000, 2**60):  # packed into one integer; too large for that: two keys
        keys = rng.integers(0, top, 4000)
        keys[::7] = keys[0]  # cells with several triangles
        got = _by_cell(keys, tris, 500)
        order = np.lexsort((tris, keys))
        np.testing.assert_array_equal(got[0], keys[order])
        np.testing.assert_array_equal(got[1], tris[order])
