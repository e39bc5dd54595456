"""Warnings about suspicious grasps, recorded in the metadata, and third-party warnings kept
from the users of `run_batch` and of the command line.

Small on purpose: the built-in Barrett hand (palm top at z = 8 cm, open fingers), built-in
boxes, 19 paths x 3 steps, coarse voxel grids.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import exactgrasp as eg
from exactgrasp import diagnostics
from exactgrasp.backends.voxel import VoxelBackend
from exactgrasp.diagnostics import (
    PENETRATION_LIMIT,
    VALUE_LIMIT,
    hull_gap,
    third_party_warnings_ignored,
)
from exactgrasp.errors import warn_caller

SAMPLER = eg.PathSampler(3, 2, 2, n_steps=3)
PARAMS = {"object_resolution": 16, "hand_resolution": 24}
PALM_TOP = 0.08  # m, hand coordinates of eg.hands.barrett()
BOX = (0.06, 0.1, 0.1)
KEYS = ("max_value", "volume_ratio", "size_ratio", "hull_gap_m", "grasp_overlap", "warnings")


def box_grasp(bottom: float, size=BOX, name: str = "box") -> eg.Grasp:
    """The open built-in hand and a box centred over the palm, its bottom face at ``bottom``."""
    pose = np.eye(4)
    pose[2, 3] = bottom + size[2] / 2
    return eg.Grasp(eg.hands.barrett(), eg.objects.box(size), pose, name=name)


def describe(grasp: eg.Grasp, backend: str = "voxel"):
    """The descriptor and the warnings it issued (every one recorded)."""
    params = PARAMS if backend == "voxel" else {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = eg.compute_descriptor(grasp, SAMPLER, eg.get_backend(backend, **params))
    return d, caught


def test_a_box_on_the_palm_warns_nothing():
    grasp = box_grasp(PALM_TOP, name="on the palm")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = eg.compute_descriptor(grasp, SAMPLER, eg.get_backend("voxel", **PARAMS))
    meta = d.metadata
    assert all(key in meta for key in KEYS)
    assert meta["warnings"] == []
    assert meta["hull_gap_m"] == 0.0
    assert 0.0 < meta["grasp_overlap"] < PENETRATION_LIMIT
    assert 0.0 < meta["max_value"] == d.values.max() <= VALUE_LIMIT
    object_volume = float(np.prod(BOX))
    assert meta["volume_ratio"] == pytest.approx(object_volume / grasp.hand.volume, rel=1e-12)


def test_a_far_object_warns_once_with_its_distance():
    grasp = box_grasp(0.5, name="far")
    d, caught = describe(grasp)
    assert not d.values.any()
    assert len(caught) == 1 and caught[0].category is UserWarning
    message = str(caught[0].message)
    assert "'far'" in message and "convex hull" in message and "every value" in message
    # The fingers' tips are the hand's highest points (z = 11.8 cm): the box is 38 cm above.
    gap = d.metadata["hull_gap_m"]
    assert 0.37 < gap < 0.39
    assert f"{gap * 1000:.1f} mm" in message
    assert d.metadata["warnings"] == [message]
    assert caught[0].filename == __file__  # attributed to the caller, not to exactgrasp


def test_an_object_sunk_3_cm_into_the_palm_warns(tmp_path):
    grasp = box_grasp(PALM_TOP - 0.03, name="sunk")
    d, caught = describe(grasp)
    messages = [str(w.message) for w in caught]
    assert len(messages) == 1 and "already overlaps the hand" in messages[0]
    overlap = d.metadata["grasp_overlap"]
    assert overlap > PENETRATION_LIMIT
    # At least the 3 cm slab of the box inside the palm's 9 x 9 cm top: 1.62e-4 m^3 of 6e-4.
    assert overlap >= 0.06 * 0.09 * 0.03 / np.prod(BOX) - 0.02
    assert f"{overlap:.0%} of the object's volume" in messages[0]
    loaded = eg.Descriptor.load(d.save(tmp_path / "sunk.npz"))
    assert loaded.metadata["warnings"] == messages


def test_the_exact_backend_measures_the_same_penetration():
    grasp = box_grasp(PALM_TOP - 0.03, name="sunk")
    d, caught = describe(grasp, "exact")
    assert [w for w in caught if "already overlaps" in str(w.message)]
    # Exactly: the palm's 9 x 9 cm square (corners rounded) under the box's 6 x 10 cm footprint
    # makes 6 x 9 cm, plus what the open proximal links add.
    assert d.metadata["grasp_overlap"] * np.prod(BOX) >= 0.06 * 0.09 * 0.03 * 0.9


def test_a_one_metre_cube_gives_values_above_one_and_says_why():
    grasp = box_grasp(PALM_TOP - 0.5, size=(1.0, 1.0, 1.0), name="cube")
    d, caught = describe(grasp)
    meta = d.metadata
    assert meta["max_value"] == d.values.max() > VALUE_LIMIT
    assert meta["volume_ratio"] == pytest.approx(1.0 / grasp.hand.volume, rel=1e-9)
    above = [str(w.message) for w in caught if "values reach" in str(w.message)]
    assert len(above) == 1
    assert "never exceeds" in above[0] and f"{meta['volume_ratio']:.3g} times" in above[0]
    # The whole hand is inside the cube at the grasp pose: that is also said.
    assert any("of the hand's volume" in str(w.message) for w in caught)


def test_exact_values_stay_at_most_one_for_the_cube():
    grasp = box_grasp(PALM_TOP - 0.5, size=(1.0, 1.0, 1.0), name="cube")
    d, caught = describe(grasp, "exact")
    assert d.values.max() <= VALUE_LIMIT * (1 + diagnostics.VALUE_TOLERANCE)
    assert not [w for w in caught if "values reach" in str(w.message)]


def test_compare_style_repeats_warn_each_descriptor():
    grasp = box_grasp(0.5, name="far")
    first, caught_first = describe(grasp)
    second, caught_second = describe(grasp)
    assert len(caught_first) == len(caught_second) == 1
    assert first.metadata["warnings"] == second.metadata["warnings"]


# -- convex hulls ------------------------------------------------------------------------------


CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float) - 0.5


@pytest.mark.parametrize(
    ("shift", "gap"),
    [((2.0, 0, 0), 1.0), ((2.0, 2.0, 0), np.sqrt(2.0)), ((0.5, 0.5, 0.5), 0.0), ((1, 0, 0), 0)],
)
def test_hull_gap_of_two_cubes(shift, gap):
    assert hull_gap(CUBE, CUBE + shift) == pytest.approx(gap, abs=1e-12)


def test_hull_gap_edge_to_face_and_edge_to_edge():
    # A cube turned 45 degrees about z points an edge at the other cube's face.
    turned = CUBE @ Rotation.from_euler("z", 45, degrees=True).as_matrix().T
    assert hull_gap(CUBE, turned + np.array((2.0, 0, 0))) == pytest.approx(
        1.5 - np.sqrt(0.5), abs=1e-12
    )
    # Two crossed bars, one above the other, each turned 45 degrees about its length: the
    # nearest points lie inside an edge of each.
    bar = CUBE * (4.0, 0.2, 0.2) @ Rotation.from_euler("x", 45, degrees=True).as_matrix().T
    crossed = bar @ Rotation.from_euler("z", 90, degrees=True).as_matrix().T
    edge_height = 0.1 * np.sqrt(2.0)
    gap = hull_gap(bar, crossed + np.array((0, 0, 1.0)))
    assert gap == pytest.approx(1.0 - 2 * edge_height, abs=1e-12)
    # The same bars crossing, no vertex of either inside the other: they meet.
    assert hull_gap(bar, crossed) == 0.0


def test_hull_gap_thins_large_hulls_within_the_limit(monkeypatch):
    sphere = np.random.default_rng(0).normal(size=(400, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    other = sphere + np.array((3.0, 0, 0))
    exact = hull_gap(sphere, other)  # hulls inside unit spheres 3 apart: a little over 1
    monkeypatch.setattr(diagnostics, "MINKOWSKI_POINTS", 10_000)
    thinned = hull_gap(sphere, other)  # one hull of 25 of its 400 points: farther
    assert 1.0 <= exact < 1.05 and exact <= thinned < 1.5


# -- third-party warnings -----------------------------------------------------------------------


def _third_party(name: str):
    """A function whose warnings belong to module ``name``, as a library's would."""
    namespace = {"__name__": name, "warnings": warnings}
    code = textwrap.dedent(
        """
        def noisy():
            warnings.warn("internal deprecation", FutureWarning)
            warnings.warn("internal notice", UserWarning)
        """
    )
    exec(compile(code, f"/site-packages/{name.replace('.', '/')}.py", "exec"), namespace)
    return namespace["noisy"]


@pytest.mark.parametrize("module", ["distributed.worker", "dask", "scipy.sparse", "trimesh"])
def test_third_party_warnings_stop_ours_pass(module):
    noisy = _third_party(module)
    before = list(warnings.filters)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with third_party_warnings_ignored():
            noisy()
            with pytest.raises(UserWarning, match="ours"):
                warn_caller("ours")
            with pytest.raises(UserWarning, match="the caller's"):
                warnings.warn("the caller's", UserWarning, stacklevel=1)
        with pytest.raises(FutureWarning):
            noisy()  # only inside the block
    assert warnings.filters == before


def test_a_package_named_like_a_library_is_not_filtered():
    noisy = _third_party("dasky.tools")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with third_party_warnings_ignored():
            noisy()
    assert len(caught) == 2


@pytest.fixture
def noisy_voxel(monkeypatch):
    """The voxel backend, raising a dask-internal and a mujoco-internal warning per call."""
    internals = [_third_party("distributed.client"), _third_party("mujoco.renderer")]
    volumes = VoxelBackend.volumes

    def noisy_volumes(self, grasp, poses):
        for noisy in internals:
            noisy()
        return volumes(self, grasp, poses)

    monkeypatch.setattr(VoxelBackend, "volumes", noisy_volumes)


def _manifest(folder: Path) -> Path:
    box_grasp(PALM_TOP, name="on").save(folder / "on.json")
    box_grasp(0.5, name="far").save(folder / "far.json")
    manifest = folder / "manifest.jsonl"
    rows = [{"id": "on", "grasp": "on.json"}, {"id": "far", "grasp": "far.json"}]
    manifest.write_text("".join(json.dumps(row) + "\n" for row in rows))
    return manifest


def test_run_batch_keeps_third_party_warnings_and_passes_ours(tmp_path, noisy_voxel):
    pytest.importorskip("pyarrow")
    manifest = _manifest(tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        summary = eg.run_batch(
            manifest,
            tmp_path / "out",
            sampler=SAMPLER,
            backend=eg.get_backend("voxel", **PARAMS),
            workers=0,
        )
    assert summary.done == 2
    messages = [str(w.message) for w in caught]
    assert not [m for m in messages if m.startswith("internal")]
    far = [w for w in caught if "'far'" in str(w.message) and "convex hull" in str(w.message)]
    assert len(far) == 1 and far[0].filename == __file__  # the caller's line
    batch = eg.read_batch(tmp_path / "out")
    far = batch.descriptors[batch.ids.index("far")]
    assert len(far.metadata["warnings"]) == 1


def test_the_command_line_keeps_third_party_warnings(tmp_path, noisy_voxel):
    from exactgrasp.cli import main

    _manifest(tmp_path)
    args = ["descriptor", str(tmp_path / "far.json"), "-o", str(tmp_path / "far.npz")]
    args += ["--sampler", json.dumps(SAMPLER.params)]
    args += [f"--param={key}={value}" for key, value in PARAMS.items()]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(args) == 0
    assert not [w for w in caught if str(w.message).startswith("internal")]
    ours = [w for w in caught if "convex hull" in str(w.message)]
    assert len(ours) == 1 and ours[0].filename == __file__


BATCH_SCRIPT = """
import json, sys
import exactgrasp as eg

if __name__ == "__main__":
    params = json.loads(sys.argv[3])
    summary = eg.run_batch(sys.argv[1], sys.argv[2], sampler=params["sampler"],
                           backend=eg.get_backend("voxel", **params["backend"]),
                           workers=1)
    print(summary.text())
    sys.exit(summary.exit_status)
"""


@pytest.mark.slow
def test_a_dask_batch_runs_under_warnings_as_errors(tmp_path):
    pytest.importorskip("distributed")
    pytest.importorskip("pyarrow")
    manifest = tmp_path / "manifest.jsonl"
    box_grasp(PALM_TOP, name="on").save(tmp_path / "on.json")
    manifest.write_text(json.dumps({"id": "on", "grasp": "on.json"}) + "\n")
    script = tmp_path / "run.py"
    script.write_text(BATCH_SCRIPT)
    params = json.dumps({"sampler": SAMPLER.params, "backend": PARAMS})
    done = subprocess.run(
        [sys.executable, "-W", "error", str(script), str(manifest), str(tmp_path / "out"), params],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "1 done, 0 failed" in done.stdout
    assert "Warning" not in done.stderr, done.stderr[-3000:]


# -- units ------------------------------------------------------------------------------------


def test_an_object_in_metres_read_as_millimetres_is_warned_once():
    """The README's 6 x 10 x 10 cm box, its metre coordinates read with units="mm"."""
    box = eg.objects.box(BOX)
    tiny = eg.Solid(box.vertices, box.faces, units="mm")
    grasp = box_grasp(PALM_TOP, name="metres as mm")
    grasp = eg.Grasp(grasp.hand, tiny, grasp.object_pose, name="metres as mm")
    for backend in ("voxel", "exact"):
        d, caught = describe(grasp, backend)
        small = [str(w.message) for w in caught if "times smaller than the hand" in str(w.message)]
        assert len(small) == 1, backend
        # 0.1 mm against the open hand's 336.6 mm (its longest side, y): 3,366 times smaller.
        assert "3,366 times smaller" in small[0] and "0.1 mm across" in small[0]
        assert "read as millimetres (units='mm')" in small[0]
        assert d.metadata["size_ratio"] == pytest.approx(1e-4 / 0.33663, rel=1e-3)
        assert small[0] in d.metadata["warnings"]


def test_an_object_in_centimetres_read_as_metres_is_warned_once():
    """A 4 cm cube whose file is in centimetres, read in metres: 4 m across."""
    cube = eg.objects.box((0.04, 0.04, 0.04))
    big = eg.Solid(cube.vertices * 100, cube.faces, units="m")
    grasp = eg.Grasp(eg.hands.barrett(), big, box_grasp(PALM_TOP + 2).object_pose, name="cm as m")
    d, caught = describe(grasp)
    large = [str(w.message) for w in caught if "times larger than the hand" in str(w.message)]
    assert len(large) == 1
    assert "11.9 times larger" in large[0] and "4 m across" in large[0]
    assert "read as metres (units='m', the default)" in large[0]
    assert d.metadata["size_ratio"] == pytest.approx(4.0 / 0.33663, rel=1e-3)
    assert large[0] in d.metadata["warnings"]


@pytest.mark.parametrize("size", [(0.0035, 0.0035, 0.0035), (1.0, 1.0, 1.0)])
def test_plausible_sizes_are_not_warned_about(size):
    """A 3.5 mm cube and a 1 m cube beside the 34 cm hand: within `SIZE_RATIO_RANGE`."""
    d, caught = describe(box_grasp(PALM_TOP, size=size))
    assert not [w for w in caught if "than the hand (" in str(w.message)]
    low, high = diagnostics.SIZE_RATIO_RANGE
    assert low < d.metadata["size_ratio"] < high
