"""A lab's gripper as its ROS package ships it, used unmodified: ``package://`` mesh names, an
open collision mesh, prismatic fingers that close towards their lower limit with a URDF
``<mimic>``; read from a grasp file, closed, and described, without editing a file."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

import exactgrasp as eg
from exactgrasp.grasp.closing import close_grasp

BASE = (0.10, 0.04, 0.02)  # box sides (m), its top face at z = 0
JAW = (0.02, 0.01, 0.05)
STROKE = 0.04  # per finger: fully open jaws are 0.08 m apart
WIDTH = 0.05  # the grasped box, along y

URDF = """<robot name="lab_gripper">
  <link name="base"><collision><origin xyz="0 0 -0.01"/>
    <geometry><mesh filename="package://lab_gripper/meshes/base.stl"/></geometry></collision>
  </link>
  <link name="left"><collision><origin xyz="0 0.005 0.025"/>
    <geometry><mesh filename="package://lab_gripper/meshes/jaw.obj"/></geometry></collision>
  </link>
  <link name="right"><collision><origin xyz="0 -0.005 0.025"/>
    <geometry><mesh filename="package://lab_gripper/meshes/jaw.obj"/></geometry></collision>
  </link>
  <joint name="left_joint" type="prismatic"><parent link="base"/><child link="left"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="{stroke}" effort="10" velocity="1"/></joint>
  <joint name="right_joint" type="prismatic"><parent link="base"/><child link="right"/>
    <axis xyz="0 -1 0"/><limit lower="0" upper="{stroke}" effort="10" velocity="1"/>
    <mimic joint="left_joint" multiplier="1" offset="0"/></joint>
</robot>"""


def _lab_package(root: Path) -> Path:
    pkg = root / "src" / "lab_gripper"
    (pkg / "meshes").mkdir(parents=True)
    base = trimesh.creation.box(BASE)
    # As exported from a CAD tool with one side missing: open, needs repair.
    trimesh.Trimesh(base.vertices, base.faces[:-2], process=False).export(pkg / "meshes/base.stl")
    trimesh.creation.box(JAW).export(pkg / "meshes" / "jaw.obj")
    (pkg / "package.xml").write_text("<package format='3'><name>lab_gripper</name></package>")
    (pkg / "urdf").mkdir()
    (pkg / "urdf" / "gripper.urdf").write_text(URDF.format(stroke=STROKE))
    return pkg


@pytest.fixture
def grasp_file(tmp_path, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    pkg = _lab_package(tmp_path / "ws")
    trimesh.creation.box((0.03, WIDTH, 0.04)).export(tmp_path / "box.stl")
    record = {
        "object": "box.stl",
        "object_units": "m",
        "object_pose_in_hand": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.025], [0, 0, 0, 1]],
        "hand_model": str(Path("ws/src/lab_gripper/urdf/gripper.urdf")),
        "hand_options": {
            "package_dirs": ["ws/src"],
            "repair": True,
            "palm": {"origin": [0, 0, 0], "normal": "+z", "up": "+y", "depth": 0.05},
        },
        "joints": {"left_joint": STROKE},
    }
    path = tmp_path / "grasps" / "lab.json"
    path.parent.mkdir()
    # Paths in a grasp file are relative to the file.
    record["object"] = "../box.stl"
    record["hand_model"] = "../" + record["hand_model"]
    record["hand_options"]["package_dirs"] = ["../ws/src"]
    path.write_text(json.dumps(record))
    assert pkg.is_dir()
    return path


def test_lab_gripper_closes_and_is_described_unmodified(grasp_file):
    with pytest.warns(UserWarning, match="base"):  # the repaired mesh is reported
        grasp = eg.Grasp.from_file(grasp_file)
    assert grasp.hand.volume == pytest.approx(np.prod(BASE) + 2 * np.prod(JAW), rel=1e-6)

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no back-off, no penetration warning
        closed = close_grasp(grasp)
    gap = 2 * closed.hand.joints["left_joint"]  # the mimic jaw mirrors the driver
    assert 0.0 < gap - WIDTH <= 2e-3
    np.testing.assert_array_equal(closed.object_pose, grasp.object_pose)

    sampler = eg.PathSampler(n_translations=6, n_axes=2, n_amounts=2, n_steps=3)
    d = eg.compute_descriptor(closed, sampler, backend="exact")
    assert d.values.shape == (sampler.n_paths, 3)
    # In contact, not penetrating, at the grasp pose; moving the box out of the hand makes it
    # intersect the jaws and the base.
    assert eg.get_backend("exact").volumes(closed, np.eye(4)) == 0.0
    assert d.values.max() > 0.01

    out = grasp_file.with_name("closed.json")
    closed.save(out)
    again = eg.Grasp.from_file(out)
    assert again.hand.joints == pytest.approx(closed.hand.joints)
