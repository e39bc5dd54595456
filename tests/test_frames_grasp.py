import json
import re

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.errors import FrameError
from tests.conftest import box_arrays


def palm_frame():
    return eg.HandFrame.from_palm([0, 0, 0.08], [0, 0, 1], [0, 1, 0], 0.085)


def test_palm_frame_maps_centre_to_origin_and_scales():
    frame = palm_frame()
    centre = np.array([0, 0, 0.08 + 0.085 / 2])
    np.testing.assert_allclose(frame.apply(centre), 0.0, atol=1e-15)
    # the fingertips (palm + d) land at canonical z = +1, the palm at z = -1
    np.testing.assert_allclose(frame.apply([0, 0, 0.08 + 0.085]), [0, 0, 1], atol=1e-14)
    np.testing.assert_allclose(frame.apply([0, 0, 0.08]), [0, 0, -1], atol=1e-14)
    np.testing.assert_allclose(
        frame.apply(centre + np.array([0, 0.01, 0])), [0, 0.01 * 2 / 0.085, 0]
    )
    assert frame.scale == pytest.approx(2 / 0.085)


def test_palm_frame_rotates_normal_to_z_and_up_to_y():
    frame = eg.HandFrame.from_palm([1, 2, 3], [1, 0, 0], [0, 0, 1], 2.0)
    rot = frame.matrix[:3, :3] / frame.scale
    np.testing.assert_allclose(rot @ [1, 0, 0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(rot @ [0, 0, 1], [0, 1, 0], atol=1e-15)
    assert np.linalg.det(rot) == pytest.approx(1.0)
    # a non-orthogonal up keeps only its part across the palm
    skew = eg.HandFrame.from_palm([0, 0, 0], [0, 0, 1], [0, 1, 1], 2.0)
    np.testing.assert_allclose(
        skew.matrix, eg.HandFrame.from_palm([0, 0, 0], [0, 0, 1], [0, 1, 0], 2.0).matrix
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (([0, 0, 0], [0, 0, 1], [0, 0, 2], 1.0), "parallel to the palm normal"),
        (([0, 0, 0], [0, 0, 0], [0, 1, 0], 1.0), "normal must be a non-zero vector"),
        (([0, 0, 0], [0, 0, 1], [0, 1, 0], -1.0), "depth must be a positive length"),
        (([0, np.nan, 0], [0, 0, 1], [0, 1, 0], 1.0), "origin must be 3 finite numbers"),
    ],
)
def test_bad_palm_frames(args, message):
    with pytest.raises(FrameError, match=message):
        eg.HandFrame.from_palm(*args)


def test_frame_dict_round_trip():
    frame = palm_frame()
    assert np.array_equal(eg.HandFrame.from_dict(frame.to_dict()).matrix, frame.matrix)
    assert eg.HandFrame.from_dict(eg.HandFrame.identity().to_dict()).palm is None


def two_link_hand():
    a = box_arrays([-0.05, -0.05, 0.0], [0.05, 0.05, 0.02])
    b = box_arrays([-0.01, -0.01, 0.0], [0.01, 0.01, 0.1])  # overlaps a by 0.02*0.02*0.02
    return eg.Hand.from_meshes(
        [a, b], frame=eg.HandFrame.from_palm([0, 0, 0.02], [0, 0, 1], [0, 1, 0], 0.08)
    )


def test_hand_volume_is_union_of_links():
    hand = two_link_hand()
    union = 0.1 * 0.1 * 0.02 + 0.02 * 0.02 * 0.1 - 0.02 * 0.02 * 0.02
    assert hand.volume == pytest.approx(union, rel=1e-12)
    assert sum(eg.Solid(*arr).volume for arr in hand.link_arrays()) > hand.volume * 1.01


def test_rigid_hand_refuses_joints_and_missing_frame():
    a = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    with pytest.raises(eg.JointError, match="rigid hand .* has no joints"):
        eg.Hand.from_meshes([a], frame=eg.HandFrame.identity()).with_joints({"j": 1.0})
    with pytest.raises(FrameError, match="names no palm frame; pass frame="):
        eg.Hand.from_meshes([a])


def test_grasp_canonical_geometry():
    hand = two_link_hand()
    obj = eg.Solid(*box_arrays([-0.01, -0.01, -0.01], [0.01, 0.01, 0.01]))
    pose = np.eye(4)
    pose[:3, 3] = [0, 0, 0.06]  # the palm-frame centre: z = 0.02 + 0.08 / 2
    grasp = eg.Grasp(hand, obj, pose)
    ((vertices, _),) = grasp.canonical_object_bodies()
    np.testing.assert_allclose(vertices.mean(axis=0), 0.0, atol=1e-15)
    np.testing.assert_allclose(np.ptp(vertices, axis=0), 0.02 * 2 / 0.08)
    assert grasp.canonical_hand_volume == pytest.approx(hand.volume * (2 / 0.08) ** 3)


def test_grasp_rejects_non_rigid_pose():
    hand = two_link_hand()
    obj = eg.Solid(*box_arrays([0, 0, 0], [0.01, 0.01, 0.01]))
    with pytest.raises(eg.GraspError, match="not a rigid transform.*units="):
        eg.Grasp(hand, obj, np.diag([2.0, 2.0, 2.0, 1.0]))
    with pytest.raises(eg.GraspError, match="must be a 4x4 matrix"):
        eg.Grasp(hand, obj, np.eye(3))


@pytest.mark.parametrize(
    ("pose", "defect"),
    [
        (np.diag([-1.0, 1.0, 1.0, 1.0]), r"its rotation part has determinant -1 \(a reflection\)"),
        (
            np.diag([1000.0, 1000.0, 1000.0, 1.0]),
            r"its rotation part is not orthonormal \(max \|R\^T R - I\| = 1e\+06: a scale or a "
            r"shear\)",
        ),
        (
            np.array([[1, 0.01, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]]),
            r"its rotation part is not orthonormal \(max \|R\^T R - I\| = 0\.01: a scale or a "
            r"shear\)",
        ),
        (
            np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0.5, 1.0]]),
            r"its last row is \[0\.0, 0\.0, 0\.5, 1\.0\], not \[0, 0, 0, 1\]",
        ),
    ],
    ids=["reflection", "scale", "shear", "last row"],
)
def test_non_rigid_object_pose_says_what_is_wrong_and_the_fix(pose, defect):
    hand = two_link_hand()
    obj = eg.Solid(*box_arrays([0, 0, 0], [0.01, 0.01, 0.01]))
    with pytest.raises(eg.GraspError) as info:
        eg.Grasp(hand, obj, pose)
    # an in-memory grasp: not an error of a grasp file
    assert not isinstance(info.value, eg.GraspFileError)
    message = str(info.value)
    assert re.match(
        r"object_pose is not a rigid transform: " + defect + r"\. Give a rotation", message
    )
    assert "a mesh in other units takes Solid(..., units=...), not a scale in the pose" in message
    assert message.endswith("and a mirrored object a mirrored mesh.")


def test_pose_tolerance_is_1e_5_on_the_determinant_too():
    hand = two_link_hand()
    obj = eg.Solid(*box_arrays([0, 0, 0], [0.01, 0.01, 0.01]))
    pose = np.eye(4)
    pose[:3, :3] *= 1 + 4e-6  # R^T R - I = 8e-6, det - 1 = 1.2e-5: the determinant decides
    with pytest.raises(eg.GraspError, match=r"determinant 1\.0000120000\d*, 1\.2e-05 from 1"):
        eg.Grasp(hand, obj, pose)
    pose[:3, :3] = np.eye(3) * (1 + 3e-6)
    assert np.array_equal(eg.Grasp(hand, obj, pose).object_pose, pose)


def test_grasp_keeps_its_own_copy_of_the_pose():
    hand = two_link_hand()
    obj = eg.Solid(*box_arrays([0, 0, 0], [0.01, 0.01, 0.01]))
    pose = np.eye(4)
    grasp = eg.Grasp(hand, obj, pose)
    key = grasp.object_key
    pose[0, 3] = 0.5
    assert grasp.object_pose[0, 3] == 0.0
    assert eg.Grasp(hand, obj, np.eye(4)).object_key == key


def test_authors_scale_reproduces_their_frame():
    # The authors' code scaled the Barrett hand by 5.15568 instead of 2 / depth.
    frame = eg.HandFrame.from_palm([0, 0, 0.08], [0, 0, 1], [0, 1, 0], 0.085, scale=5.15568)
    assert frame.scale == 5.15568
    np.testing.assert_allclose(frame.apply([0, 0, 0.1225]), 0.0, atol=1e-15)
    np.testing.assert_allclose(frame.apply([0, 0.1, 0.1225]), [0, 0.515568, 0], atol=1e-15)
    assert eg.HandFrame.from_dict(frame.to_dict()).scale == 5.15568


def test_grasp_file_round_trip_bit_exact(tmp_path):
    hand = two_link_hand()
    obj = eg.objects.cylinder()
    pose = np.eye(4)
    pose[:3, 3] = [0.001, 0.002, 0.07]
    grasp = eg.Grasp(hand, obj, pose, name="rt")
    path = grasp.save(tmp_path / "g.json")
    again = eg.Grasp.from_file(path)
    assert again.name == "rt"
    assert again.geometry_key == grasp.geometry_key
    assert np.array_equal(again.object_pose, grasp.object_pose)
    data = json.loads(path.read_text())
    assert data["format"] == "exactgrasp.grasp/1"


def test_grasp_file_errors(tmp_path):
    missing = tmp_path / "none.json"
    with pytest.raises(eg.GraspFileError, match="no such grasp file"):
        eg.Grasp.from_file(missing)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(eg.GraspFileError, match="not valid JSON"):
        eg.Grasp.from_file(bad)
    nopose = tmp_path / "nopose.json"
    nopose.write_text(json.dumps({"object": "x.stl"}))
    with pytest.raises(eg.GraspFileError, match="missing required key 'object_pose_in_hand'"):
        eg.Grasp.from_file(nopose)
    noobj = tmp_path / "noobj.json"
    hand = {"type": "builtin", "name": "barrett"}
    noobj.write_text(
        json.dumps({"object": "x.stl", "object_pose_in_hand": np.eye(4).tolist(), "hand": hand})
    )
    with pytest.raises(eg.GraspFileError, match=r"the object file 'x\.stl' .* does not exist"):
        eg.Grasp.from_file(noobj)


def test_object_pose_noise_statistics():
    hand = two_link_hand()
    obj = eg.objects.box((0.02, 0.04, 0.08))
    grasp = eg.Grasp(hand, obj, np.eye(4))
    rng = np.random.default_rng(5)
    shifts, angles = [], []
    for _ in range(200):
        pose = eg.object_pose_noise(grasp, eps=0.025, delta=32, rng=rng)
        centre = pose[:3, :3] @ obj.centroid + pose[:3, 3]
        shifts.append(np.linalg.norm(centre - obj.centroid))
        angles.append(np.arccos(np.clip((np.trace(pose[:3, :3]) - 1) / 2, -1, 1)))
    np.testing.assert_allclose(shifts, 0.025 * 0.08, rtol=1e-9)  # eps x longest length
    np.testing.assert_allclose(angles, np.pi / 32, rtol=1e-9)
    again = eg.object_pose_noise(grasp, 0.025, 32, rng=7)
    assert np.array_equal(again, eg.object_pose_noise(grasp, 0.025, 32, rng=7))
    with pytest.raises(ValueError, match="delta must be positive"):
        eg.object_pose_noise(grasp, 0.01, 0, rng=1)


def test_a_link_that_is_no_mesh_is_a_mesh_error():
    with pytest.raises(eg.MeshError, match="link link0: expected a trimesh.Trimesh"):
        eg.Hand.from_meshes([42], frame=eg.HandFrame.identity())
