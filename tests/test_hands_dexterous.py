"""The built-in five-finger hands read from the optional package gymnasium-robotics."""

from __future__ import annotations

import importlib.util
import json

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.cli.main import main
from exactgrasp.errors import MissingDependencyError
from exactgrasp.hands import dexterous

HAVE_PACKAGE = importlib.util.find_spec("gymnasium_robotics") is not None
needs_package = pytest.mark.skipif(
    not HAVE_PACKAGE,
    reason="gymnasium-robotics (the hands extra: pip install 'exactgrasp[hands]') is absent",
)
TINY = {"n_translations": 3, "n_axes": 2, "n_amounts": 2, "n_steps": 3}


def _in_front_of_palm(hand: eg.Hand, distance: float) -> np.ndarray:
    """A pose ``distance`` (m) out of the palm face, 32 mm from its centre towards the
    fingers (under the fingers' middle links), in hand coordinates."""
    palm = hand.model.palm
    pose = np.eye(4)
    pose[:3, 3] = np.asarray(palm.origin) + distance * np.asarray(palm.normal) + [0, 0, 0.032]
    return pose


def test_the_five_finger_hands_are_built_in_names():
    assert {"adroit", "shadow_hand"} <= eg.hands.available_hands()
    assert eg.hands.get_builtin("adroit") is eg.hands.adroit
    assert eg.hands.get_builtin("shadow_hand") is eg.hands.shadow_hand


def test_without_the_package_the_message_says_what_to_install(monkeypatch):
    monkeypatch.setattr(dexterous.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(MissingDependencyError, match=r"pip install \"exactgrasp\[hands\]\""):
        dexterous.model_file("adroit")


@needs_package
@pytest.mark.parametrize(
    ("name", "prefix"), [("adroit", ""), ("shadow_hand", "robot0:")], ids=["adroit", "shadow"]
)
def test_hand_loads_with_palm_frame_and_closing_joints(name, prefix):
    hand = eg.hands.get_builtin(name)()
    model = hand.model
    assert dexterous.model_file(name).is_file()
    assert len(model.link_names) == 22 and len(model.joint_names) == 24
    assert model.palm.normal == (0.0, -1.0, 0.0) and model.palm.depth == 0.07
    assert model.closing_directions[f"{prefix}FFJ2"] == 1
    assert model.closing_directions[f"{prefix}THJ0"] == -1
    assert f"{prefix}WRJ1" not in model.closing_joints
    assert hand.source == {"type": "builtin", "name": name, "options": {}}
    # the palm face: no link reaches past it at the flat pose except the thumb's
    faces = [V[:, 1].min() for link, V, _ in model.link_meshes() if "palm" in link]
    assert min(faces) == pytest.approx(model.palm.origin[1], abs=1e-3)


@needs_package
def test_close_fingers_closes_the_adroit_hand_on_a_box():
    hand = eg.hands.adroit()
    box = eg.objects.box((0.05, 0.05, 0.05))
    pose = _in_front_of_palm(hand, 0.03)
    result = eg.close_fingers_result(hand, box, object_pose=pose)
    assert result.backoff_distance == 0.0
    touching = {f.joints[0]: f.contact_links for f in result.fingers}
    assert all(touching[j] for j in ("FFJ2", "MFJ2", "RFJ2", "LFJ2")), touching
    assert all(f.gap >= 0 for f in result.fingers)
    closed = result.hand.joints
    assert all(closed[f"{f}J2"] > 0.1 for f in ("FF", "MF", "RF", "LF"))
    assert closed["WRJ1"] == 0.0 and closed["THJ4"] == 0.0
    grasp = eg.Grasp(result.hand, box, result.object_pose)
    d = eg.compute_descriptor(grasp, eg.PathSampler(**TINY), backend="voxel", progress=False)
    assert np.all(np.isfinite(d.values)) and d.values.max() > 0


@needs_package
def test_adroit_grasp_file_round_trip(tmp_path):
    hand = eg.hands.adroit({"FFJ2": 0.4, "THJ3": 0.5})
    grasp = eg.Grasp(hand, eg.objects.box((0.04, 0.04, 0.04)), _in_front_of_palm(hand, 0.03))
    path = grasp.save(tmp_path / "adroit.json")
    assert json.loads(path.read_text())["hand"] == {
        "type": "builtin",
        "name": "adroit",
        "options": {},
    }
    back = eg.Grasp.from_file(path)
    assert back.hand.joints["FFJ2"] == 0.4 and back.hand.joints["THJ3"] == 0.5


@needs_package
def test_inspect_reads_the_package_file(capsys):
    assert main(["inspect", "adroit"]) == 0
    out = capsys.readouterr().out
    assert "as a hand (root_body='forearm'): 22 links" in out
    assert "palm frame: origin (0, -0.011, 0.468), normal (0, -1, 0), up (1, 0, 0)" in out
    assert "THJ3 +, THJ0 -" in out
