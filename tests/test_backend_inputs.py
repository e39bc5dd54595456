"""What every backend accepts: rigid poses only, checked options, and culling that decides each
shell of a multi-shell hand or object."""

from __future__ import annotations

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.backends.exact import ExactBackend, ExactIntersector
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
        results[broadphase] = ex.volumes(poses)
        if broadphase is not None:
            # Only the pose with both cubes away from the hand is culled.
            assert ex.stats["poses_culled"] == 1
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


@pytest.fixture
def grasp():
    hand = eg.Hand.from_meshes(
        [box_arrays([-0.05, -0.05, 0.0], [0.05, 0.05, 0.02])], frame=eg.HandFrame.identity()
    )
    return eg.Grasp(hand, eg.Solid(*box_arrays([0, 0, 0], [0.01, 0.01, 0.01])), name="g")


def _not_rigid(kind: str) -> np.ndarray:
    poses = np.tile(np.eye(4), (4, 1, 1))
    bad = poses[2]
    if kind == "reflection":
        bad[0, 0] = -1.0
    elif kind == "scale":
        bad[:3, :3] *= 1.5
    elif kind == "shear":
        bad[0, 1] = 0.3
    elif kind == "last row":
        bad[3, 0] = 0.2
    elif kind == "slightly scaled":
        bad[:3, :3] *= 1.0 + 1e-7
    return poses


NOT_RIGID = {
    "reflection": "determinant -1 (a reflection)",
    "scale": "not orthonormal",
    "shear": "not orthonormal",
    "last row": "last row is [0.2, 0.0, 0.0, 1.0]",
    "slightly scaled": "not orthonormal",
}


@pytest.mark.parametrize("backend", ["voxel", "exact"])
@pytest.mark.parametrize("kind", sorted(NOT_RIGID))
def test_every_backend_refuses_a_pose_that_is_not_rigid_and_names_it(grasp, backend, kind):
    params = {"broadphase": None} if backend == "exact" else {"hand_resolution": 20}
    be = eg.get_backend(backend, **params)
    with pytest.raises(BackendError) as err:
        be.volumes(grasp, _not_rigid(kind))
    message = str(err.value)
    assert "poses[2] is not a rigid motion" in message
    assert NOT_RIGID[kind] in message


def test_rigid_poses_within_rounding_are_accepted(grasp):
    poses = np.tile(np.eye(4), (2, 1, 1))
    poses[1, :3, :3] *= 1.0 + 1e-12
    for be in (VoxelBackend(hand_resolution=20), ExactBackend(broadphase=None)):
        assert be.volumes(grasp, poses).shape == (2,)


def test_a_single_pose_is_named_without_an_index():
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    ex = ExactIntersector(hand, hand, broadphase=None)
    pose = np.eye(4)
    pose[1, 1] = -1
    with pytest.raises(BackendError, match=r"^poses is not a rigid motion: .*reflection"):
        ex.volumes(pose)


# -- options are checked in the constructor --------------------------------------------------

BAD_OPTIONS = [
    ({"hand_cell": -1}, "hand_cell must be a positive, finite length"),
    ({"hand_cell": float("nan")}, "hand_cell must be a positive, finite length"),
    ({"hand_cell": 0}, "hand_cell must be a positive, finite length"),
    ({"object_cell": "fine"}, "object_cell must be a positive length"),
    ({"capacity": -5}, "capacity must be a positive integer"),
    ({"capacity": 2.5}, "capacity must be a positive integer"),
    ({"n_jobs": 0}, "n_jobs must be a positive integer or -1"),
    ({"n_jobs": True}, "n_jobs must be a positive integer or -1"),
    ({"broadphase": "bullet"}, "unknown broadphase 'bullet'"),
    ({"cell": 0.1}, r"unknown tuning options \['cell'\]"),
]


@pytest.mark.parametrize(("options", "message"), BAD_OPTIONS)
def test_exact_options_are_refused_in_both_constructors_with_the_option_named(options, message):
    options = {"broadphase": None, **options}
    with pytest.raises(BackendError, match=message):
        ExactBackend(**options)
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    with pytest.raises(BackendError, match=message):
        ExactIntersector(hand, hand, **options)


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
