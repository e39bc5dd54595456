"""The grasp file format: the shipped JSON Schema against the code and the docs, round trips of
every hand kind, and the messages of unknown keys, missing keys, wrong types and bad meshes."""

from __future__ import annotations

import inspect
import json
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

import exactgrasp as eg
from exactgrasp.cache import LRUCache
from exactgrasp.errors import (
    WARNED,
    Fix,
    GraspFileError,
    JointError,
    MeshError,
    MeshWarning,
    ModelError,
)
from exactgrasp.geometry import solid as solid_module
from exactgrasp.geometry.intake import UNITS
from exactgrasp.grasp import FORMAT, files
from exactgrasp.grasp.files import HAND_KEYS, OBJECT_KEYS, OBJECTS, file_terms
from exactgrasp.grasp.schema import INFORMATIONAL, check_grasp_data, grasp_file_schema
from exactgrasp.hands.barrett import barrett
from exactgrasp.hands.builtins import BUILTIN_HANDS
from exactgrasp.hands.gripper import parallel_gripper
from exactgrasp.hands.loading import load_model
from exactgrasp.hands.sources import HAND_SOURCES
from tests.conftest import box_arrays

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "grasp-file.md"
SCHEMA = grasp_file_schema()
POSE = [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0.13], [0, 0, 0, 1.0]]


def resolve(schema: dict) -> dict:
    while "$ref" in schema:
        target = SCHEMA
        for part in schema["$ref"].removeprefix("#/").split("/"):
            target = target[part]
        schema = {**target, **{k: v for k, v in schema.items() if k != "$ref"}}
    return schema


def key_paths(schema: dict = SCHEMA, prefix: str = "") -> dict[str, dict]:
    """Every named key of the schema, dotted (``hand_options.palm.depth``) -> its schema."""
    schema = resolve(schema)
    found = {}
    for branch in schema.get("oneOf", []) + schema.get("anyOf", []):
        found.update(key_paths(branch, prefix))
    for key, sub in schema.get("properties", {}).items():
        path = f"{prefix}{key}"
        found[path] = resolve(sub)
        found.update(key_paths(sub, path + "."))
    return found


KEYS = key_paths()


def hand_variants() -> list[dict]:
    return [resolve(b) for b in resolve(KEYS["hand"])["oneOf"]]


def const(branch: dict, key: str):
    return branch["properties"][key].get("const")


# -- the schema against the code --------------------------------------------------------------


def test_schema_is_valid_json_schema_and_accepts_what_save_writes(tmp_path):
    jsonschema = pytest.importorskip("jsonschema", reason="jsonschema is not a dependency")
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    grasp = eg.Grasp(barrett(), eg.objects.box(), POSE)
    data = json.loads(grasp.save(tmp_path / "g.json").read_text())
    jsonschema.Draft202012Validator(SCHEMA).validate(data)


def test_schema_names_what_the_code_takes():
    assert KEYS["format"]["enum"] == [FORMAT]
    assert KEYS["object_units"]["enum"] == list(UNITS)
    assert {const(b, "type") for b in hand_variants()} == set(HAND_SOURCES) - {"model"}
    (file,) = [b for b in hand_variants() if const(b, "type") == "file"]
    assert file["properties"]["units"]["enum"] == list(UNITS)
    builtins = {const(b, "name"): b for b in hand_variants() if const(b, "type") == "builtin"}
    assert sorted(builtins) == sorted(BUILTIN_HANDS)
    for name, branch in builtins.items():
        params = inspect.signature(BUILTIN_HANDS[name]).parameters
        options = {n for n, p in params.items() if p.kind is inspect.Parameter.KEYWORD_ONLY}
        assert set(branch["properties"]["options"].get("properties", {})) == options, name
    model = inspect.signature(load_model).parameters
    options = {n for n, p in model.items() if p.kind is inspect.Parameter.KEYWORD_ONLY}
    assert set(KEYS["hand_options"]["properties"]) == options - {"xml"}
    frame = set(eg.HandFrame.from_palm([0, 0, 0], [0, 0, 1], [0, 1, 0], 1.0).to_dict())
    assert frame | {"identity"} <= set(KEYS["hand_frame"]["properties"])
    # every key has a description; the file's spelling of each Python option is a schema key
    assert all(sub.get("description") for sub in KEYS.values())
    spelled = [*OBJECT_KEYS.values(), *(k for keys in HAND_KEYS.values() for k in keys.values())]
    # ("": a Python-only setting, such as check_scale, that no key reaches)
    assert set(spelled) - {""} <= set(KEYS)


def test_real_barrett_grasp_files_all_load(shared_data):
    barrett_dir = shared_data / "barrett-grasps"
    files = sorted((barrett_dir / "grasps").glob("*.json")) + sorted(
        (barrett_dir / "noise").glob("*.json")
    )
    assert len(files) == 46
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for path in files:
            eg.Grasp.from_file(path)
    # the study records follow the same schema (read with clipping and repairs elsewhere)
    records = sorted((barrett_dir / "study-records").rglob("*.json"))
    assert len(records) > 300
    for path in records:
        check_grasp_data(json.loads(path.read_text()), str(path))


# -- round trips, one per hand kind -----------------------------------------------------------

MJCF = """<mujoco model="two_link">
  <compiler angle="radian"/>
  <asset><mesh name="palm" file="package://my_hand/meshes/palm.stl"/></asset>
  <worldbody>
    <body name="palm">
      <geom type="mesh" mesh="palm"/>
      <body name="finger" pos="0 0.04 0.01">
        <joint name="knuckle" type="hinge" axis="1 0 0" range="0 1.5"/>
        <geom type="box" size="0.01 0.01 0.03" pos="0 0 0.03"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""
PALM = {"origin": [0, 0, 0.01], "normal": "+z", "up": "+y", "depth": 0.06}


def make_hand(kind: str, folder: Path) -> eg.Hand:
    frame = eg.HandFrame.from_palm([0, 0, 0.02], [0, 0, 1], [0, 1, 0], 0.08)
    if kind == "builtin":
        return barrett({"finger_1_med_joint": 0.7}, distal_coupling=True, tessellation=16)
    if kind == "gripper":
        return parallel_gripper({"finger_1_joint": 0.01})
    if kind == "meshes":
        links = [box_arrays([-0.05, -0.05, 0], [0.05, 0.05, 0.02])]
        return eg.Hand.from_meshes(links, frame=frame, names=["palm"])
    if kind == "file":
        trimesh.Trimesh(*box_arrays([-50, -50, 0], [50, 50, 20])).export(folder / "palm.stl")
        return eg.Hand.from_file(folder / "palm.stl", frame=frame, units="mm", repair=True)
    meshes = folder / "ros" / "my_hand" / "meshes"
    meshes.mkdir(parents=True)
    trimesh.creation.box((0.08, 0.1, 0.02)).export(meshes / "palm.stl")
    (folder / "models").mkdir()
    (folder / "models" / "hand.xml").write_text(MJCF)
    return eg.Hand.from_mjcf(
        folder / "models" / "hand.xml",
        joints={"knuckle": 0.3},
        package_dirs=[str(folder / "ros")],
        repair=True,
        palm=PALM,
    )


@pytest.mark.parametrize("kind", [*sorted(HAND_SOURCES), "gripper"])
def test_round_trip_of_each_hand_kind(kind, tmp_path, monkeypatch):
    grasp = eg.Grasp(make_hand(kind, tmp_path), eg.objects.box((0.02, 0.02, 0.02)), POSE, "rt")
    path = grasp.save(tmp_path / "grasps" / "g.json")
    data = json.loads(path.read_text())
    check_grasp_data(data, str(path))
    assert ("hand_model" in data) == (kind == "model")
    if kind != "model":
        assert data["hand"]["type"] == ("builtin" if kind == "gripper" else kind)
    # read from elsewhere: every path is relative to the grasp file, not the working folder
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    again = eg.Grasp.from_file(path)
    assert again.geometry_key == grasp.geometry_key
    assert again.hand.joints == grasp.hand.joints
    copy_path = again.save(tmp_path / "copies" / "deeper" / "g.json")
    copied = json.loads(copy_path.read_text())
    assert eg.Grasp.from_file(copy_path).geometry_key == grasp.geometry_key
    if kind == "model":
        options = copied["hand_options"]
        assert options["package_dirs"] == ["../../ros"]
        assert options["repair"] is True
        assert options["palm"] == PALM
        assert copied["hand_model"] == "../../models/hand.xml"
    if kind == "builtin":
        assert copied["hand"]["options"] == {"distal_coupling": True, "tessellation": 16}
    if kind == "file":
        assert copied["hand"] == {
            "type": "file",
            "path": "../../palm.stl",
            "units": "mm",
            "repair": True,
        }


def test_surface_samples_are_relative_to_the_grasp_file(tmp_path, monkeypatch):
    trimesh.Trimesh(*box_arrays([-10, -10, -10], [10, 10, 10])).export(tmp_path / "box.stl")
    points = trimesh.PointCloud([[10.0, 0, 0], [0, 10.0, 0], [0, 0, -10.0]])
    points.export(tmp_path / "box_P.ply")
    data = {
        "object": "box.stl",
        "object_units": "mm",
        "object_surface_samples": "box_P.ply",
        "object_pose_in_hand": POSE,
        "hand": {"type": "builtin", "name": "barrett"},
    }
    (tmp_path / "g.json").write_text(json.dumps(data))
    monkeypatch.chdir(tmp_path.parent)
    grasp = eg.Grasp.from_file(tmp_path / "g.json")
    np.testing.assert_allclose(grasp.object.surface_samples[0], [0.01, 0, 0])
    saved = json.loads(grasp.save(tmp_path / "out" / "g.json").read_text())
    assert saved["object_surface_samples"] == "../box_P.ply"


def test_an_object_is_read_once_per_file_and_warned_about_once(tmp_path):
    # An inside-out box (its triangles reversed), 20 mm a side: read, flipped with a warning.
    vertices, faces = box_arrays([-10, -10, -10], [10, 10, 10])
    trimesh.Trimesh(vertices, faces[:, ::-1], process=False).export(tmp_path / "box.stl")
    data = {
        "object": "box.stl",
        "object_units": "mm",
        "object_pose_in_hand": POSE,
        "hand": {"type": "builtin", "name": "barrett"},
    }
    for name in ("a", "b"):
        (tmp_path / f"{name}.json").write_text(json.dumps(data))
    builds = OBJECTS.builds
    grasps = []
    with pytest.warns(MeshWarning, match="inside-out") as caught:
        grasps.append(eg.Grasp.from_file(tmp_path / "a.json"))
    # The warning points at this line, not inside the package.
    assert any(w.filename == __file__ for w in caught)
    # The same mesh read again, through another file too: nothing new to say.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        grasps += [eg.Grasp.from_file(tmp_path / f"{name}.json") for name in ("b", "a")]
    assert not caught
    assert OBJECTS.builds == builds + 1
    assert grasps[0].object is grasps[1].object is grasps[2].object
    assert grasps[0].object.volume == pytest.approx(8e-6, rel=1e-12)

    # Another mesh in the same file (its bytes, not its time stamp) is read again: 40 mm a
    # side, in its own winding.
    trimesh.Trimesh(*box_arrays([-20, -20, -20], [20, 20, 20])).export(tmp_path / "box.stl")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        changed = eg.Grasp.from_file(tmp_path / "a.json")
    assert OBJECTS.builds == builds + 2
    assert changed.object.volume == pytest.approx(6.4e-5, rel=1e-12)
    # Other units are another object.
    data["object_units"] = "cm"
    (tmp_path / "c.json").write_text(json.dumps(data))
    assert eg.Grasp.from_file(tmp_path / "c.json").object.volume == pytest.approx(6.4e-2)
    assert OBJECTS.builds == builds + 3

    # A read that warns and then fails gives its warning and its error, and keeps nothing:
    # the inside-out box read in metres is 20 m long.
    trimesh.Trimesh(vertices, faces[:, ::-1], process=False).export(tmp_path / "box.stl")
    data["object_units"] = "m"
    (tmp_path / "d.json").write_text(json.dumps(data))
    with (
        pytest.warns(MeshWarning, match="inside-out"),
        pytest.raises(GraspFileError, match="too large"),
    ):
        eg.Grasp.from_file(tmp_path / "d.json")
    with warnings.catch_warnings(record=True) as caught:  # the error again, the warning once
        warnings.simplefilter("always")
        with pytest.raises(GraspFileError, match="too large"):
            eg.Grasp.from_file(tmp_path / "d.json")
    assert not caught
    assert OBJECTS.builds == builds + 5


def test_a_resolved_object_is_kept_on_disk_for_every_process(tmp_path, monkeypatch):
    # Two 20 mm cubes in one file, the second 10 mm along x: the solid they bound is a
    # 30 x 20 x 20 mm box, which reading resolves them into with a warning.
    first = box_arrays([-10, -10, -10], [10, 10, 10])
    second = box_arrays([0, -10, -10], [20, 10, 10])
    mesh = trimesh.Trimesh(
        np.vstack([first[0], second[0]]), np.vstack([first[1], second[1] + len(first[0])])
    )
    mesh.export(tmp_path / "two.stl")
    data = {
        "object": "two.stl",
        "object_units": "mm",
        "object_pose_in_hand": POSE,
        "hand": {"type": "builtin", "name": "barrett"},
    }
    (tmp_path / "a.json").write_text(json.dumps(data))
    # Counted where the mesh file is loaded, a call that has returned before any warning.
    reads = []
    real = solid_module.load_trimesh
    monkeypatch.setattr(
        solid_module, "load_trimesh", lambda path: reads.append(path) or real(path)
    )
    with pytest.warns(UserWarning, match="2 shells") as given:
        read = eg.Grasp.from_file(tmp_path / "a.json").object
    assert len(reads) == 1
    assert read.volume == pytest.approx(1.2e-5, rel=1e-12)
    assert read.shell_report["n_shells"] == 2 and read.shell_report["actions"]

    # As another process: its own memory cache, the same disk cache. The mesh is not read
    # again; the solid, its reports and its warnings are the same.
    monkeypatch.setattr(files, "OBJECTS", LRUCache(32))
    WARNED.clear()
    with pytest.warns(UserWarning, match="2 shells") as again:
        kept = eg.Grasp.from_file(tmp_path / "a.json").object
    assert len(reads) == 1
    assert [str(w.message) for w in again] == [str(w.message) for w in given]
    # Kept in memory now, and already said in this process; said again, at this line.
    with warnings.catch_warnings(record=True) as third:
        warnings.simplefilter("always")
        assert eg.Grasp.from_file(tmp_path / "a.json").object is kept
    assert not third
    WARNED.clear()
    with pytest.warns(UserWarning, match="2 shells") as fourth:
        assert eg.Grasp.from_file(tmp_path / "a.json").object is kept
    assert [(w.filename, str(w.message)) for w in fourth] == [
        (__file__, str(w.message)) for w in given
    ]
    assert kept.volume == read.volume  # a cached property of `read` already
    assert set(vars(kept)) == set(vars(read))
    for name, value in vars(read).items():
        if isinstance(value, np.ndarray):
            assert np.array_equal(getattr(kept, name), value), name
        else:
            assert getattr(kept, name) == value, name

    # A process of its own, where reading the mesh would fail: the solid comes from the disk.
    program = (
        "import warnings, exactgrasp as eg\n"
        "from exactgrasp.geometry.solid import Solid\n"
        "def refuse(*a, **k): raise AssertionError('read again')\n"
        "Solid.from_file = refuse\n"
        "warnings.simplefilter('ignore')\n"
        f"print(eg.Grasp.from_file({str(tmp_path / 'a.json')!r}).object.volume)\n"
    )
    run = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert float(run.stdout) == read.volume

    # Surface samples given as an array: not kept, read again each time (the warning, the
    # same mesh's, already said in this process).
    points = np.array([[0.0, 0.0, 10.0], [15.0, 0.0, 10.0]])
    for expected_reads in (2, 3):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            grasp = eg.Grasp.from_file(tmp_path / "a.json", surface_samples=points)
        assert not caught
        assert len(reads) == expected_reads
        assert grasp.object.volume == pytest.approx(1.2e-5, rel=1e-12)

    # Other bytes in the file are another object, read again: one 20 mm cube.
    trimesh.Trimesh(*first).export(tmp_path / "two.stl")
    monkeypatch.setattr(files, "OBJECTS", LRUCache(32))
    assert eg.Grasp.from_file(tmp_path / "a.json").object.volume == pytest.approx(8e-6)
    assert len(reads) == 4


# -- refused keys -----------------------------------------------------------------------------


@pytest.fixture
def grasp_file(tmp_path) -> tuple[Path, dict]:
    """A valid grasp file of the built-in hand and a box, and its content."""
    grasp = eg.Grasp(barrett(), eg.objects.box(), POSE, name="g")
    path = grasp.save(tmp_path / "g.json")
    return path, json.loads(path.read_text())


def write(path: Path, data: dict) -> Path:
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda d: d.update(object_unit="mm"),
            r"unknown key 'object_unit'; did you mean 'object_units'\?",
        ),
        (
            lambda d: d["hand"].update(optins={}),
            r"unknown key 'hand\.optins'; did you mean 'hand\.options'\?",
        ),
        (
            lambda d: d["hand"]["options"].update(tesselation=8),
            r"unknown key 'hand\.options\.tesselation'; "
            r"did you mean 'hand\.options\.tessellation'\?",
        ),
        (
            lambda d: d["hand_frame"].update(orgin=[0, 0, 0]),
            r"unknown key 'hand_frame\.orgin'; did you mean 'hand_frame\.origin'\?",
        ),
        (
            lambda d: d.update(colour="red"),
            r"unknown key 'colour'\. Keys of a grasp file: format, name, object",
        ),
    ],
)
def test_unknown_keys_refused_with_the_closest_known_key(grasp_file, edit, message):
    path, data = grasp_file
    edit(data)
    with pytest.raises(GraspFileError, match=re.escape(str(path)) + ": " + message):
        eg.Grasp.from_file(write(path, data))


def test_unknown_hand_options_key_refused(tmp_path):
    data = {
        "object": "box.stl",
        "object_pose_in_hand": POSE,
        "hand_model": "hand.urdf",
        "hand_options": {"package_dir": ["ros"]},
    }
    with pytest.raises(
        GraspFileError,
        match=r"g\.json: unknown key 'hand_options\.package_dir'; "
        r"did you mean 'hand_options\.package_dirs'\?",
    ):
        eg.Grasp.from_file(write(tmp_path / "g.json", data))


def test_own_notes_and_the_shared_data_keys_are_accepted(grasp_file):
    path, data = grasp_file
    data["x-recorded-by"] = {"rig": 2}
    data["contact_links"] = None
    data["checks"] = {"hand_object_intersection_m3": 0.0}
    assert eg.Grasp.from_file(write(path, data)).name == "g"


def test_own_notes_and_informational_keys_are_not_written_back(grasp_file, tmp_path):
    path, data = grasp_file
    written = set(data)
    data["x-recorded-by"] = {"rig": 2}
    data["contact_links"] = ["finger_1_dist"]
    data["checks"] = {"hand_object_intersection_m3": 0.0}
    again = json.loads(
        eg.Grasp.from_file(write(path, data)).save(tmp_path / "again.json").read_text()
    )
    assert set(again) == written
    assert "x-recorded-by" not in again and "checks" not in again


def test_non_rigid_pose_in_a_file_names_the_key_and_object_units(grasp_file):
    path, data = grasp_file
    data["object_pose_in_hand"] = [
        [1000, 0, 0, 0],
        [0, 1000, 0, 0],
        [0, 0, 1000, 0.1],
        [0, 0, 0, 1],
    ]
    with pytest.raises(GraspFileError) as info:
        eg.Grasp.from_file(write(path, data))
    message = str(info.value)
    assert message.startswith(
        f"{path}: object_pose_in_hand is not a rigid transform: its rotation part is not "
        "orthonormal (max |R^T R - I| = 1e+06: a scale or a shear)."
    )
    assert 'a mesh in other units takes "object_units" in the grasp file, not a scale' in message
    assert "units=" not in message and "Solid(" not in message


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda d: d.pop("object_pose_in_hand"),
            r"missing required key 'object_pose_in_hand' \(Rigid 4x4",
        ),
        (
            lambda d: d["hand"].pop("type"),
            r"missing required key 'hand\.type' \(one of \"builtin\", \"file\", \"meshes\"\)",
        ),
        (
            lambda d: d.update(object_pose_in_hnad=d.pop("object_pose_in_hand")),
            r"missing required key 'object_pose_in_hand'; the file has 'object_pose_in_hnad': "
            r"did you mean 'object_pose_in_hand'\? \(Rigid 4x4",
        ),
        (
            lambda d: d["hand"].update(tpye=d["hand"].pop("type")),
            r"missing required key 'hand\.type'; the file has 'hand\.tpye': did you mean "
            r"'hand\.type'\? \(one of",
        ),
        (lambda d: d.pop("hand"), r"the grasp file needs 'hand_model' or 'hand'"),
        (
            lambda d: d.update(hand_model="h.urdf"),
            r"the grasp file gives 'hand_model' and 'hand'; give one",
        ),
        (
            lambda d: d.update(hand_options={"repair": True}),
            r"'hand_options' applies to 'hand_model' only",
        ),
        (
            lambda d: d.update(hand_frame={"origin": [0, 0, 0]}),
            r"hand_frame needs 'identity' or all of 'origin', 'normal', 'up', 'depth'",
        ),
    ],
)
def test_missing_keys(grasp_file, edit, message):
    path, data = grasp_file
    edit(data)
    with pytest.raises(GraspFileError, match=re.escape(str(path)) + ": " + message):
        eg.Grasp.from_file(write(path, data))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            lambda d: d.update(object_pose_in_hand="eye"),
            r"object_pose_in_hand must be a list of 4 lists of 4 numbers, got the string \"eye\"",
        ),
        (
            lambda d: d["object_pose_in_hand"].pop(),
            r"object_pose_in_hand must be a list of 4 lists of 4 numbers, got a list of 3 items",
        ),
        (
            lambda d: d["object_pose_in_hand"][1].__setitem__(2, "1"),
            r"object_pose_in_hand\[1\]\[2\] must be a number, got the string \"1\"",
        ),
        (
            lambda d: d.update(object_units="millimetres"),
            r"object_units must be one of \"m\", \"cm\", \"mm\", \"inch\", \"in\", "
            r"got the string \"millimetres\"",
        ),
        (
            lambda d: d.update(object_repair="yes"),
            r"object_repair must be true or false, got the string \"yes\"",
        ),
        (
            lambda d: d["joints"].update(finger_1_med_joint="0.5"),
            r"joints\.finger_1_med_joint must be a number",
        ),
        (
            lambda d: d["hand"]["options"].update(tessellation=2),
            r"hand\.options\.tessellation must be an integer >= 4, got 2",
        ),
        (
            lambda d: d["hand"].update(type="builtn"),
            r"hand\.type must be one of \"builtin\", \"file\", \"meshes\", got the string "
            r"\"builtn\" \(did you mean \"builtin\"\?\)",
        ),
        (
            lambda d: d["hand_frame"].update(depth=-1),
            r"hand_frame\.depth must be a number > 0, got -1",
        ),
        (lambda d: d.update(name=7), r"name must be a string, got 7"),
    ],
)
def test_wrong_types(grasp_file, edit, message):
    path, data = grasp_file
    edit(data)
    with pytest.raises(GraspFileError, match=re.escape(str(path)) + ": " + message):
        eg.Grasp.from_file(write(path, data))


# -- errors of the object and the hand name the file's keys -----------------------------------


def open_box_file(path: Path) -> None:
    vertices, faces = box_arrays([-10, -10, -10], [10, 10, 10])
    trimesh.Trimesh(vertices, faces[1:], process=False).export(path)


def test_bad_object_mesh_names_object_and_object_repair(tmp_path):
    open_box_file(tmp_path / "open.stl")
    data = {
        "object": "open.stl",
        "object_units": "mm",
        "object_pose_in_hand": POSE,
        "hand": {"type": "builtin", "name": "barrett"},
    }
    path = write(tmp_path / "g.json", data)
    with pytest.raises(GraspFileError) as info:
        eg.Grasp.from_file(path)
    message = str(info.value)
    assert message.startswith(f"{path}: object: ")
    assert 'set "object_repair": true in the grasp file' in message
    assert "repair=True" not in message
    assert isinstance(info.value.__cause__, MeshError)
    # the fix as the message spells it works, and so does the Python override
    repaired = eg.Grasp.from_file(write(path, {**data, "object_repair": True}))
    assert repaired.object.volume == pytest.approx(0.02**3)
    assert eg.Grasp.from_file(path, repair=True).object.hash == repaired.object.hash


def test_object_in_the_wrong_unit_names_object_units(tmp_path):
    trimesh.Trimesh(*box_arrays([-50, -50, -50], [50, 50, 50])).export(tmp_path / "box.stl")
    data = {
        "object": "box.stl",
        "object_pose_in_hand": POSE,
        "hand": {"type": "builtin", "name": "barrett"},
    }
    with pytest.raises(
        GraspFileError, match=r'set "object_units": "mm" in the grasp file'
    ) as info:
        eg.Grasp.from_file(write(tmp_path / "g.json", data))
    assert "check_scale" not in str(info.value)


def test_hand_errors_name_the_file_keys(tmp_path, grasp_file):
    path, data = grasp_file
    data["joints"]["finger_1_med_joint"] = 3.0
    with pytest.raises(
        JointError, match=r'g\.json: joints: .*set "on_limit": "clip" in the grasp file'
    ):
        eg.Grasp.from_file(write(path, data))
    with pytest.warns(UserWarning, match="clip"):
        eg.Grasp.from_file(write(path, {**data, "on_limit": "clip"}))
    # a model whose package is not found: the fix is spelled as hand_options.package_dirs
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "hand.xml").write_text(MJCF)
    model = {
        "object": data["object"],
        "object_pose_in_hand": POSE,
        "hand_model": "models/hand.xml",
        "hand_options": {"palm": PALM},
    }
    with pytest.raises(
        GraspFileError, match=r'g\.json: hand_model: .*"hand_options": \{"package_dirs"'
    ) as info:
        eg.Grasp.from_file(write(path, model))
    assert isinstance(info.value.__cause__, ModelError)
    assert "package_dirs=" not in str(info.value)
    model["hand_options"]["package_dirs"] = ["nowhere"]
    with pytest.raises(GraspFileError, match=r"hand_options\.package_dirs: the folder 'nowhere'"):
        eg.Grasp.from_file(write(path, model))
    # a rigid hand without a frame: the fix is hand_frame
    trimesh.Trimesh(*box_arrays([0, 0, 0], [0.1, 0.1, 0.02])).export(tmp_path / "palm.stl")
    rigid = {**data, "hand": {"type": "file", "path": "palm.stl"}, "joints": {}}
    del rigid["hand_frame"]
    with pytest.raises(GraspFileError, match=r'g\.json: hand: .*give "hand_frame": \{"origin"'):
        eg.Grasp.from_file(write(path, rigid))


def test_file_terms():
    def key(fix, keys):
        return fix.replace(file_key=keys[fix.parameter])

    assert file_terms(key(Fix("repair", True, "pass"), OBJECT_KEYS)) == (
        'set "object_repair": true in the grasp file'
    )
    assert file_terms(key(Fix("package_dirs", ["/a"], "Pass"), HAND_KEYS["model"])) == (
        'Set "hand_options": {"package_dirs": ["/a"]} in the grasp file'
    )
    assert file_terms(key(Fix("repair", True), HAND_KEYS["file"])) == '"hand": {"repair": true}'
    assert file_terms(key(Fix("units", form="where"), OBJECT_KEYS)) == (
        '"object_units" in the grasp file'
    )
    # a Python-only escape hatch is dropped, a fix without a key keeps its Python spelling
    assert file_terms(key(Fix("check_scale", False, "pass"), OBJECT_KEYS)) is None
    assert file_terms(Fix("repair", True, "pass")) == "pass repair=True"
    # the whole message: the same parts, spelled for the file
    error = MeshError("m: ", Fix("repair", True, "pass"), " to fix it")
    assert str(error) == "m: pass repair=True to fix it"
    again = error.respelled(file_terms, "g.json: object: ", keys=OBJECT_KEYS, cls=GraspFileError)
    assert str(again) == 'g.json: object: m: set "object_repair": true in the grasp file to fix it'
    assert type(again) is GraspFileError and again.parameter == "repair"


# -- the docs ---------------------------------------------------------------------------------

DOC_TEXT = DOC.read_text()
EXAMPLES = re.findall(r"```json\n(.*?)```", DOC_TEXT, flags=re.S)


def doc_rows() -> dict[str, str]:
    return {m.group(1): m.group(0) for m in re.finditer(r"^\| `([^`]+)` \|.*$", DOC_TEXT, re.M)}


def test_doc_describes_every_schema_key_with_its_default():
    rows = doc_rows()
    missing = sorted(set(KEYS) - set(rows))
    assert not missing, f"{DOC.name} has no table row for {missing}"
    unknown = sorted(set(rows) - set(KEYS))
    assert not unknown, f"{DOC.name} describes keys the schema does not have: {unknown}"
    for key, sub in KEYS.items():
        if "default" in sub:
            assert f"`{json.dumps(sub['default'])}`" in rows[key], f"default of {key}"
        if sub["description"].startswith(INFORMATIONAL):
            assert rows[key].count("|") == 4, f"{key} belongs in the informational table"


def test_doc_examples_follow_the_schema():
    assert len(EXAMPLES) == 3
    for text in EXAMPLES:
        check_grasp_data(json.loads(text), DOC.name)


def test_doc_example_loads(tmp_path):
    data = json.loads(EXAMPLES[0])
    trimesh.creation.box((60, 100, 100)).export(tmp_path / data["object"])
    grasp = eg.Grasp.from_file(write(tmp_path / "box-grasp.json", data))
    assert grasp.name == "box-grasp"
    assert grasp.hand.joints["finger_1_med_joint"] == 0.9
    np.testing.assert_allclose(np.ptp(grasp.object.vertices, axis=0), [0.06, 0.1, 0.1])
    resaved = json.loads(grasp.save(tmp_path / "again.json").read_text())
    assert resaved == data
