"""``examples/penetration_descent.py``: its forward kinematics in torch against the library's,
and its gradient descent on the exact volume removing penetration (a built-in hand, raw
study records of the shared data, the command line)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

import exactgrasp as eg

torch = pytest.importorskip("torch")

ROOT = Path(__file__).resolve().parents[1]


def _example():
    spec = importlib.util.spec_from_file_location(
        "penetration_descent", ROOT / "examples" / "penetration_descent.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


pd = _example()

#: Raw cereal-box records (``barrett-grasps/study-records/CerealBox``) and whether the palm is
#: in the box: in the first only fingers are (opening them is enough), in the second the palm
#: too (the box has to move).
RECORDS = {"obj5_sub5_grasp6_extreme1": False, "obj5_sub6_grasp1_extreme0": True}


def _record_hand(shared_data) -> eg.Hand:
    path = shared_data / "barrett-grasps/study-records/CerealBox" / f"{next(iter(RECORDS))}.json"
    return eg.Grasp.from_file(path).hand


def _fk_matches(hand: eg.Hand, seed: int) -> None:
    kin = pd.TorchKinematics.of(hand)
    assert kin.joint_names == hand.joint_names
    rng = np.random.default_rng(seed)
    for _ in range(10):
        q = rng.uniform(kin.lower.numpy(), kin.upper.numpy())
        joints = dict(zip(kin.joint_names, q, strict=True))
        ours = kin.link_transforms(torch.tensor(q)).numpy()
        theirs = hand.model.link_poses(joints)
        assert ours.shape == theirs.shape == (len(hand.link_names), 4, 4)
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12)
        posed = hand.with_joints(joints).link_arrays()
        for v, (w, _) in zip(kin.link_vertices(torch.tensor(q)), posed, strict=True):
            np.testing.assert_allclose(v.numpy(), w, rtol=0, atol=1e-12)


def test_torch_kinematics_are_the_library_s_on_the_built_in_barrett_hand():
    # Its spread is one joint driving two links (finger_2_prox_joint follows it).
    hand = eg.hands.barrett()
    assert "finger_2_prox_joint" in hand.model.couplings
    _fk_matches(hand, seed=0)


def test_torch_kinematics_are_the_library_s_on_the_records_hand(shared_data):
    _fk_matches(_record_hand(shared_data), seed=1)


def test_a_rigid_hand_is_refused_naming_the_fix():
    box = eg.objects.box((0.1, 0.1, 0.1))
    hand = eg.Hand.from_meshes([box], frame=eg.HandFrame.identity())
    with pytest.raises(TypeError, match=r"no kinematic model.*eg\.hands\.barrett\(\)"):
        pd.TorchKinematics.of(hand)


def test_torch_kinematics_gradient_is_the_joint_twist():
    # d(link vertex)/d(joint) is the joint's twist at that vertex: a hinge moves x at a × (x - p).
    hand = eg.hands.barrett({"finger_3_med_joint": 0.7, "finger_3_dist_joint": 0.3})
    kin = pd.TorchKinematics.of(hand)
    q = torch.tensor([hand.joints[n] for n in kin.joint_names], dtype=torch.float64)
    q.requires_grad_()
    j = kin.joint_names.index("finger_3_med_joint")
    link = hand.link_names.index("finger_3_dist")
    (velocity,) = torch.autograd.grad(kin.link_vertices(q)[link][0].sum(), q)
    _, anchor, axis = hand.model.joint_frames(hand.joints)["finger_3_med_joint"]
    x = hand.link_arrays()[link][0][0]
    assert velocity[j].item() == pytest.approx(np.cross(axis, x - anchor).sum(), abs=1e-12)
    with pytest.raises(TypeError, match=r"q\.double\(\)"):
        kin.link_transforms(q.detach().float())


def _check_removed(result, start: eg.Grasp) -> None:
    losses = np.array(result.losses)
    assert result.removed and losses[-1] == 0.0 < losses[0]
    assert (np.diff(losses) < 0).all()  # only steps that shed volume are taken
    # The result as the library poses it (its own kinematics): no link in the object, and
    # the union of the links within the stated tolerance of 0.
    assert pd.link_volumes(result.grasp) == [0.0] * len(start.hand.link_names)
    assert 0.0 <= eg.intersection_volume(result.grasp) <= pd.TOLERANCE * start.object.volume
    for name, value in result.grasp.hand.joints.items():
        lo, hi = start.hand.joint_limits[name]
        assert lo <= value <= hi


def test_descent_frees_a_box_sunk_into_the_palm_and_a_finger():
    hand = eg.hands.barrett(
        {"finger_3_med_joint": 1.3, "finger_3_dist_joint": 0.6}, tessellation=8
    )
    pose = np.eye(4)
    pose[2, 3] = 0.128  # the box's bottom 2 mm below the palm's face (z = 0.08)
    start = eg.Grasp(hand, eg.objects.box((0.02, 0.06, 0.1)), pose, "sunk")
    before = pd.link_volumes(start)
    assert before[hand.link_names.index("palm")] > 0
    assert before[hand.link_names.index("finger_3_dist")] > 0
    result = pd.descend(start)
    _check_removed(result, start)
    # The box rises out of the palm and stops at its face, within the contact search's
    # tolerance; finger 3 opens, the other fingers have no reason to move.
    p = result.grasp.object_pose
    bottom = (start.object.vertices @ p[:3, :3].T + p[:3, 3])[:, 2].min()
    assert 0.08 <= bottom < 0.08 + 1e-4
    changed = {n for n in hand.joint_names if result.grasp.hand.joints[n] != hand.joints[n]}
    assert changed == {"finger_3_med_joint", "finger_3_dist_joint"}
    assert result.grasp.hand.joints["finger_3_med_joint"] < 1.3


@pytest.mark.parametrize("record", RECORDS)
def test_descent_removes_the_penetration_of_raw_records(shared_data, record):
    folder = shared_data / "barrett-grasps/study-records/CerealBox"
    start = eg.Grasp.from_file(folder / f"{record}.json")
    palm_in = pd.link_volumes(start)[start.hand.link_names.index("palm")] > 0
    assert palm_in == RECORDS[record]
    result = pd.descend(start)
    _check_removed(result, start)
    assert result.evaluations <= pd.MAX_STEPS
    c = start.object.centroid
    p, q = start.object_pose, result.grasp.object_pose
    moved_mm = 1e3 * np.linalg.norm(q[:3, :3] @ c + q[:3, 3] - (p[:3, :3] @ c + p[:3, 3]))
    # The object moves where the palm holds it (2.4 mm measured), hardly where it does not.
    assert moved_mm > 1.0 if palm_in else moved_mm < 0.1


def test_a_step_budget_too_small_leaves_penetration_and_says_so(capsys, tmp_path):
    hand = eg.hands.barrett(
        {"finger_3_med_joint": 1.3, "finger_3_dist_joint": 0.6}, tessellation=8
    )
    pose = np.eye(4)
    pose[2, 3] = 0.128
    path = tmp_path / "sunk.json"
    eg.Grasp(hand, eg.objects.box((0.02, 0.06, 0.1)), pose, "sunk").save(path)
    assert pd.main([str(path), "--steps", "2"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("sunk: loss 5199") and "in 2 evaluations" in out
    assert "(penetration left)" in out
