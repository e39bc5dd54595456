"""`separate` and ``exactgrasp separate``: penetration removed by the smallest rigid motion."""

from __future__ import annotations

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.backends.exact import ExactBackend
from exactgrasp.cli import separate as separate_command
from exactgrasp.cli.main import main
from exactgrasp.separation import FINGERS, buried_links, in_contact
from tests.conftest import box_grasp


def sunk_box(depth: float) -> eg.Grasp:
    """The one-box hand of `box_grasp` (top face z = 0.02 m) with a 10 mm cube sunk
    ``depth`` m into its top face, far from its sides."""
    grasp = box_grasp()
    pose = np.eye(4)
    pose[2, 3] = 0.02 - depth
    return eg.Grasp(grasp.hand, grasp.object, pose, name="sunk")


def test_a_sunk_box_moves_out_by_its_depth():
    result = eg.separate(sunk_box(0.005), rotation=False)
    # Pure translation along the top face's normal, by the depth less at most the tolerance.
    assert 5.0 - 0.01 <= result.translation_mm <= 5.0 + 1e-9
    assert result.rotation_deg == 0.0
    np.testing.assert_allclose(result.motion[:3, 3], [0, 0, result.translation_mm * 1e-3])
    assert result.in_contact and result.joint_changes == {}
    # A hand without joints has no fingers to re-close: the default keeps them.
    assert result.fingers == "keep" and result.buried_links == ()
    assert result.volume_before == pytest.approx(0.01 * 0.01 * 0.005, rel=1e-9)
    assert ExactBackend().volumes(result.grasp, np.eye(4)[None])[0] == 0


def test_separation_is_deterministic_and_in_contact_with_rotation():
    a = eg.separate(sunk_box(0.004))
    b = eg.separate(sunk_box(0.004))
    np.testing.assert_array_equal(a.motion, b.motion)
    assert a.in_contact
    # The twist metric weighs a radian as a canonical unit about the frame's origin, so the
    # way out turns the cube a little and moves its centroid a little farther than the depth.
    assert 3.9 <= a.translation_mm <= 4.5 and 0 < a.rotation_deg < 5
    assert in_contact(a.grasp, a.direction)
    assert not in_contact(sunk_box(0.004), a.direction)  # still penetrating


def test_a_grasp_already_apart_is_left_alone():
    result = eg.separate(sunk_box(-0.003))
    assert result.steps == 0 and result.translation_mm == 0 and result.volume_before == 0
    assert not result.in_contact  # 3 mm apart: a 1 mm push does not reach the hand


def test_an_enclosed_object_is_refused():
    with pytest.raises(eg.SeparationError, match="enclosed by the hand"):
        eg.separate(sunk_box(0.015))  # the cube lies wholly inside the hand box


def gripper_grasp(jaw: float, height: float, name: str) -> eg.Grasp:
    """The built-in parallel gripper, each jaw ``jaw`` m from the centre plane, holding a
    30 x 50 x 40 mm box centred ``height`` m above the palm face."""
    hand = eg.hands.parallel_gripper().with_joints({"finger_1_joint": jaw})
    pose = np.eye(4)
    pose[2, 3] = height
    return eg.Grasp(hand, eg.objects.box((0.03, 0.05, 0.04)), pose, name=name)


def test_the_default_recloses_buried_fingers_and_keeps_the_others():
    # Jaws 40 mm apart squeeze the 50 mm box: each has a third of its volume inside it.
    squeezed = gripper_grasp(0.02, 0.025, "squeezed")
    assert buried_links(squeezed) == ("finger_1", "finger_2")
    result = eg.separate(squeezed)
    assert result.fingers == "reclose" and result.buried_links == ("finger_1", "finger_2")
    # The open hand is clear of the box: it stays, and the jaws close onto it to 0.1 mm.
    assert result.steps == 0 and result.translation_mm == 0
    assert 0.005 < result.joint_changes["finger_1_joint"] <= 0.005 + 1e-4
    assert ExactBackend().volumes(result.grasp, np.eye(4)[None])[0] == 0
    # Keeping the jaws, no rigid motion frees the box: the two sides cancel.
    with pytest.raises(eg.SeparationError, match="enclosed by the hand"):
        eg.separate(squeezed, fingers="keep")
    # The open gripper with the box sunk 5 mm into its palm: no finger link inside, so the
    # joints stay and the box moves out by the depth.
    sunk = gripper_grasp(0.04, 0.015, "sunk")
    assert buried_links(sunk) == ()
    result = eg.separate(sunk)
    assert result.fingers == "keep" and result.buried_links == ()
    assert result.joint_changes == {} and result.in_contact
    assert 5.0 - 0.01 <= result.translation_mm <= 5.0 + 1e-9
    # A mode given is done as given, and nothing is measured.
    assert eg.separate(sunk, fingers="reclose").buried_links is None


def test_the_command_line_offers_the_same_finger_modes():
    assert separate_command.FINGERS == FINGERS


def test_bad_options_are_refused():
    with pytest.raises(eg.SeparationError, match="fingers='open'"):
        eg.separate(sunk_box(0.001), fingers="open")
    with pytest.raises(eg.SeparationError, match="tolerance_mm=0"):
        eg.separate(sunk_box(0.001), tolerance_mm=0)


def test_the_command_writes_the_separated_grasp(tmp_path, capsys):
    path = sunk_box(0.005).save(tmp_path / "sunk.json")
    out = tmp_path / "out.json"
    assert main(["separate", str(path), "-o", str(out), "--no-rotation"]) == 0
    text = capsys.readouterr().out
    assert "in contact" in text and "moved 5.000 mm" in text
    separated = eg.Grasp.from_file(out)
    assert 0.01999 <= separated.object_pose[2, 3] <= 0.02 + 1e-12
    enclosed = sunk_box(0.015).save(tmp_path / "enclosed.json")
    assert main(["separate", str(enclosed), "-o", str(tmp_path / "x.json")]) == 2
    assert "enclosed by the hand" in capsys.readouterr().err


def test_a_raw_study_record_lands_near_the_authors_adjustment(shared_data):
    name = "obj5_sub4_grasp1_optimal0"
    raw = eg.Grasp.from_file(shared_data / f"barrett-grasps/study-records/CerealBox/{name}.json")
    theirs = eg.Grasp.from_file(shared_data / f"barrett-grasps/grasps/{name}_target.json")
    result = eg.separate(raw)  # the default re-closes: the three distal links are buried
    assert result.fingers == "reclose"
    assert result.buried_links == ("finger_1_dist", "finger_2_dist", "finger_3_dist")
    assert result.in_contact
    assert result.volume_before == pytest.approx(1.967e-05, rel=1e-3)
    ours = result.grasp
    # The authors opened the fingers by these amounts too (to a few milliradians).
    for joint in ("finger_1_med_joint", "finger_1_dist_joint", "finger_3_dist_joint"):
        assert abs(ours.hand.joints[joint] - theirs.hand.joints[joint]) < 0.01
        assert abs(raw.hand.joints[joint] - theirs.hand.joints[joint]) > 0.05
    c = raw.object.centroid

    def centre(g):
        return g.object_pose[:3, :3] @ c + g.object_pose[:3, 3]

    assert np.linalg.norm(centre(ours) - centre(theirs)) < np.linalg.norm(
        centre(raw) - centre(theirs)
    )


#: Raw cereal-box records (and their adjusted grasps' suffixes) where keeping the fingers
#: lands farther from the authors' adjustment than the raw record (the first two) or is
#: refused (the third); ``benchmarks/separate_authors.py`` runs all 34.
KEEP_FAILS = {
    "obj5_sub4_grasp2_optimal0": "_target",
    "obj5_sub4_grasp4_extreme2": "_target",
    "obj5_sub5_grasp5_extreme1": "_target",
}


def test_the_default_lands_closer_to_the_authors_adjustment_than_the_raw_record(shared_data):
    folder = shared_data / "barrett-grasps"
    closer = {"default": 0, "keep": 0}
    refused = {"default": 0, "keep": 0}
    for name, suffix in KEEP_FAILS.items():
        raw = eg.Grasp.from_file(folder / f"study-records/CerealBox/{name}.json")
        theirs = eg.compute_descriptor(eg.Grasp.from_file(folder / f"grasps/{name}{suffix}.json"))
        before = eg.distance(eg.compute_descriptor(raw), theirs)
        for mode, options in (("default", {}), ("keep", {"fingers": "keep"})):
            try:
                result = eg.separate(raw, **options)
            except eg.SeparationError:
                refused[mode] += 1
                continue
            assert result.in_contact
            after = eg.distance(eg.compute_descriptor(result.grasp), theirs)
            closer[mode] += after < before
    assert closer == {"default": 3, "keep": 0}
    assert refused == {"default": 0, "keep": 1}


def test_the_default_recloses_fingers_that_block_the_way_out(shared_data):
    # No finger link of this record enters the remote (the palm and the knuckles do), but the
    # fingers closed around it leave no rigid way out: keeping them is refused, so the
    # default re-closes them.
    path = shared_data / "barrett-grasps/study-records/Remote/obj9_sub10_grasp1_extreme1.json"
    grasp = eg.Grasp.from_file(path)
    with pytest.raises(eg.SeparationError, match="after 60 steps"):
        eg.separate(grasp, fingers="keep")
    result = eg.separate(grasp)
    assert result.buried_links == () and result.fingers == "reclose"
    assert result.in_contact and 15.0 < result.translation_mm < 16.0
