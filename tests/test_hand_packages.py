"""Hands as robotics packages ship them: package:// and model:// mesh names, open meshes
repaired, scenes with root_body (and without), and ``exactgrasp inspect``."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

pytest.importorskip("mujoco", reason="the models extra (mujoco) is not installed")

import exactgrasp as eg
from exactgrasp.cli.main import main
from exactgrasp.errors import ModelError
from exactgrasp.hands import load_model
from exactgrasp.hands.sources import ModelSource

PALM = (0.04, 0.04, 0.02)  # box sides (m)
FINGER = (0.01, 0.03, 0.01)

URDF = """<robot name="pkg_hand">
  <link name="palm"><collision><geometry><mesh filename="{palm}"/></geometry></collision>
    <visual><geometry><mesh filename="{visual}"/></geometry></visual></link>
  <link name="finger"><collision><origin xyz="0 0.015 0.005"/>
    <geometry><mesh filename="{finger}"/></geometry></collision></link>
  <joint name="knuckle" type="revolute"><parent link="palm"/><child link="finger"/>
    <origin xyz="0 0.02 0.01"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="1.5" effort="1" velocity="1"/></joint>
</robot>"""
PALM_URI = "package://my_hand/meshes/collision/palm.obj"
FINGER_URI = "package://my_hand/meshes/collision/finger.stl"
# A visual mesh MuJoCo cannot read: never opened when only collision geometry is wanted.
VISUAL_URI = "package://my_hand/meshes/visual/palm.dae"


def _box_file(path: Path, sides, drop_face: bool = False) -> Path:
    box = trimesh.creation.box(sides)
    faces = box.faces[:-2] if drop_face else box.faces  # the last two triangles: one side
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.Trimesh(box.vertices, faces, process=False).export(path)
    return path


def _package(root: Path, folder: str = "my_hand", name: str = "my_hand") -> Path:
    """A ROS package: package.xml naming it, meshes, and its URDF in urdf/."""
    pkg = root / folder
    _box_file(pkg / "meshes" / "collision" / "palm.obj", PALM)
    _box_file(pkg / "meshes" / "collision" / "finger.stl", FINGER)
    (pkg / "meshes" / "visual").mkdir(parents=True)
    (pkg / "meshes" / "visual" / "palm.dae").write_text("<COLLADA/>")
    (pkg / "package.xml").write_text(f"<package format='3'><name>{name}</name></package>")
    (pkg / "urdf").mkdir()
    (pkg / "urdf" / "hand.urdf").write_text(
        URDF.format(palm=PALM_URI, finger=FINGER_URI, visual=VISUAL_URI)
    )
    return pkg


def _elsewhere(tmp_path: Path, pkg: Path) -> Path:
    """The package's URDF copied to a folder outside it: the fallback cannot find the meshes."""
    out = tmp_path / "elsewhere"
    out.mkdir()
    (out / "hand.urdf").write_text((pkg / "urdf" / "hand.urdf").read_text())
    return out / "hand.urdf"


def _check_volumes(model):
    volumes = {n: trimesh.Trimesh(V, F).volume for n, V, F in model.link_meshes({})}
    assert volumes["palm"] == pytest.approx(np.prod(PALM), rel=1e-6)
    assert volumes["finger"] == pytest.approx(np.prod(FINGER), rel=1e-6)


@pytest.fixture
def no_env(monkeypatch):
    for var in ("ROS_PACKAGE_PATH", "GZ_SIM_RESOURCE_PATH", "GAZEBO_MODEL_PATH"):
        monkeypatch.delenv(var, raising=False)
    return monkeypatch


def test_package_uris_through_package_dirs(tmp_path, no_env):
    pkg = _package(tmp_path / "ws" / "src")
    urdf = _elsewhere(tmp_path, pkg)
    _check_volumes(load_model(urdf, package_dirs={"my_hand": pkg}))
    _check_volumes(load_model(urdf, package_dirs=[tmp_path / "ws"]))  # a folder of packages
    _check_volumes(load_model(urdf, package_dirs=str(pkg)))  # the package itself


def test_package_uris_through_ros_package_path(tmp_path, no_env):
    pkg = _package(tmp_path / "ws" / "src")
    no_env.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'nothing'}:{tmp_path / 'ws'}")
    model = load_model(_elsewhere(tmp_path, pkg))
    _check_volumes(model)
    assert model.joint_names == ("knuckle",)


def test_package_uris_fall_back_to_the_model_folder_and_parents(tmp_path, no_env):
    # package.xml names the package; the folder is named otherwise (a downloaded archive).
    pkg = _package(tmp_path, folder="my_hand-main")
    _check_volumes(load_model(pkg / "urdf" / "hand.urdf"))
    # The mesh folder itself named as the package ("package://meshes/..."): found as
    # <ancestor>/meshes/collision/... (the message used to show a single slash).
    text = (
        (pkg / "urdf" / "hand.urdf")
        .read_text()
        .replace("package://my_hand/meshes/", "package://meshes/")
    )
    (pkg / "urdf" / "short.urdf").write_text(text)
    _check_volumes(load_model(pkg / "urdf" / "short.urdf"))


def test_unresolvable_package_uri_is_named_with_the_places_searched(tmp_path, no_env):
    pkg = _package(tmp_path / "ws" / "src")
    urdf = _elsewhere(tmp_path, pkg)
    with pytest.raises(ModelError) as info:
        load_model(urdf)
    message = str(info.value)
    assert PALM_URI in message  # the full URI, both slashes
    assert "ROS_PACKAGE_PATH: not set" in message
    assert "package_dirs (not given)" in message and "package_dirs={'my_hand':" in message
    assert str(urdf.parent) in message  # the model's folder, searched last
    # A package that is found but lacks the file says so.
    other = tmp_path / "other" / "my_hand"
    other.mkdir(parents=True)
    with pytest.raises(ModelError, match=r"package 'my_hand' found at .*other/my_hand"):
        load_model(urdf, package_dirs={"my_hand": other})
    with pytest.raises(ModelError, match="is not a folder"):
        load_model(urdf, package_dirs={"my_hand": tmp_path / "missing"})
    with pytest.raises(ModelError, match="package_dirs must be"):
        load_model(urdf, package_dirs=3)


def test_visual_meshes_resolved_only_when_wanted(tmp_path, no_env):
    pkg = _package(tmp_path)
    # geometry="visual" needs the .dae, which MuJoCo cannot read: refused, not silently skipped.
    with pytest.raises(ModelError, match=r"palm\.dae"):
        load_model(pkg / "urdf" / "hand.urdf", geometry="visual")


MJCF = """<mujoco model="gz_hand">
  <asset><mesh name="palm" file="{uri}"/></asset>
  <worldbody><body name="palm"><geom name="palm" type="mesh" mesh="palm"/></body></worldbody>
</mujoco>"""


def test_model_uri_in_mjcf(tmp_path, no_env):
    _box_file(tmp_path / "models" / "gz_hand" / "meshes" / "palm.stl", PALM)
    path = tmp_path / "scenes" / "hand.xml"
    path.parent.mkdir()
    path.write_text(MJCF.format(uri="model://gz_hand/meshes/palm.stl"))
    with pytest.raises(ModelError, match=r"'model://gz_hand/meshes/palm\.stl'"):
        load_model(path)
    model = load_model(path, package_dirs=[tmp_path / "models"])
    V, F = model.link_meshes({})[0][1:]
    assert trimesh.Trimesh(V, F).volume == pytest.approx(np.prod(PALM), rel=1e-6)
    hand = eg.Hand.from_mjcf(
        path, frame=eg.HandFrame.identity(), package_dirs=[tmp_path / "models"]
    )
    assert hand.volume == pytest.approx(np.prod(PALM), rel=1e-6)
    no_env.setenv("GAZEBO_MODEL_PATH", str(tmp_path / "models"))
    assert load_model(path).link_names == ("palm",)


def test_grasp_file_keeps_package_dirs_relative(tmp_path, no_env):
    pkg = _package(tmp_path / "ws" / "src")
    urdf = _elsewhere(tmp_path, pkg)
    hand = eg.Hand.from_urdf(urdf, frame=eg.HandFrame.identity(), package_dirs={"my_hand": pkg})
    keys = ModelSource().write(hand, tmp_path / "grasps", "g")
    assert keys["hand_options"]["package_dirs"] == {"my_hand": "../ws/src/my_hand"}
    (tmp_path / "grasps").mkdir()
    data = {**keys, "hand_model": "../elsewhere/hand.urdf"}
    read = ModelSource().read(
        data,
        tmp_path / "grasps",
        "g.json",
        joints={},
        frame=eg.HandFrame.identity(),
        on_limit="error",
    )
    assert read.link_names == ["palm", "finger"]


# -- repair ----------------------------------------------------------------------------------

OPEN_HAND = """<mujoco model="open_hand">
  <asset><mesh name="shell" file="open_box.stl"/></asset>
  <worldbody>
    <body name="{outer}">
      {outer_geom}
      <body name="hand" pos="0 0 0.1">
        <geom name="palm_shell" type="mesh" mesh="shell"/>
        <body name="finger" pos="0 0 0.05">
          <joint name="knuckle" axis="1 0 0" range="0 1.5"/>
          <geom name="pad" type="box" size="0.005 0.01 0.005" pos="0 0 0.01"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""
SIDES = (0.03, 0.02, 0.04)


def _open_hand(tmp_path, outer_geom=""):
    _box_file(tmp_path / "open_box.stl", SIDES, drop_face=True)
    path = tmp_path / "open_hand.xml"
    path.write_text(OPEN_HAND.format(outer="mount", outer_geom=outer_geom))
    return path


def test_open_mesh_refused_without_repair(tmp_path):
    with pytest.raises(ModelError) as info:
        load_model(_open_hand(tmp_path))
    message = str(info.value)
    assert "'palm_shell'" in message and "'hand'" in message and "not a closed" in message
    assert "repair=True" in message


def test_open_mesh_repaired(tmp_path):
    path = _open_hand(tmp_path)
    with pytest.warns(UserWarning, match=r"repaired 1 mesh geom") as caught:
        hand = eg.Hand.from_mjcf(path, frame=eg.HandFrame.identity(), repair=True)
    message = next(str(w.message) for w in caught if "repaired" in str(w.message))
    assert "'palm_shell'" in message and "filled holes" in message
    before, after = map(float, re.search(r"volume (\S+) -> (\S+) m\^3", message).groups())
    assert after == pytest.approx(np.prod(SIDES), rel=1e-5) and before != after
    links = dict(zip(hand.link_names, hand.link_arrays(), strict=True))
    V, F = links["hand"]
    # MuJoCo stores mesh vertices as float32: the closed box, to float32 rounding.
    assert trimesh.Trimesh(V, F).volume == pytest.approx(np.prod(SIDES), rel=1e-6)
    assert hand.volume == pytest.approx(np.prod(SIDES) + 0.01 * 0.02 * 0.01, rel=1e-6)
    assert hand.source["options"] == {"repair": True}


def test_a_mesh_geom_repair_cannot_close_is_named(tmp_path):
    pytest.importorskip("pymeshfix", reason="repair needs the repair extra (pymeshfix)")
    # A tetrahedron missing a face, and a lone triangle beside it: nothing closes the triangle.
    (tmp_path / "torn.obj").write_text(
        "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0 0 0.01\nv 0.05 0 0\nv 0.06 0 0\n"
        "v 0.05 0.01 0.002\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 5 6 7\n"
    )
    path = tmp_path / "torn.xml"
    path.write_text(
        '<mujoco><asset><mesh name="torn" file="torn.obj"/></asset><worldbody><body name="palm">'
        '<geom name="palm_shell" type="mesh" mesh="torn"/></body></worldbody></mujoco>'
    )
    with pytest.raises(ModelError) as info, np.errstate(invalid="ignore", divide="ignore"):
        load_model(path, repair=True, palm=False)
    message = str(info.value)
    assert message.startswith(
        f"{path}: mesh geom 'palm_shell' of body 'palm': repair=True could not close the surface"
    )
    assert "fix the mesh in a modeller (e.g. MeshLab, Blender's 3D-print toolbox)" in message


def test_open_mesh_outside_root_body_does_not_stop_the_load(tmp_path):
    # The arm link ("mount") carries the open mesh too; only the hand's subtree is checked.
    path = _open_hand(tmp_path, outer_geom='<geom name="arm_shell" type="mesh" mesh="shell"/>')
    shell = '<geom name="palm_shell" type="mesh" mesh="shell"/>'
    box = '<geom name="palm" type="box" size="0.02 0.02 0.01"/>'
    path.write_text(path.read_text().replace(shell, box))
    with pytest.warns(UserWarning, match=r"outside root body 'hand': arm_shell"):
        model = load_model(path, root_body="hand")
    assert model.link_names == ("hand", "finger")
    with pytest.raises(ModelError, match="'arm_shell'"):
        load_model(path)  # the whole model: the open arm link is part of it


# -- scenes ----------------------------------------------------------------------------------

SCENE = """<mujoco model="scene">
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="table" pos="0 0 0.4"><geom name="top" type="box" size="0.5 0.5 0.02"/></body>
    <body name="hand" pos="0 0 0.6">
      <geom name="palm" type="box" size="0.04 0.04 0.01"/>
      <body name="finger" pos="0 0.04 0.01">
        <joint name="knuckle" axis="1 0 0" range="0 90"/>
        <geom name="phalanx" type="capsule" fromto="0 0 0 0 0.04 0" size="0.008"/>
      </body>
    </body>
    <body name="mug" pos="0 0 0.7">
      <freejoint/>
      <geom name="cup" type="cylinder" size="0.03 0.04"/>
    </body>
  </worldbody>
</mujoco>"""


def test_scene_without_root_body_is_refused_with_the_candidates(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE)
    with pytest.raises(ModelError) as info:
        load_model(path)
    message = str(info.value)
    assert "3 top-level bodies" in message and "root_body=" in message
    names = re.findall(r"'(hand|table|mug)' \(", message)
    assert names == ["hand", "table", "mug"]  # joints first, then geometry; loose last
    assert "free joint: a loose object" in message


def test_free_joint_object_is_never_a_hand_link(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE)
    with pytest.warns(UserWarning, match="outside root body 'hand'"):
        model = load_model(path, root_body="hand", palm=False)
    assert model.link_names == ("hand", "finger") and model.joint_names == ("knuckle",)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        whole = load_model(path, root_body="world", palm=False)
    assert "mug" not in whole.link_names and "table" in whole.link_names
    assert any("loose objects" in str(w.message) and "mug" in str(w.message) for w in caught)


def test_single_body_on_a_ground_plane_needs_no_root_body(tmp_path):
    lines = SCENE.splitlines()
    keep = [line for line in lines if "table" not in line]
    start = next(i for i, line in enumerate(keep) if 'name="mug"' in line)
    path = tmp_path / "hand.xml"
    path.write_text("\n".join(keep[:start] + keep[start + 4 :]))
    with pytest.warns(UserWarning, match=r"not closed solids: floor"):
        model = load_model(path, palm=False)
    assert model.link_names == ("hand", "finger")


# -- exactgrasp inspect ----------------------------------------------------------------------


def test_inspect_builtin_hands(capsys):
    assert main(["inspect", "barrett"]) == 0
    out = capsys.readouterr().out
    assert "finger_1_med_joint': hinge, axis (-1, 0, 0), [0, 2.44] rad" in out
    assert re.search(r"\n  palm  1 collision geom\(s\) \(box\), 0\.09 x 0\.09 x 0\.08 m", out)
    assert "sites: palm_face at (0, 0, 0.08)" in out
    assert "coupling: finger_2_prox_joint follows finger_1_prox_joint" in out
    assert "finger_1_med_joint +, finger_1_dist_joint +" in out
    assert main(["inspect", "parallel_gripper"]) == 0
    out = capsys.readouterr().out
    assert "finger_1_joint': slide, axis (0, 1, 0), [0, 0.04] m" in out
    assert (
        "closing joints (close_fingers' default; + towards the upper limit): finger_1_joint -"
        in out
    )


def test_inspect_scene_and_package(tmp_path, capsys, no_env):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE)
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out
    assert "top-level bodies with geometry (a scene): pass root_body= one of:" in out
    assert "\n  hand  1 collision geom(s) (box)" in out
    assert "\n    finger  1 collision geom(s) (capsule)" in out
    assert "joint 'knuckle': hinge, axis (1, 0, 0), [0, 1.571] rad (0 .. 90 deg)" in out
    assert "as a hand: not loadable" in out
    assert main(["inspect", str(path), "--root-body", "hand"]) == 0
    assert "user-facing joints: knuckle" in capsys.readouterr().out
    pkg = _package(tmp_path / "ws")
    urdf = _elsewhere(tmp_path, pkg)
    assert main(["inspect", str(urdf)]) == 2
    err = capsys.readouterr().err
    assert PALM_URI in err
    # The command names its flag, not load_model's package_dirs argument.
    assert "Searched --package-dir (not given)" in err
    assert "Pass --package-dir my_hand=/path/to/my_hand or --package-dir /folder/holding" in err
    assert "package_dirs" not in err
    assert main(["inspect", str(urdf), "--package-dir", f"my_hand={tmp_path / 'none'}"]) == 2
    err = capsys.readouterr().err
    assert (
        f"--package-dir my_hand={tmp_path / 'none'}: '{tmp_path / 'none'}' is not a folder" in err
    )
    assert main(["inspect", str(urdf), "--package-dir", f"my_hand={pkg}"]) == 0
    assert "joint 'knuckle': hinge" in capsys.readouterr().out


def test_grasp_file_round_trip_with_package_dirs(tmp_path, no_env):
    pkg = _package(tmp_path / "ws" / "src")
    urdf = _elsewhere(tmp_path, pkg)
    hand = eg.Hand.from_urdf(urdf, frame=eg.HandFrame.identity(), package_dirs=[tmp_path / "ws"])
    pose = np.eye(4)
    pose[2, 3] = 0.1
    out = tmp_path / "grasps" / "g.json"
    out.parent.mkdir()
    eg.Grasp(hand, eg.objects.box((0.02, 0.02, 0.02)), pose, name="g").save(out)
    again = eg.Grasp.from_file(out)
    assert again.hand.link_names == hand.link_names
    assert again.hand.volume == pytest.approx(hand.volume, rel=1e-12)
