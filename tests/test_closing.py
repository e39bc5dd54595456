"""close_fingers: contact without penetration on the built-in and the real Barrett hand,
repair of a penetrating study record, and each bad input with its message."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="the models extra (mujoco) is not installed")
pytest.importorskip("coal", reason="close_fingers' default engine (coal) is not installed")

import exactgrasp as eg
from exactgrasp.errors import JointError
from exactgrasp.geometry.manifold import to_manifold, union
from exactgrasp.grasp.closing import ClosingError, close_fingers, close_fingers_result, close_grasp

TOL = 1e-4
FLEXION = [f"finger_{i}_{part}_joint" for i in (1, 2, 3) for part in ("med", "dist")]
CEREAL = "obj5_sub4_grasp1_optimal0_target"  # three distal contacts, no breakaway


def _intersection(hand, obj, pose) -> float:
    """Exact volume of (union of the hand links) ∩ object, m^3."""
    placed = obj.vertices @ pose[:3, :3].T + pose[:3, 3]
    return float((union(hand.link_arrays()) ^ to_manifold(placed, obj.faces)).volume())


def _gaps(hand, obj, pose) -> dict[str, float]:
    """Per-link distance to the object with python-fcl (independent of the coal engine)."""
    fcl = pytest.importorskip("fcl", reason="python-fcl checks the gaps independently")

    def placed(V, F, T=None):
        T = np.eye(4) if T is None else T
        bvh = fcl.BVHModel()
        bvh.beginModel(len(V), len(F))
        bvh.addSubModel(np.asarray(V, float), np.asarray(F, np.int32))
        bvh.endModel()
        return fcl.CollisionObject(bvh, fcl.Transform(T[:3, :3], T[:3, 3]))

    target = placed(obj.vertices, obj.faces, pose)
    return {
        name: fcl.distance(placed(V, F), target, fcl.DistanceRequest(), fcl.DistanceResult())
        for name, (V, F) in zip(hand.link_names, hand.link_arrays(), strict=True)
    }


def _check_contact_grasp(result, obj):
    """Zero exact intersection; each touching finger has a link within (0, TOL] of the object."""
    assert _intersection(result.hand, obj, result.object_pose) == 0.0
    gaps = _gaps(result.hand, obj, result.object_pose)
    assert min(gaps.values()) > 0.0
    touching = [f for f in result.fingers if f.contact_links]
    assert touching
    for finger in touching:
        assert min(gaps[link] for link in finger.contact_links) <= TOL * (1 + 1e-6), finger


@pytest.fixture(scope="module")
def cylinder_grasp():
    """A can lying across the built-in hand, its axis along x, 10 mm above the palm."""
    pose = np.eye(4)
    pose[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]
    pose[:3, 3] = [0.0, 0.0, 0.08 + 0.035 + 0.01]
    return eg.hands.barrett(), eg.objects.cylinder(), pose


@pytest.mark.parametrize("engine", ["coal", "fcl"])
def test_builtin_hand_closes_onto_cylinder(cylinder_grasp, engine):
    if engine == "fcl":
        pytest.importorskip("fcl", reason="python-fcl is not installed")
    hand, obj, pose = cylinder_grasp
    result = close_fingers_result(hand, obj, pose, engine=engine)
    assert result.backoff_distance == 0.0
    np.testing.assert_array_equal(result.object_pose, pose)
    assert [f.joints for f in result.fingers] == [tuple(FLEXION[k : k + 2]) for k in (0, 2, 4)]
    assert all(f.contact_links for f in result.fingers)
    _check_contact_grasp(result, obj)
    # The spread is not a closing joint: it keeps its value.
    assert result.hand.joints["finger_1_prox_joint"] == hand.joints["finger_1_prox_joint"]
    # Range-proportional closing: distal/medial = 0.837 / 2.44 (the hand's 12/35 coupling).
    joints = result.hand.joints
    assert joints["finger_1_dist_joint"] == pytest.approx(
        joints["finger_1_med_joint"] * 0.837 / 2.44, rel=1e-9
    )


def test_engines_agree_and_hand_returned(cylinder_grasp):
    pytest.importorskip("fcl", reason="python-fcl is not installed")
    hand, obj, pose = cylinder_grasp
    closed = {e: close_fingers(hand, obj, pose, engine=e) for e in ("coal", "fcl")}
    assert isinstance(closed["coal"], eg.Hand)
    for name in FLEXION:
        assert closed["coal"].joints[name] == pytest.approx(closed["fcl"].joints[name], abs=1e-6)


def test_each_link_mesh_gets_one_bvh_per_process(cylinder_grasp):
    """The built-in hand's 9 links have 4 distinct meshes: closing builds their 4 BVHs and the
    can's, and a second closing, from another spread, builds none."""
    from exactgrasp.geometry.bvh import BVHS

    hand, obj, pose = cylinder_grasp
    BVHS.clear()
    builds = BVHS.builds
    close_fingers(hand, obj, pose)
    assert BVHS.builds - builds == 4 + 1
    close_fingers(eg.hands.barrett({"finger_1_prox_joint": 0.3}), obj, pose)
    assert BVHS.builds - builds == 4 + 1


def test_coupled_distals_close_through_their_medials(cylinder_grasp):
    _, obj, pose = cylinder_grasp
    hand = eg.hands.barrett(distal_coupling=True)
    result = close_fingers_result(hand, obj, pose)
    assert [f.joints for f in result.fingers] == [(f"finger_{i}_med_joint",) for i in (1, 2, 3)]
    _check_contact_grasp(result, obj)


def test_breakaway_medial_stops_distal_keeps_closing():
    # A thin bar across finger 3 only, close to the palm: the medial link hits it first.
    hand = eg.hands.barrett()
    bar = eg.objects.box((0.06, 0.01, 0.01))
    pose = np.eye(4)
    pose[:3, 3] = [0.0, 0.09, 0.105]
    result = close_fingers_result(hand, bar, pose)
    finger_3 = result.fingers[2]
    assert finger_3.contact_links[0] == "finger_3_med"
    joints = result.hand.joints
    assert joints["finger_3_dist_joint"] > joints["finger_3_med_joint"] * 0.837 / 2.44 + 0.05
    assert not result.fingers[0].contact_links  # fingers 1 and 2 miss it: partial contact
    assert result.fingers[0].at_limit == ("finger_1_med_joint", "finger_1_dist_joint")
    _check_contact_grasp(result, bar)


def test_real_barrett_cereal_box_reopened_and_closed(shared_data):
    grasp = eg.Grasp.from_file(shared_data / "barrett-grasps" / "grasps" / f"{CEREAL}.json")
    opened = grasp.hand.with_joints(dict.fromkeys(FLEXION, 0.0))
    result = close_fingers_result(opened, grasp.object, grasp.object_pose)
    assert result.backoff_distance == 0.0
    assert [f.contact_links for f in result.fingers] == [(f"finger_{i}_dist",) for i in (1, 2, 3)]
    _check_contact_grasp(result, grasp.object)
    # The authors' adjusted grasp came from the same kind of closing: same joints to 1e-3 rad
    # (measured 9e-4; median 2e-3 over the 34 grasps).
    for name in FLEXION:
        assert result.hand.joints[name] == pytest.approx(grasp.hand.joints[name], abs=5e-3)


def test_raw_study_record_repaired(shared_data):
    path = shared_data / "barrett-grasps" / "noise" / "spray_bottle_study_record.json"
    grasp = eg.Grasp.from_file(path)
    before = _intersection(grasp.hand, grasp.object, grasp.object_pose)
    assert before == pytest.approx(2.8038e-5, rel=1e-3)  # README: 2.804e-5 m^3
    with pytest.warns(UserWarning, match=r"moved \d+\.\d+ mm out along the palm normal"):
        fixed = close_grasp(grasp)
    shift = fixed.object_pose[:3, 3] - grasp.object_pose[:3, 3]
    # Straight out along the palm normal (+z), by the palm's depth in the bottle (5.05 mm).
    np.testing.assert_allclose(shift[:2], 0.0, atol=1e-12)
    assert 4.5e-3 < shift[2] < 5.5e-3
    np.testing.assert_array_equal(fixed.object_pose[:3, :3], grasp.object_pose[:3, :3])
    assert _intersection(fixed.hand, fixed.object, fixed.object_pose) == 0.0
    gaps = _gaps(fixed.hand, fixed.object, fixed.object_pose)
    assert 0.0 < gaps["palm"] <= TOL  # backed off until the palm just clears
    for i in (1, 2, 3):
        assert 0.0 < gaps[f"finger_{i}_dist"] <= TOL


# -- bad input ---------------------------------------------------------------------------------


def test_object_out_of_reach(cylinder_grasp):
    hand, obj, pose = cylinder_grasp
    far = pose.copy()
    far[2, 3] = 0.5
    with pytest.raises(ClosingError, match=r"cylinder does not fit inside the reach of .*"
                       r"move the object closer to the palm"):  # fmt: skip
        close_fingers(hand, obj, far)


def test_close_grasp_names_the_grasp(cylinder_grasp):
    hand, obj, pose = cylinder_grasp
    far = pose.copy()
    far[2, 3] = 0.5
    with pytest.raises(ClosingError, match=r"^grasp 'can far away': cylinder does not fit"):
        close_grasp(eg.Grasp(hand, obj, far, name="can far away"))


def test_penetrating_palm_without_backoff(cylinder_grasp):
    hand, obj, pose = cylinder_grasp
    sunk = pose.copy()
    sunk[2, 3] = 0.08 + 0.035 - 0.004  # 4 mm into the palm, 11.4 mm below the knuckle tops
    message = (
        r"the open hand penetrates cylinder by 11\.4\d\d mm along the palm normal \(links "
        r"palm, finger_1_prox, finger_2_prox\); pass backoff=True"
    )
    with pytest.raises(ClosingError, match=message):
        close_fingers(hand, obj, sunk, backoff=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = close_fingers_result(hand, obj, sunk)
    assert result.backoff_distance == pytest.approx(0.0874 - 0.076, abs=2e-4)
    _check_contact_grasp(result, obj)


@pytest.mark.parametrize(
    ("joints", "error", "message"),
    [
        (["finger_1_med_joint", "thumb_joint"], JointError, r"unknown joint name 'thumb_joint'"),
        (["finger_2_prox_joint"], JointError, r"follows 'finger_1_prox_joint' \(coupled\)"),
        ("finger_1_med_joint", JointError, r"joints must be a list of joint names"),
        ([], JointError, r"joints is empty"),
    ],
)
def test_bad_joint_names(cylinder_grasp, joints, error, message):
    hand, obj, pose = cylinder_grasp
    with pytest.raises(error, match=message):
        close_fingers(hand, obj, pose, joints=joints)


@pytest.mark.parametrize(
    ("option", "message"),
    [
        ({"tolerance": 0.0}, r"tolerance must be a positive number \(m\), got 0\.0"),
        ({"tolerance": float("inf")}, r"tolerance must be finite"),
        ({"step": -0.1}, r"step must be a positive number \(rad\)"),
        ({"engine": "bullet"}, r"engine must be 'coal' or 'fcl', got 'bullet'"),
    ],
)
def test_bad_options(cylinder_grasp, option, message):
    hand, obj, pose = cylinder_grasp
    with pytest.raises(ClosingError, match=message):
        close_fingers(hand, obj, pose, **option)


def test_bad_hand_object_and_pose(cylinder_grasp):
    hand, obj, pose = cylinder_grasp
    rigid = eg.Hand.from_meshes([obj], frame=eg.HandFrame.identity())
    with pytest.raises(ClosingError, match=r"has no joints to close .* Hand.from_urdf"):
        close_fingers(rigid, obj, pose)
    with pytest.raises(ClosingError, match=r"object must be an exactgrasp Solid, got Trimesh"):
        close_fingers(hand, obj.to_trimesh(), pose)
    with pytest.raises(eg.GraspError, match=r"must be a 4x4 matrix"):
        close_fingers(hand, obj, pose[:3])
    no_palm = eg.hands.barrett(frame=eg.HandFrame.identity())
    assert close_fingers(no_palm, obj, pose).joints  # the model's palm still gives the normal


def test_no_palm_needs_explicit_joints(cylinder_grasp):
    from exactgrasp.hands.barrett import BARRETT_MJCF
    from exactgrasp.hands.loading import load_model

    _, obj, pose = cylinder_grasp
    model = load_model("no_palm.xml", xml=BARRETT_MJCF, palm=False)
    hand = eg.Hand(model, frame=eg.HandFrame.identity())
    with pytest.raises(ClosingError, match=r"names no palm frame.*pass joints=\[\.\.\.\]"):
        close_fingers(hand, obj, pose)
    closed = close_fingers(hand, obj, pose, joints=FLEXION)
    assert _intersection(closed, obj, pose) == 0.0


def test_object_wholly_inside_the_palm_is_found():
    # BVH distance alone says 35 mm clear: no triangle of the palm meets the small box.
    hand, cube = eg.hands.barrett(), eg.objects.box((0.01, 0.01, 0.01))
    pose = np.eye(4)
    pose[2, 3] = 0.04  # the palm box spans z = 0 .. 0.08
    with pytest.raises(ClosingError, match=r"penetrates box by 45\.0\d\d mm .*\(links palm\)"):
        close_fingers(hand, cube, pose, backoff=False)


def test_model_closing_joints_attribute_is_the_default(cylinder_grasp):
    from exactgrasp.hands.barrett import BARRETT_MJCF, BARRETT_PALM
    from exactgrasp.hands.loading import load_model

    _, obj, pose = cylinder_grasp
    model = load_model("two_fingers.xml", xml=BARRETT_MJCF, palm=BARRETT_PALM)
    model.closing_joints = ("finger_1_med_joint", "finger_3_med_joint")
    result = close_fingers_result(eg.Hand(model), obj, pose)
    assert [f.joints for f in result.fingers] == [("finger_1_med_joint",), ("finger_3_med_joint",)]
    assert result.hand.joints["finger_2_med_joint"] == 0.0


# -- closing directions ------------------------------------------------------------------------


def test_parallel_gripper_closes_towards_its_lower_limit():
    # A 5 cm box between the open jaws (0.08 m): they shut onto it, nothing backs off.
    hand, width = eg.hands.parallel_gripper(), 0.05
    assert hand.joints == {"finger_1_joint": 0.04}  # open by default
    box = eg.objects.box((0.03, width, 0.04))
    pose = np.eye(4)
    pose[2, 3] = 0.025
    result = close_fingers_result(hand, box, pose)
    assert result.backoff_distance == 0.0
    np.testing.assert_array_equal(result.object_pose, pose)
    assert result.directions == {"finger_1_joint": -1}
    assert result.fingers[0].inferred == (True,)
    assert set(result.fingers[0].contact_links) == {"finger_1", "finger_2"}
    gap = 2 * result.hand.joints["finger_1_joint"]  # the second jaw mirrors the first
    assert 0.0 < gap - width <= 2 * TOL
    _check_contact_grasp(result, box)
    assert "finger_1_joint - (inferred)" in repr(result) and "back-off 0 mm" in result.summary()
    # Closing towards the upper limit (the old fixed rule) starts shut inside the box: the
    # object is backed off out of the jaws, and the jaws touch it only with their tips.
    with pytest.warns(UserWarning, match="penetrates box"):
        wrong = close_fingers_result(hand, box, pose, direction={"finger_1_joint": +1})
    assert wrong.backoff_distance > 0.04 and wrong.hand.joints["finger_1_joint"] == 0.0


MIXED = """<mujoco model="mixed">
  <compiler angle="radian"/>
  <worldbody>
    <body name="palm">
      <geom name="palm" type="box" pos="0 0 -0.01" size="0.03 0.06 0.01"/>
      <site name="face"/>
      <body name="a" pos="0 0.05 0">
        <joint name="a_joint" axis="1 0 0" range="0 2.6"/>
        <geom name="a" type="capsule" fromto="0 0 0.005 0 0.05 0.005" size="0.005"/>
      </body>
      <body name="b" pos="0 -0.05 0">
        <joint name="b_joint" axis="1 0 0" range="-2.6 0"/>
        <geom name="b" type="capsule" fromto="0 0 0.005 0 -0.05 0.005" size="0.005"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


@pytest.fixture(scope="module")
def mixed_grasp():
    """Two fingers on one axis: ``a`` curls inwards (over the palm) with + values, ``b`` with
    - values; a box above the palm between them."""
    from exactgrasp.hands.loading import load_model

    palm = {"site": "face", "normal": "+z", "up": "+y", "depth": 0.06}
    model = load_model("mixed.xml", xml=MIXED, palm=palm)
    pose = np.eye(4)
    pose[2, 3] = 0.04
    return eg.Hand(model), eg.objects.box((0.02, 0.06, 0.04)), pose


def test_mixed_directions_inferred(mixed_grasp):
    hand, box, pose = mixed_grasp
    assert eg.grasp.closing.closing_directions(hand) == {"a_joint": 1, "b_joint": -1}
    result = close_fingers_result(hand, box, pose)
    assert result.directions == {"a_joint": 1, "b_joint": -1}
    assert all(f.inferred == (True,) for f in result.fingers)
    assert [f.contact_links for f in result.fingers] == [("a",), ("b",)]
    assert 0 < result.hand.joints["a_joint"] < 2.6
    assert -2.6 < result.hand.joints["b_joint"] < 0
    _check_contact_grasp(result, box)


def test_mixed_directions_given(mixed_grasp):
    hand, box, pose = mixed_grasp
    inferred = close_fingers(hand, box, pose)
    given = close_fingers_result(hand, box, pose, direction={"a_joint": 1, "b_joint": -1})
    assert given.hand.joints == inferred.joints
    assert all(f.inferred == (False,) for f in given.fingers)


def test_model_closing_directions_attribute(mixed_grasp):
    from exactgrasp.hands.loading import load_model

    _, box, pose = mixed_grasp
    palm = {"site": "face", "normal": "+z", "up": "+y", "depth": 0.06}
    model = load_model("mixed_preset.xml", xml=MIXED, palm=palm)
    model.closing_directions = {"b_joint": -1}
    result = close_fingers_result(eg.Hand(model), box, pose)
    assert [f.inferred for f in result.fingers] == [(True,), (False,)]


@pytest.mark.parametrize(
    "direction, message",
    [
        ({"finger_2_prox_joint": 1}, "follows 'finger_1_prox_joint'"),
        ({"finger_1_prox_joint": 1}, "not a closing joint"),
        ({"finger_1_med_joint": 2}, r"must be \+1 or -1"),
        ({"finger_1_med_joint": True}, r"must be \+1 or -1"),
        ([1, -1], "must be a dict"),
    ],
)
def test_bad_directions(cylinder_grasp, direction, message):
    hand, obj, pose = cylinder_grasp
    with pytest.raises(JointError, match=message):
        close_fingers(hand, obj, pose, direction=direction)
