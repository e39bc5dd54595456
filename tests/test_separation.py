"""`separate` and ``exactgrasp separate``: penetration removed by the smallest rigid motion."""

from __future__ import annotations

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.backends.exact import ExactBackend
from exactgrasp.cli.main import main
from exactgrasp.separation import in_contact
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
    result = eg.separate(raw, fingers="reclose")
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
