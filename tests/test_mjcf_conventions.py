"""MJCF and URDF files as simulation frameworks ship them: the angle unit a gripper file leaves
to the robot model that includes it, fixed tendons as couplings, all of a model's problems in
one report, palm frames without a file."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
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
    assert [str(caution) for caution in model.cautions] == [message.split(" (in a grasp file")[0]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        radians = load_model(path, palm=PALM, angle="radian")
        degrees = load_model(path, palm=PALM, angle="degree")
    assert radians.joint_limits["left_joint"] == pytest.approx((0.0, 0.8))
    assert radians.cautions == ()
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
    assert model.cautions == ()
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


# -- fixed tendons as couplings -----------------------------------------------------------------

RADIAN = '<compiler angle="radian"/>'
ONE_TENDON = """
  <tendon><fixed name="split"><joint joint="left_joint" coef="1"/>
    <joint joint="right_joint" coef="-2"/></fixed></tendon>
  <equality><tendon tendon1="split" polycoef="0.05 0 0 0 0"/></equality>"""
TWO_TENDONS = """
  <tendon><fixed name="a"><joint joint="right_joint" coef="2"/></fixed>
    <fixed name="b"><joint joint="left_joint" coef="1"/></fixed></tendon>
  <equality><tendon tendon1="a" tendon2="b" polycoef="0.1 0.5 0 0 0"/></equality>"""


def _residual(model, joints) -> float:
    """MuJoCo's own equality residual at the hand's full joint values."""
    import mujoco

    m = model._m
    data = mujoco.MjData(m)
    for name, value in model.all_joint_values(model.check_joints(joints)).items():
        data.qpos[m.jnt_qposadr[model._joint_ids[name]]] = value
    mujoco.mj_forward(m, data)
    return float(
        np.abs(data.efc_pos[data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY]).max()
    )


@pytest.mark.parametrize(
    ("extra", "ratio", "offset"), [(ONE_TENDON, 0.5, -0.025), (TWO_TENDONS, 0.25, 0.05)]
)
def test_a_gripper_tied_by_a_fixed_tendon_closes_as_one(tmp_path, extra, ratio, offset):
    """left - 2 right = 0.05 (one tendon held); 2 right = 0.1 + 0.5 left (two tied)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = load_model(_write(tmp_path, gripper(RADIAN, extra=extra)), palm=PALM)
    assert model.joint_names == ("left_joint",)
    driver, got_ratio, got_offset = model.couplings["right_joint"]
    assert (driver, got_ratio, got_offset) == (
        "left_joint",
        pytest.approx(ratio),
        pytest.approx(offset),
    )
    for left in (0.2, 0.5, 0.8):
        full = model.all_joint_values({"left_joint": left})
        assert full["right_joint"] == pytest.approx(offset + ratio * left)
        assert _residual(model, {"left_joint": left}) < 1e-12
    # moving the driving joint turns the other finger by the relation (box centres, hand frame)
    centres = {name: V.mean(axis=0) for name, V, _ in model.link_meshes({"left_joint": 0.6})}
    right = offset + ratio * 0.6
    np.testing.assert_allclose(
        centres["left"], [0.02 + 0.02 * np.sin(0.6), 0, 0.01 + 0.02 * np.cos(0.6)], atol=1e-12
    )
    np.testing.assert_allclose(
        centres["right"],
        [-0.02 - 0.02 * np.sin(right), 0, 0.01 + 0.02 * np.cos(right)],
        atol=1e-12,
    )


def test_a_soft_tendon_is_warned_with_the_coupling_that_would_tie_it(tmp_path):
    soft = """
  <tendon><fixed name="spring" stiffness="50" springlength="0.1">
    <joint joint="left_joint" coef="1"/><joint joint="right_joint" coef="-1"/></fixed></tendon>"""
    path = _write(tmp_path, gripper(RADIAN, extra=soft))
    with pytest.warns(UserWarning) as caught:
        model = load_model(path, palm=PALM)
    (message,) = [str(w.message) for w in caught]
    assert message == (
        f"{path}: fixed tendons with stiffness and no <equality><tendon> couple their joints "
        "only softly, so here the joints move independently: 'spring' ties left_joint, "
        "right_joint (couplings={'right_joint': ('left_joint', 1, -0.1)} holds its rest "
        "length); pass couplings={dependent: (driver, ratio, offset)} to tie them"
    )
    assert model.joint_names == ("left_joint", "right_joint")
    # the coupling it names ties them, and quiets it
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tied = load_model(path, palm=PALM, couplings={"right_joint": ("left_joint", 1, -0.1)})
    assert tied.all_joint_values({"left_joint": 0.5})["right_joint"] == pytest.approx(0.4)


def test_a_tendon_equality_over_three_joints_is_left_with_a_warning(tmp_path):
    text = gripper(RADIAN).replace(
        '<geom name="palm"',
        '<joint name="wrist" type="hinge" axis="0 0 1" range="-1 1"/><geom name="palm"',
    )
    text = text.replace(
        '<body name="palm">',
        '<body name="base"><geom type="sphere" size="0.001"/><body name="palm">',
    ).replace("</worldbody>", "</body></worldbody>")
    extra = """
  <tendon><fixed name="three"><joint joint="left_joint" coef="1"/>
    <joint joint="right_joint" coef="1"/><joint joint="wrist" coef="1"/></fixed></tendon>
  <equality><tendon tendon1="three"/></equality>"""
    path = _write(tmp_path, text.replace("</mujoco>", extra + "\n</mujoco>"))
    with pytest.warns(UserWarning, match=r"ties 3 joint\(s\) \(left_joint, right_joint, wrist\)"):
        model = load_model(path, palm=PALM)
    assert model.couplings == {}


@pytest.mark.parametrize(
    ("extra", "said"),
    [
        (TWO_TENDONS.replace("0.1 0.5 0 0 0", "0.1 0.5 0.2 0 0"), "non-linear tendon equality"),
        (
            """
  <tendon><spatial name="cord"><site site="s1"/><site site="s2"/></spatial></tendon>
  <equality><tendon tendon1="cord"/></equality>""",
            r"only fixed tendons \(sums of joint values\) become couplings",
        ),
    ],
)
def test_tendon_equalities_that_are_not_couplings_are_warned(tmp_path, extra, said):
    text = gripper(RADIAN, extra=extra)
    text = text.replace('pos="0 0 0.02"/>', 'pos="0 0 0.02"/><site name="s{}"/>', 2)
    text = text.replace("s{}", "s1", 1).replace("s{}", "s2", 1)
    with pytest.warns(UserWarning, match=said):
        model = load_model(_write(tmp_path, text), palm=PALM)
    assert model.joint_names == ("left_joint", "right_joint") and model.couplings == {}


# -- all of a model's problems in one report ------------------------------------------------------

#: A tetrahedron with one face missing: MuJoCo compiles it; it bounds no solid.
OPEN_TETRA = "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0 0 0.01\nf 1 3 2\nf 1 2 4\nf 2 3 4\n"


def _broken(tmp_path):
    """The gripper, in degrees without saying so, with an open mesh geom on its palm."""
    (tmp_path / "open.obj").write_text(OPEN_TETRA)
    text = gripper().replace(
        '<geom name="palm" type="box" size="0.03 0.02 0.01"/>',
        '<geom name="palm" type="box" size="0.03 0.02 0.01"/>'
        '<geom name="shell" type="mesh" mesh="open" pos="0 0 -0.03"/>',
    )
    text = text.replace(
        "<worldbody>", '<asset><mesh name="open" file="open.obj"/></asset>\n  <worldbody>'
    )
    return _write(tmp_path, text)


def test_three_problems_come_in_one_error_each_with_its_fix(tmp_path):
    path = _broken(tmp_path)
    with pytest.raises(ModelError) as caught:
        eg.Hand.from_mjcf(path)
    error = caught.value
    lines = str(error).splitlines()
    assert lines[0] == f"{path}: 3 problems, each with its fix:"
    assert len(lines) == 4 and all(line.startswith("  - ") for line in lines[1:])
    assert "mesh geom 'shell' of body 'palm' is not a closed surface" in lines[1]
    assert "pass repair=True" in lines[1]
    assert "MuJoCo read its hinge ranges in degrees" in lines[2]
    assert "pass angle='radian'" in lines[2]
    assert lines[3].startswith("  - gripper has no palm frame; write the palm frame into ")
    assert 'or pass palm={"origin": [x, y, z], "normal": [x, y, z], "up"' in lines[3]
    assert [type(p).__name__ for p in error.problems] == ["ModelError", "ModelError", "FrameError"]
    assert [f.parameter for p in error.problems for f in p.fixes] == [
        "repair", "angle", "angle", "palm"
    ]  # fmt: skip
    # load_model reports a palm frame that names no body, with the rest
    with pytest.raises(ModelError) as caught:
        load_model(path, palm={"body": "nope", "normal": "+z", "up": "+y", "depth": 0.05})
    lines = str(caught.value).splitlines()
    assert lines[0] == f"{path}: 3 problems, each with its fix:"
    assert lines[2] == f"  - {path}: palm body 'nope' does not exist"
    # each fix taken, it loads
    with pytest.warns(UserWarning, match="repaired 1 mesh geom"):
        hand = eg.Hand.from_mjcf(path, palm=PALM, repair=True, angle="radian")
    assert hand.joint_limits["left_joint"] == pytest.approx((0.0, 0.8))


def test_inspect_prints_the_same_report_in_its_flags(tmp_path, capsys):
    from exactgrasp.cli import main

    path = _broken(tmp_path)
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    at = out.index("as a hand: not loadable with these options (3 problem(s), each with its fix):")
    report = out[at + 1 :]
    assert len(report) == 3
    assert "is not a closed surface" in report[0] and "pass --repair" in report[0]
    assert "pass --angle radian" in report[1]
    assert 'or pass --palm \'{"origin": [x, y, z]' in report[2]
    palm = json.dumps(PALM)
    argv = ["inspect", str(path), "--repair", "--angle", "radian", "--palm", palm]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "palm frame: origin (0, 0, 0.01), normal (0, 0, 1), up (0, 1, 0), depth 0.06 m" in out
    coupled = '{"right_joint": ["left_joint", 1]}'
    assert main([*argv, "--couplings", coupled]) == 0
    out = capsys.readouterr().out
    assert "user-facing joints: left_joint\n" in out and "right_joint = 0 + 1 * left_joint" in out


# -- palm frames without a file -------------------------------------------------------------------


def test_a_palm_frame_file_keyed_by_model_file_name(tmp_path):
    """The documented keyed palm_frame.json, in a folder of two models (and one it lacks)."""
    page = (ROOT / "docs" / "hand-models.md").read_text()
    keyed = json.loads(page.split("is keyed):\n\n```json\n")[1].split("```")[0])
    (tmp_path / "palm_frame.json").write_text(json.dumps(keyed))
    site = '<site name="pinch" pos="0 0 0.01"/><geom name="palm"'
    robotiq = gripper(RADIAN).replace('<geom name="palm"', site)
    model = load_model(_write(tmp_path, robotiq, "robotiq.xml"))
    assert model.palm.origin == pytest.approx((0, 0, 0.01)) and model.palm.depth == 0.06
    urdf = tmp_path / "panda_hand.urdf"
    urdf.write_text(
        '<robot name="panda_hand"><link name="base"><collision><geometry>'
        '<box size="0.1 0.1 0.1"/></geometry></collision></link></robot>'
    )
    assert load_model(urdf).palm.origin == pytest.approx((0, 0, 0.06))
    other = _write(tmp_path, gripper(RADIAN), "other.xml")
    assert load_model(other).palm is None
    with pytest.raises(eg.FrameError) as caught:
        eg.Hand.from_mjcf(other)
    assert str(caught.value) == (
        'gripper has no palm frame; add "other.xml": {"origin": [x, y, z], "normal": [x, y, z], '
        f'"up": [x, y, z], "depth": d}} to {tmp_path / "palm_frame.json"} (keyed by model file '
        "name) in the model's coordinates (metres): the centre of the palm's face, the "
        "direction out of the palm, the direction along the palm towards the thumb (or a "
        "chosen side), and the distance from the palm to the outside of the loosely closed "
        "fingers (see docs/tutorial.md, 'The palm frame'), or pass palm={\"origin\": [x, y, z], "
        '"normal": [x, y, z], "up": [x, y, z], "depth": d}.'
    )
    # palm= needs no file; a grasp file spells it as its key
    assert eg.Hand.from_mjcf(other, palm=PALM).frame.scale == pytest.approx(2 / 0.06)
    fix = caught.value.fixes[0]
    assert fix.parameter == "palm"
    from exactgrasp.grasp.files import file_terms

    assert file_terms(fix.replace(file_key="hand_options.palm")) == (
        'set "hand_options": {"palm": {"origin": [x, y, z], "normal": [x, y, z], "up": '
        '[x, y, z], "depth": d}} in the grasp file'
    )


def test_an_unreadable_palm_frame_file_is_one_of_the_problems(tmp_path):
    (tmp_path / "palm_frame.json").write_text("{not json")
    path = _broken(tmp_path)
    with pytest.raises(ModelError) as caught:
        eg.Hand.from_mjcf(path, angle="radian")
    lines = str(caught.value).splitlines()
    assert lines[0] == f"{path}: 2 problems, each with its fix:"
    assert lines[2].startswith(f"  - {tmp_path / 'palm_frame.json'}: unreadable (")
