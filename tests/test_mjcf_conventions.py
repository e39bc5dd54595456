"""MJCF and URDF files as simulation frameworks ship them: the angle unit a gripper file leaves
to the robot model that includes it, fixed tendons as couplings, all of a model's problems in
one report, palm frames without a file."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import pytest
import trimesh

pytest.importorskip("mujoco", reason="the models extra (mujoco) is not installed")

import exactgrasp as eg
from exactgrasp.errors import ModelError
from exactgrasp.hands import load_model

ROOT = Path(__file__).resolve().parents[1]
PALM = {"origin": [0, 0, 0.01], "normal": "+z", "up": "+y", "depth": 0.06}


def gripper(compiler: str = "", ranges: str = "0 0.8", extra: str = "") -> str:
    """A two-finger MJCF gripper: a palm box and two hinged fingers, ``compiler`` and
    ``extra`` (tendons, equalities) inserted as given."""
    return f"""<mujoco model="gripper">{compiler}
  <worldbody>
    <body name="palm">
      <geom name="palm" type="box" size="0.03 0.02 0.01"/>
      <body name="left" pos="0.02 0 0.01">
        <joint name="left_joint" type="hinge" axis="0 1 0" range="{ranges}"/>
        <geom name="left" type="box" size="0.004 0.004 0.02" pos="0 0 0.02"/>
      </body>
      <body name="right" pos="-0.02 0 0.01">
        <joint name="right_joint" type="hinge" axis="0 -1 0" range="{ranges}"/>
        <geom name="right" type="box" size="0.004 0.004 0.02" pos="0 0 0.02"/>
      </body>
    </body>
  </worldbody>{extra}
</mujoco>
"""


def _write(tmp_path, text: str, name: str = "gripper.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


# -- the angle unit ---------------------------------------------------------------------------


def test_ranges_read_as_degrees_are_warned_and_angle_radian_reads_radians(tmp_path):
    path = _write(tmp_path, gripper())
    with pytest.warns(UserWarning) as caught:
        model = load_model(path, palm=PALM)
    (message,) = [str(w.message) for w in caught if "compiler angle" in str(w.message)]
    assert message.startswith(f"{path}: the file sets no <compiler angle=...>")
    assert "left_joint [0, 0.8], right_joint [0, 0.8] degrees" in message
    assert "pass angle='radian' to read the file's angles as radians" in message
    assert "or angle='degree' to keep degrees" in message
    assert '"hand_options": {"angle": ...}' in message and "--angle" in message
    assert model.joint_limits["left_joint"] == pytest.approx((0.0, math.radians(0.8)))
    assert [str(issue) for issue in model.issues] == [message.split(" (in a grasp file")[0]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        radians = load_model(path, palm=PALM, angle="radian")
        degrees = load_model(path, palm=PALM, angle="degree")
    assert radians.joint_limits["left_joint"] == pytest.approx((0.0, 0.8))
    assert radians.issues == ()
    assert degrees.joint_limits["left_joint"] == pytest.approx((0.0, math.radians(0.8)))
    # the unit reaches every angle of the file, as MuJoCo's compiler attribute does
    hand = eg.Hand.from_mjcf(path, {"left_joint": 0.5}, palm=PALM, angle="radian")
    assert hand.joints["left_joint"] == 0.5
    assert hand.source["options"]["angle"] == "radian"


@pytest.mark.parametrize(
    ("compiler", "ranges"),
    [
        ('<compiler angle="radian"/>', "0 0.8"),
        ('<compiler angle="degree"/>', "0 0.8"),
        ("", "0 90"),
    ],
)
def test_no_warning_when_the_file_says_or_a_range_is_wider_than_a_turn(tmp_path, compiler, ranges):
    path = _write(tmp_path, gripper(compiler, ranges))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = load_model(path, palm=PALM)
    assert model.issues == ()
    high = float(ranges.split()[1])
    expected = high if "radian" in compiler else math.radians(high)
    assert model.joint_limits["left_joint"][1] == pytest.approx(expected)


def test_a_compiler_in_an_included_file_counts(tmp_path):
    _write(tmp_path, '<mujoco><compiler angle="radian"/></mujoco>', "settings.xml")
    text = gripper('<include file="settings.xml"/>')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = load_model(_write(tmp_path, text), palm=PALM)
    assert model.joint_limits["left_joint"] == pytest.approx((0.0, 0.8))


def test_bad_angle_values_are_refused_naming_the_argument(tmp_path):
    path = _write(tmp_path, gripper())
    for bad in ("radians", "rad", 1, True):
        with pytest.raises(ModelError, match=r"^angle must be 'degree', 'radian' or None"):
            load_model(path, palm=PALM, angle=bad)
    urdf = tmp_path / "hand.urdf"
    urdf.write_text(
        '<robot name="r"><link name="base"><collision><geometry><box size="0.1 0.1 0.1"/>'
        "</geometry></collision></link></robot>"
    )
    with pytest.raises(ModelError, match=r"a URDF's angles are radians; angle='degree' applies"):
        load_model(urdf, angle="degree")
    assert load_model(urdf, angle="radian", palm=PALM).link_names == ("base",)


def test_a_grasp_file_sets_the_angle_unit(tmp_path):
    _write(tmp_path, gripper())
    trimesh.creation.box((0.02, 0.02, 0.02)).export(tmp_path / "box.stl")
    data = {
        "format": "exactgrasp.grasp/1",
        "hand_model": "gripper.xml",
        "hand_options": {"angle": "radian", "palm": PALM},
        "joints": {"left_joint": 0.7},
        "object": "box.stl",
        "object_pose_in_hand": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.05], [0, 0, 0, 1]],
    }
    (tmp_path / "g.json").write_text(json.dumps(data))
    grasp = eg.Grasp.from_file(tmp_path / "g.json")
    assert grasp.hand.joints["left_joint"] == 0.7
    assert grasp.hand.joint_limits["left_joint"] == pytest.approx((0.0, 0.8))
    data["hand_options"]["angle"] = "radians"
    (tmp_path / "g.json").write_text(json.dumps(data))
    with pytest.raises(eg.GraspFileError, match=r"hand_options\.angle"):
        eg.Grasp.from_file(tmp_path / "g.json")


def test_the_warning_is_as_documented_and_inspect_gives_it_as_flags(tmp_path, monkeypatch, capsys):
    from exactgrasp.cli import main

    monkeypatch.chdir(tmp_path)
    _write(tmp_path, gripper())
    with pytest.warns(UserWarning, match="compiler angle") as caught:
        load_model("gripper.xml", palm=PALM)
    page = (ROOT / "docs" / "hand-models.md").read_text()
    section = page.split("## Angles: degrees unless the MJCF file says")[1]
    documented = " ".join(section.split("```text\n")[1].split("```")[0].split())
    assert documented in [str(w.message) for w in caught]
    assert main(["inspect", "gripper.xml"]) == 0
    out = capsys.readouterr().out
    assert "[0, 0.01396] rad (0 .. 0.8 deg)" in out
    assert "pass --angle radian to read the file's angles as radians" in out
    assert main(["inspect", "gripper.xml", "--angle", "radian"]) == 0
    out = capsys.readouterr().out
    assert "[0, 0.8] rad (0 .. 45.84 deg)" in out and "warning" not in out
