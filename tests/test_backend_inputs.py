"""What every backend accepts: rigid poses only, checked options, and culling that decides each
shell of a multi-shell hand or object."""

from __future__ import annotations

import numpy as np
import pytest

from exactgrasp.backends.base import check_poses
from exactgrasp.backends.exact import ExactBackend, ExactIntersector
from exactgrasp.backends.params import Interval, Options, Param, validate_parameters
from exactgrasp.backends.voxel import VoxelBackend
from exactgrasp.errors import BackendError
from tests.conftest import box_arrays

BROADPHASES = (None, "coal", "fcl")


def shells(*meshes):
    """One mesh holding every given (V, F) shell."""
    vertices, faces, offset = [], [], 0
    for V, F in meshes:
        vertices.append(V)
        faces.append(np.asarray(F) + offset)
        offset += len(V)
    return np.vstack(vertices), np.vstack(faces)


def reversed_box(lo, hi):
    V, F = box_arrays(lo, hi)
    return V, F[:, ::-1].copy()


def translations(*offsets):
    P = np.tile(np.eye(4), (len(offsets), 1, 1))
    P[:, :3, 3] = offsets
    return P


# -- culling decides each shell --------------------------------------------------------------


def test_two_cube_object_one_inside_one_far_gives_the_inner_cube_under_every_broadphase():
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    obj = [shells(box_arrays([0.3, 0.3, 0.3], [0.5, 0.5, 0.5]), box_arrays([5, 5, 5], [6, 6, 6]))]
    poses = translations([0, 0, 0], [0.1, 0, 0], [-20, 0, 0])
    results = {}
    for broadphase in BROADPHASES:
        ex = ExactIntersector(hand, obj, broadphase=broadphase)
        result = ex.intersect(poses)
        results[broadphase] = result.volumes
        if broadphase is not None:
            # Only the pose with both cubes away from the hand is culled.
            assert result.stats["poses_culled"] == 1
    np.testing.assert_allclose(results[None], [0.008, 0.008, 0.0], rtol=1e-12, atol=0)
    assert results[None][2] == 0.0
    for broadphase in ("coal", "fcl"):
        np.testing.assert_array_equal(results[broadphase], results[None])


def test_two_link_hand_one_link_around_the_object_gives_the_object_under_every_broadphase():
    hand = [box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([5, 5, 5], [6, 6, 6])]
    obj = [box_arrays([0.2, 0.2, 0.2], [0.4, 0.4, 0.4])]
    # Object inside link 0; inside link 1 (5.2..5.4); between the links; far away.
    poses = translations([0, 0, 0], [5, 5, 5], [2.5, 2.5, 2.5], [-20, 0, 0])
    results = {bp: ExactIntersector(hand, obj, broadphase=bp).volumes(poses) for bp in BROADPHASES}
    np.testing.assert_allclose(results[None], [0.008, 0.008, 0.0, 0.0], rtol=1e-12, atol=0)
    for broadphase in ("coal", "fcl"):
        np.testing.assert_array_equal(results[broadphase], results[None])


def test_hollow_hand_object_in_the_cavity_is_zero_and_object_around_it_is_the_shell_volume():
    outer, inner = ([-1, -1, -1], [1, 1, 1]), ([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5])
    hand = [shells(box_arrays(*outer), reversed_box(*inner))]
    obj = [box_arrays([-0.1, -0.1, -0.1], [0.1, 0.1, 0.1])]
    big = [box_arrays([-3, -3, -3], [3, 3, 3])]
    shell_volume = 8.0 - 1.0
    poses = translations([0, 0, 0], [0.2, 0.2, 0.2], [0, 0, 0.45], [10, 0, 0])
    for broadphase in BROADPHASES:
        small = ExactIntersector(hand, obj, broadphase=broadphase).volumes(poses)
        np.testing.assert_array_equal(small[[0, 1, 3]], [0.0, 0.0, 0.0])
        # Poking 0.05 into the cavity's wall: 0.2 x 0.2 x 0.05 inside the wall.
        np.testing.assert_allclose(small[2], 0.002, rtol=1e-12)
        around = ExactIntersector(hand, big, broadphase=broadphase).volumes(poses[:1])
        np.testing.assert_allclose(around, [shell_volume], rtol=1e-12)


def test_object_holding_the_whole_hand_is_computed_not_culled():
    hand = [box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([2, 0, 0], [3, 1, 1])]
    obj = [box_arrays([-1, -1, -1], [4, 2, 2])]
    poses = translations([0, 0, 0], [0.01, 0, 0])
    results = {bp: ExactIntersector(hand, obj, broadphase=bp).volumes(poses) for bp in BROADPHASES}
    np.testing.assert_allclose(results[None], [2.0, 2.0], rtol=1e-12)
    for broadphase in ("coal", "fcl"):
        np.testing.assert_array_equal(results[broadphase], results[None])


# -- poses must be rigid motions -------------------------------------------------------------


# The generic pose checks (every kind of non-rigid pose refused with its index, rigid poses
# within rounding accepted) run on every backend in tests/test_backend_conformance.py.


def test_a_single_pose_is_named_without_an_index():
    pose = np.eye(4)
    pose[1, 1] = -1
    with pytest.raises(BackendError, match=r"^poses is not a rigid motion: .*reflection"):
        check_poses(pose)


def test_a_determinant_just_off_one_says_how_far_it_is():
    pose = np.eye(4)
    pose[:3, :3] *= np.sqrt(1.0 + 0.9e-9)  # orthonormal to 0.9e-9, determinant 1 + 1.35e-9
    with pytest.raises(
        BackendError,
        match=r"^poses is not a rigid motion: its rotation part has determinant "
        r"1\.00000000135\d*, 1\.35e-09 from 1\. ",
    ):
        check_poses(pose)


# -- options are checked in the constructor --------------------------------------------------

CELL = "must be a positive, finite number or None, got"
BAD_OPTIONS = [
    ({"hand_cell": -1}, f"hand_cell {CELL} -1 .grid cell edge, same units as the meshes"),
    ({"hand_cell": float("nan")}, f"hand_cell {CELL} nan"),
    ({"hand_cell": float("inf")}, f"hand_cell {CELL} inf"),
    ({"hand_cell": 0}, f"hand_cell {CELL} 0"),
    ({"object_cell": "fine"}, f"object_cell {CELL} 'fine'"),
    ({"capacity": -5}, "capacity must be a positive integer, got -5 .edge crossings"),
    ({"capacity": 2.5}, "capacity must be a positive integer, got 2.5"),
    ({"n_jobs": 0}, "n_jobs must be a positive integer, -1 or None, got 0"),
    ({"n_jobs": True}, "n_jobs must be a positive integer, -1 or None, got True"),
    ({"broadphase": "bullet"}, "broadphase must be 'coal', 'fcl' or None, got 'bullet'"),
]


@pytest.mark.parametrize(("options", "message"), BAD_OPTIONS)
def test_exact_options_are_refused_in_both_constructors_with_the_option_named(options, message):
    options = {"broadphase": None, **options}
    with pytest.raises(BackendError, match=f"^ExactBackend: {message}"):
        ExactBackend(**options)
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    with pytest.raises(BackendError, match=message):
        ExactIntersector(hand, hand, **options)


def test_an_unknown_exact_option_is_refused_naming_it():
    # The backend's options are its constructor's arguments: Python refuses an unknown one.
    with pytest.raises(TypeError, match="'cell'"):
        ExactBackend(broadphase=None, cell=0.1)
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    unknown = r"unknown parameters \['cell'\]; it takes broadphase, n_jobs, hand_cell"
    with pytest.raises(BackendError, match=unknown):
        ExactIntersector(hand, hand, broadphase=None, cell=0.1)


def test_a_cell_option_that_would_lay_a_huge_grid_is_refused_with_the_smallest_allowed():
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    with pytest.raises(BackendError, match=r"hand_cell=1e-06 lays 1e\+18 grid cells .* at least"):
        ExactIntersector(hand, hand, broadphase=None, hand_cell=1e-6)


def test_explicit_cells_are_used_and_recorded():
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    obj = [box_arrays([0.5, 0.5, 0.5], [1.5, 1.5, 1.5])]
    ex = ExactIntersector(hand, obj, broadphase=None, hand_cell=0.25, object_cell=0.125)
    assert ex.tuning["hand_cell"] == 0.25 and ex.tuning["object_cell"] == 0.125
    np.testing.assert_allclose(ex.volumes(np.eye(4)), 0.125, rtol=1e-12)


def test_checked_options_become_plain_numbers_in_params():
    be = ExactBackend(broadphase=None, n_jobs=np.int64(2), capacity=np.int64(10), hand_cell=1)
    assert be.params == {"broadphase": None, "n_jobs": 2, "capacity": 10, "hand_cell": 1.0}
    # in the constructor's order, whatever order they were given in
    assert list(be.params) == ["broadphase", "n_jobs", "hand_cell", "capacity"]
    assert [type(v) for v in be.params.values()] == [type(None), int, float, int]
    assert ExactBackend(broadphase=None, object_cell=None).params == {
        "broadphase": None,
        "n_jobs": None,
    }
    voxel = VoxelBackend(hand_resolution=np.int64(20), surface_spacing=np.float32(2))
    assert type(voxel.params["hand_resolution"]) is int
    assert type(voxel.params["surface_spacing"]) is float


# -- the declared-constraints helper ---------------------------------------------------------

TABLE = {
    "count": Param(None, Interval(int, 1, 10_000_000), Options(("auto",)), hint="how many"),
    "fraction": Param(Interval(float, 0, 1, closed="left")),
    "flag": Param("boolean"),
    "hook": Param(callable, None),
    "name": Param(str),
}


@pytest.mark.parametrize(
    ("params", "message"),
    [
        (
            {"count": 0},
            "count must be None, an integer from 1 to 10,000,000 or 'auto', got 0 .how",
        ),
        ({"count": True}, "count must be None, .* got True"),
        ({"count": "AUTO"}, "count must be None, .* got 'AUTO'"),
        ({"fraction": 1}, r"fraction must be a number in \[0, 1\), got 1\.$"),
        ({"fraction": float("nan")}, "fraction must be .* got nan"),
        ({"flag": 1}, "flag must be True or False, got 1"),
        ({"hook": 3}, "hook must be a callable or None, got 3"),
        ({"name": b"x"}, "name must be a str, got b'x'"),
        ({"size": 3}, r"unknown parameters \['size'\]; it takes count, fraction, flag, hook"),
    ],
)
def test_validate_parameters_names_owner_parameter_value_and_what_is_allowed(params, message):
    with pytest.raises(BackendError, match=f"^Toy: {message}"):
        validate_parameters(TABLE, params, "Toy")


def test_the_documented_example_of_a_refusal():
    # docs/backends.md: SpheresBackend(radius=-1).
    table = {"radius": Param(Interval(float, 0, None, closed="neither"), hint="sphere radius, m")}
    with pytest.raises(
        BackendError,
        match=r"^SpheresBackend: radius must be a positive, finite number, got -1 \(sphere "
        r"radius, m\)\.$",
    ):
        validate_parameters(table, {"radius": -1}, "SpheresBackend")


def test_options_never_take_a_bool_for_0_or_1():
    table = {"bit": Param(Options((0, 1)))}
    for flag in (True, False, np.bool_(True)):
        with pytest.raises(BackendError, match=rf"^Toy: bit must be 0 or 1, got {flag!r}\.$"):
            validate_parameters(table, {"bit": flag}, "Toy")
    # A listed value comes back as listed: a plain int for numpy's, as JSON needs.
    out = validate_parameters(table, {"bit": np.int64(1)}, "Toy")
    assert out == {"bit": 1} and type(out["bit"]) is int


def test_validate_parameters_returns_plain_values():
    out = validate_parameters(
        TABLE,
        {"count": np.int32(3), "fraction": 0, "flag": np.bool_(True), "hook": None, "name": "a"},
        "Toy",
    )
    assert out == {"count": 3, "fraction": 0.0, "flag": True, "hook": None, "name": "a"}
    assert [type(v) for v in out.values()] == [int, float, bool, type(None), str]
    assert validate_parameters(TABLE, {"count": "auto"}, "Toy") == {"count": "auto"}
