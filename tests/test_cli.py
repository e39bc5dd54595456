"""The ``exactgrasp`` command: each sub-command against the library call it wraps, the shared
options (``--sampler``/``--steps``, ``--param``, ``--units``/``--repair``), their errors, and
docs/cli.md covering every command and flag."""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.backends import registry
from exactgrasp.backends.params import Interval, Options, Param
from exactgrasp.backends.registry import backend_class
from exactgrasp.backends.voxel import VoxelBackend
from exactgrasp.cli import build_parser, main
from exactgrasp.cli import descriptor as descriptor_command
from exactgrasp.cli.common import sampler_from_args
from exactgrasp.cli.params import backend_names, split_params
from exactgrasp.geometry.files import write_ply
from tests.conftest import box_arrays

ROOT = Path(__file__).resolve().parents[1]
#: A sampler of 5 paths, so that every run here is quick.
TINY = '{"n_translations": 2, "n_axes": 1, "n_amounts": 1}'
COARSE = ["--param", "object_resolution=12", "--param", "hand_resolution=24"]
SAMPLER_COMMANDS = ("demo", "descriptor", "compare", "show", "batch", "evaluate")
BACKEND_COMMANDS = ("demo", "descriptor", "compare", "batch", "evaluate")
GRASP_FILE_COMMANDS = ("descriptor", "compare", "close", "show")


def _slab_hand() -> eg.Hand:
    return eg.Hand.from_meshes(
        [box_arrays([-0.05, -0.05, 0.0], [0.05, 0.05, 0.02])],
        frame=eg.HandFrame.from_palm([0, 0, 0.02], [0, 0, 1], [0, 1, 0], 0.08),
    )


@pytest.fixture
def grasp_file(tmp_path):
    obj = eg.Solid(*box_arrays([-0.02, -0.02, -0.02], [0.02, 0.02, 0.02]))
    pose = np.eye(4)
    pose[:3, 3] = [0, 0, 0.03]  # overlaps the palm slab by 1 cm
    return eg.Grasp(_slab_hand(), obj, pose, name="slab").save(tmp_path / "slab.json")


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    # argparse has no public way to list sub-parsers.
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _flags(parser: argparse.ArgumentParser) -> list[str]:
    return [s for a in parser._actions for s in a.option_strings if s not in ("-h", "--help")]


def _help(command: str) -> str:
    return _subparsers()[command].format_help()


def _error(capsys, argv) -> str:
    """Run a command that must fail on its input: status 2, a message, no traceback."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"exactgrasp {argv[0]}: error:") and "Traceback" not in err, err
    return err


# -- descriptor and compare against the library ------------------------------------------------


def test_descriptor_and_compare_commands(grasp_file, tmp_path, capsys):
    out_a = tmp_path / "a.npz"
    argv = ["descriptor", str(grasp_file), "--backend", "voxel", "-o", str(out_a)]
    assert main([*argv, "--steps", "3", "--param", "object_resolution=20"]) == 0
    d = eg.Descriptor.load(out_a)
    assert d.shape == (474, 3)
    assert d.metadata["backend_params"]["object_resolution"] == 20
    # the command gives the same numbers as the library call it wraps
    api = eg.compute_descriptor(
        eg.Grasp.from_file(grasp_file),
        eg.PathSampler.preset("balanced", n_steps=3),
        backend=VoxelBackend(object_resolution=20),
    )
    assert np.array_equal(api.values, d.values)
    assert d.values.max() > 0
    assert "slab" in capsys.readouterr().out
    out_b = tmp_path / "b.npz"
    assert main(["descriptor", str(grasp_file), "-o", str(out_b), "--steps", "3"]) == 0
    assert main(["compare", str(out_a), str(out_b)]) == 0
    text = capsys.readouterr().out
    assert "l2 distances" in text and "l2_diff distances" in text


def test_compare_backends_command(grasp_file, tmp_path, capsys):
    table = tmp_path / "poses.csv"
    argv = ["compare", str(grasp_file), "--backends", "voxel,voxel", "--steps", "2"]
    assert main([*argv, "-o", str(table), *COARSE]) == 0
    text = capsys.readouterr().out
    assert "reference backend: voxel1" in text
    assert len(table.read_text().splitlines()) == 474 * 2 + 1


def test_errors_are_reported_not_raised(grasp_file, tmp_path, capsys):
    err = _error(capsys, ["descriptor", str(tmp_path / "missing.json"), "-o", "x.npz"])
    assert "no such grasp file" in err
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**json.loads(grasp_file.read_text()), "object": "nothing.stl"}))
    assert "does not exist" in _error(capsys, ["descriptor", str(bad), "-o", "x.npz"])
    assert "compare takes either" in _error(capsys, ["compare", str(tmp_path / "a.txt")])
    err = _error(capsys, ["compare", str(tmp_path / "a.npz"), "--param", "seed=1"])
    assert "--param" in err


def test_demo_quick(tmp_path, capsys):
    assert main(["demo", "--quick", "--out", str(tmp_path / "demo")]) == 0
    out = capsys.readouterr().out
    summary = json.loads((tmp_path / "demo" / "summary.json").read_text())
    backends = {row["backend"] for row in summary}
    assert backends == eg.available_backends()
    assert {"can", "box", "jug handle"} <= {row["grasp"] for row in summary}
    png = (tmp_path / "demo" / "descriptors.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    import matplotlib.image

    # paths x steps images of four grasps (rows) by two backends: a tall figure, not a strip
    image = matplotlib.image.imread(tmp_path / "demo" / "descriptors.png")
    assert image.shape[0] > image.shape[1] > 600
    assert "seconds" in out


def test_console_script_help():
    result = subprocess.run(
        [sys.executable, "-m", "exactgrasp.cli", "--help"], capture_output=True, text=True
    )
    assert result.returncode == 0
    for command in ("demo", "descriptor", "compare", "close"):
        assert command in result.stdout


# -- --sampler and --steps ---------------------------------------------------------------------


@pytest.mark.parametrize("command", SAMPLER_COMMANDS)
def test_sampler_and_steps_are_the_same_option_everywhere(command):
    parsers = _subparsers()
    reference = {a.dest: a.help for a in parsers["descriptor"]._actions}
    actions = {a.dest: a for a in parsers[command]._actions}
    for dest in ("sampler", "steps"):
        assert actions[dest].help == reference[dest], (command, dest)
    positional = {
        "demo": [],
        "descriptor": ["g.json", "-o", "x.npz"],
        "compare": ["g.json"],
        "show": ["g.json"],
        "batch": ["m.jsonl", "--out", "o"],
        "evaluate": ["p.csv", "-o", "o"],
    }[command]
    args = build_parser().parse_args([command, *positional, "--sampler", TINY, "--steps", "2"])
    assert sampler_from_args(args).params == eg.PathSampler(2, 1, 1, n_steps=2).params
    args = build_parser().parse_args([command, *positional, "--sampler", "rotations"])
    assert sampler_from_args(args).params == eg.PathSampler.preset("rotations").params


def test_sampler_from_a_json_file(grasp_file, tmp_path):
    spec = tmp_path / "sampler.json"
    spec.write_text(TINY)
    out = tmp_path / "d.npz"
    argv = ["descriptor", str(grasp_file), "-o", str(out), "--sampler", str(spec)]
    assert main([*argv, "--steps", "2", *COARSE]) == 0
    assert eg.Descriptor.load(out).shape == (5, 2)


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--sampler", "sideways"], r"--sampler 'sideways': not a preset"),
        (["--sampler", "{not json"], r"--sampler '\{not json': not valid JSON"),
        (["--sampler", "[1, 2]"], r"--sampler '\[1, 2\]': not a preset"),
        (["--sampler", '{"n_paths": 3}'], r"unknown parameter\(s\) n_paths; use a preset"),
        (["--sampler", '{"n_axes": 0}'], r"--sampler .*n_axes must be a positive integer"),
        (["--steps", "0"], r"--steps must be a positive number"),
    ],
)
def test_sampler_errors_name_the_flag(grasp_file, capsys, flags, named):
    err = _error(capsys, ["descriptor", str(grasp_file), "-o", "x.npz", *flags])
    assert re.search(named, err), err
    assert "n_steps=" not in err and "PathSampler instance" not in err


# -- --param -----------------------------------------------------------------------------------


@pytest.mark.parametrize("command", BACKEND_COMMANDS)
def test_help_lists_every_declared_parameter(command):
    text = _help(command)
    assert "--param KEY=VALUE" in text
    for name in backend_names():
        constraints = backend_class(name).parameter_constraints
        assert f"  {name}:" in text
        for key in constraints:
            assert re.search(rf"^\s+{key}\s", text, re.M), (command, name, key)
    assert "an integer from 2 to 1000; default 50" in text  # voxel's object_resolution


class TwoKnobs(eg.Backend):
    """A backend the command line has never heard of, with declared parameters."""

    name = "two_knobs"
    parameter_constraints: ClassVar[dict[str, Param]] = {
        "gain": Param(Interval(float, 0, 10), hint="volume multiplier"),
        "mode": Param(Options(("fast", "slow"))),
    }

    def __init__(self, gain: float = 1.0, mode: str = "fast"):
        self.gain, self.mode = gain, mode

    @property
    def params(self):
        return {"gain": self.gain, "mode": self.mode}

    def volumes(self, grasp, poses):
        poses = eg.backends.check_poses(poses)
        return self.gain * np.abs(poses[..., 0, 3])


@pytest.fixture
def two_knobs():
    eg.register_backend("two_knobs", TwoKnobs)
    yield
    registry.unregister_backend("two_knobs")


def test_a_new_backend_parameter_shows_up_without_touching_the_cli(
    two_knobs, grasp_file, tmp_path, capsys
):
    text = _help("descriptor")
    assert re.search(r"two_knobs:\n\s+gain\s+a number from 0 to 10; default 1.0; volume", text)
    assert re.search(r"mode\s+'fast' or 'slow'; default fast", text)
    out = tmp_path / "k.npz"
    argv = ["descriptor", str(grasp_file), "-o", str(out), "--backend", "two_knobs"]
    assert main([*argv, "--sampler", TINY, "--param", "gain=2.5", "--param", "mode=slow"]) == 0
    assert eg.Descriptor.load(out).metadata["backend_params"] == {"gain": 2.5, "mode": "slow"}
    err = _error(capsys, [*argv, "--param", "gain=11"])
    assert "--param gain=11: two_knobs's gain must be a number from 0 to 10, got 11" in err


@pytest.mark.parametrize(
    ("items", "named"),
    [
        (["fov=3"], r"--param fov: unknown key; voxel takes hand_resolution, object_resolution"),
        (["object_resolution=abc"], r"--param object_resolution=abc: voxel's object_resolution "),
        (["object_resolution=1"], r"must be an integer from 2 to 1000, got 1 \(voxels along"),
        (["grid=square"], r"--param grid=square: voxel's grid must be 'floor' or 'round'"),
        (["object_resolution"], r"--param 'object_resolution': expected KEY=VALUE"),
        (["exact.n_jobs=2"], r"--param exact.n_jobs=2: this command runs voxel, not 'exact'"),
        (["voxel.fov=3"], r"--param fov: unknown key; voxel takes hand_resolution"),
        (
            ["surface_samples=100", "surface_spacing=1"],
            r"--param: VoxelBackend: give either surface_samples",
        ),
    ],
)
def test_param_errors_name_the_key_and_the_allowed_keys(grasp_file, capsys, items, named):
    argv = ["descriptor", str(grasp_file), "-o", "x.npz", "--sampler", TINY]
    err = _error(capsys, [*argv, *(f for item in items for f in ("--param", item))])
    assert re.search(named, err), err


def test_param_errors_in_batch_stop_before_any_work(tmp_path, capsys):
    manifest = tmp_path / "m.jsonl"
    manifest.write_text('{"id": 1, "grasp": "g.json"}\n')
    argv = ["batch", str(manifest), "--out", str(tmp_path / "out"), "--param", "fov=1"]
    assert "--param fov: unknown key; voxel takes" in _error(capsys, argv)
    assert not (tmp_path / "out").exists()
    argv = ["batch", str(manifest), "--out", str(tmp_path / "out"), "--backend", "nope"]
    assert "--backend nope: unknown backend 'nope'" in _error(capsys, argv)


@pytest.mark.parametrize(
    ("flags", "named"),
    [
        (["--workers", "-2"], "--workers must be an integer >= 0, got -2."),
        (["--part-size", "0"], "--part-size must be an integer >= 1, got 0."),
        (
            ["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"],
            "--workers sets up a local cluster; with --scheduler the cluster's own workers "
            "compute: leave --workers out.",
        ),
    ],
)
def test_batch_errors_name_the_flag_and_stop_before_any_work(tmp_path, capsys, flags, named):
    manifest = tmp_path / "m.jsonl"
    manifest.write_text('{"id": 1, "grasp": "g.json"}\n')
    err = _error(capsys, ["batch", str(manifest), "--out", str(tmp_path / "out"), *flags])
    assert named in err
    assert "workers=" not in err and "part_size" not in err and "scheduler=" not in err
    assert not (tmp_path / "out").exists()


def test_ctrl_c_exits_130_and_version_prints_the_version(monkeypatch, capsys):
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(descriptor_command, "cmd_descriptor", interrupted)
    assert main(["descriptor", "g.json", "-o", "x.npz"]) == 130
    assert capsys.readouterr().err == "interrupted\n"
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out == f"exactgrasp {eg.__version__}\n"


def test_a_scaled_pose_in_a_grasp_file_names_units_flag_and_key(grasp_file, tmp_path, capsys):
    data = json.loads(grasp_file.read_text())
    data["object_pose_in_hand"] = np.diag([10.0, 10.0, 10.0, 1.0]).tolist()
    scaled = tmp_path / "scaled.json"
    scaled.write_text(json.dumps(data))
    err = _error(capsys, ["descriptor", str(scaled), "-o", str(tmp_path / "x.npz")])
    assert f"{scaled}: object_pose_in_hand is not a rigid transform: " in err
    assert "(max |R^T R - I| = 99: a scale or a shear)" in err
    assert 'takes --units (or "object_units" in the grasp file), not a scale in the pose' in err


def test_params_go_to_the_backends_that_take_them():
    items = ["object_resolution=20", "exact.n_jobs=2", "voxel.grid=round", "broadphase=None"]
    assert split_params(items, ["voxel", "exact"]) == {
        "voxel": {"object_resolution": 20, "grid": "round"},
        "exact": {"n_jobs": 2, "broadphase": None},
    }
    assert split_params(["surface-samples=none"], ["voxel"]) == {
        "voxel": {"surface_samples": "none"}
    }
    with pytest.raises(eg.ExactGraspError, match=r"--param fov: unknown key; voxel takes .*; "):
        split_params(["fov=1"], ["voxel", "exact"])
    with pytest.raises(eg.ExactGraspError, match=r"--backends nope: unknown backend 'nope'"):
        split_params([], ["voxel", "nope"], flag="--backends")


def test_compare_routes_params_per_backend(grasp_file, tmp_path):
    table = tmp_path / "poses.csv"
    argv = ["compare", str(grasp_file), "--backends", "voxel,exact", "--sampler", TINY]
    params = ["--param", "voxel.object_resolution=12", "--param", "hand_resolution=24"]
    assert main([*argv, "--steps", "2", *params, "--param", "n_jobs=1", "-o", str(table)]) == 0
    rows = table.read_text().splitlines()
    column = rows[0].split(",").index("value_voxel")
    voxel = [float(row.split(",")[column]) for row in rows[1:]]
    api = eg.compute_descriptor(
        eg.Grasp.from_file(grasp_file),
        eg.PathSampler(2, 1, 1, n_steps=2),
        backend=VoxelBackend(object_resolution=12, hand_resolution=24),
    )
    np.testing.assert_allclose(voxel, api.values.ravel(), rtol=1e-12)


# -- --units and --repair ----------------------------------------------------------------------


def _grasp_with_mesh(tmp_path, name, vertices, faces, units):
    """A grasp file of the slab hand whose object is the mesh file ``<name>.ply``."""
    base = eg.Grasp(_slab_hand(), eg.Solid(*box_arrays([0, 0, 0], [0.01, 0.01, 0.01])))
    data = base.to_dict(tmp_path, sidecar_stem=name)
    write_ply(tmp_path / f"{name}.ply", vertices, faces)
    pose = np.eye(4)
    pose[:3, 3] = [0, 0, 0.03]
    data.update(object=f"{name}.ply", object_units=units, object_pose_in_hand=pose.tolist())
    data["name"] = name
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("command", GRASP_FILE_COMMANDS)
def test_every_grasp_file_command_has_units_and_repair(command):
    flags = _flags(_subparsers()[command])
    for flag in ("--units", "--repair", "--no-repair", "--on-limit"):
        assert flag in flags, (command, flag)


def test_units_override_the_grasp_file(tmp_path, capsys):
    vertices, faces = box_arrays([-20, -20, -20], [20, 20, 20])  # a 4 cm cube written in mm
    wrong = _grasp_with_mesh(tmp_path, "cube_mm", vertices, faces, units="m")
    argv = ["descriptor", str(wrong), "--sampler", TINY, "--steps", "2", *COARSE]
    err = _error(capsys, [*argv, "-o", str(tmp_path / "x.npz")])
    assert "pass --units mm" in err and "units='mm'" not in err
    out = tmp_path / "cube.npz"
    assert main([*argv, "-o", str(out), "--units", "mm"]) == 0
    right = _grasp_with_mesh(tmp_path, "cube_mm_ok", vertices, faces, units="mm")
    api = eg.compute_descriptor(
        eg.Grasp.from_file(right),
        eg.PathSampler(2, 1, 1, n_steps=2),
        backend=VoxelBackend(object_resolution=12, hand_resolution=24),
    )
    np.testing.assert_array_equal(eg.Descriptor.load(out).values, api.values)
    assert (
        "invalid choice: 'km'"
        in subprocess.run(
            [sys.executable, "-m", "exactgrasp.cli", *argv, "-o", "x.npz", "--units", "km"],
            capture_output=True,
            text=True,
        ).stderr
    )


def test_repair_overrides_the_grasp_file(tmp_path, capsys):
    pytest.importorskip("pymeshfix", reason="object repair needs the repair extra (pymeshfix)")
    vertices, faces = box_arrays([-0.02, -0.02, -0.02], [0.02, 0.02, 0.02])
    holed = _grasp_with_mesh(tmp_path, "holed", vertices, faces[:-1], units="m")
    argv = ["descriptor", str(holed), "--sampler", TINY, "--steps", "2", *COARSE]
    err = _error(capsys, [*argv, "-o", str(tmp_path / "x.npz")])
    assert "not a closed surface" in err and "pass --repair" in err
    assert '(or set "object_repair": true in the grasp file)' in err
    assert main([*argv, "-o", str(tmp_path / "r.npz"), "--repair"]) == 0
    assert eg.Descriptor.load(tmp_path / "r.npz").values.max() > 0


# -- close -------------------------------------------------------------------------------------


@pytest.fixture
def barrett_box_file(tmp_path):
    pytest.importorskip("mujoco", reason="the built-in Barrett hand needs mujoco")
    pytest.importorskip("coal", reason="closing's default engine (coal) is not installed")
    pose = np.eye(4)
    pose[:3, 3] = [0.0, 0.0, 0.0914 + 0.055]  # 5 mm above the open knuckles' tops
    grasp = eg.Grasp(eg.hands.barrett(), eg.objects.box((0.1, 0.06, 0.1)), pose, name="box")
    return grasp.save(tmp_path / "box.json")


def test_close_command_writes_the_closed_grasp(barrett_box_file, tmp_path, capsys):
    out = tmp_path / "closed.json"
    assert main(["close", str(barrett_box_file), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "box: 3 of 3 fingers touch the object (coal)" in text
    closed = eg.Grasp.from_file(out)
    api = eg.close_fingers_result(
        eg.Grasp.from_file(barrett_box_file).hand, closed.object, closed.object_pose
    )
    for finger, result in enumerate(api.fingers, start=1):
        med, dist = result.joints
        assert closed.hand.joints[med] == pytest.approx(api.hand.joints[med], abs=1e-12)
        row = re.search(rf"^{finger}\s+{med}\s+([0-9.]+)\s+upper 2.4400\s+(\S+)", text, re.M)
        assert row and float(row[1]) == pytest.approx(api.hand.joints[med], abs=1e-4)
        assert row[2] == result.contact_links[0] == f"finger_{finger}_dist"
        assert re.search(rf"^\s+{dist}\s+[0-9.]+\s+upper 0.8370$", text, re.M)
    assert f"-> {out}" in text


def test_close_command_options(barrett_box_file, tmp_path, capsys):
    pytest.importorskip("fcl", reason="python-fcl is not installed")
    out = tmp_path / "one.json"
    argv = ["close", str(barrett_box_file), "-o", str(out), "--engine", "fcl"]
    assert main([*argv, "--joints", "finger_1_med_joint,finger_1_dist_joint"]) == 0
    text = capsys.readouterr().out
    assert "box: 1 of 1 fingers touch the object (fcl)" in text
    joints = eg.Grasp.from_file(out).hand.joints
    assert joints["finger_1_med_joint"] > 0.5 and joints["finger_2_med_joint"] == 0.0
    err = _error(capsys, [*argv, "--joints", "finger_1_med_joint,thumb"])
    assert "grasp 'box': unknown joint name 'thumb'" in err
    one = ["--joints", "finger_1_med_joint", "--direction", "finger_1_med_joint=-"]
    assert main([*argv, *one]) == 0
    out_text = capsys.readouterr().out
    assert re.search(
        r"^1\s+finger_1_med_joint\s+[0-9.]+\s+lower 0.0000\s+finger_1_med ", out_text, re.M
    )
    err = _error(capsys, [*argv, "--direction", "finger_1_med_joint=up"])
    assert "--direction 'finger_1_med_joint=up': expected JOINT=+" in err
    err = _error(capsys, [*argv, "--tolerance", "0"])
    assert "--tolerance must be a positive number (m), got 0.0" in err
    # --units mm reads the box's mesh as millimetres (0.1 mm wide) and the file says so.
    assert main([*argv, "--units", "mm"]) == 0
    assert json.loads(out.read_text())["object_units"] == "mm"
    assert "box: 1 of 3 fingers touch the object (fcl)" in capsys.readouterr().out


def test_close_command_backs_off_a_penetrating_object(tmp_path, capsys):
    pytest.importorskip("mujoco", reason="the built-in Barrett hand needs mujoco")
    pytest.importorskip("coal", reason="closing's default engine (coal) is not installed")
    pose = np.eye(4)
    pose[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]
    pose[:3, 3] = [0.0, 0.0, 0.08 + 0.035 - 0.004]  # a can 4 mm into the palm
    grasp = eg.Grasp(eg.hands.barrett(), eg.objects.cylinder(), pose, name="sunk")
    argv = ["close", str(grasp.save(tmp_path / "sunk.json")), "-o", str(tmp_path / "c.json")]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert re.search(r"\(coal; the object moved 11\.4\d\d mm out along the palm", captured.out)
    assert "close_fingers_result" not in captured.err
    closed = eg.Grasp.from_file(tmp_path / "c.json")
    assert closed.object_pose[2, 3] == pytest.approx(pose[2, 3] + 0.01144, abs=1e-4)
    err = _error(capsys, [*argv, "--no-backoff"])
    assert "penetrates" in err and "leave out --no-backoff" in err and "backoff=" not in err


# -- docs/cli.md -------------------------------------------------------------------------------


def _sections(text: str) -> dict[str, str]:
    parts = re.split(r"^## `exactgrasp (\w+)`$", text, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2], strict=True))


def test_docs_cover_every_command_and_flag():
    sections = _sections((ROOT / "docs" / "cli.md").read_text())
    for name, parser in _subparsers().items():
        assert name in sections, f"docs/cli.md has no section '## `exactgrasp {name}`'"
        missing = [f for f in _flags(parser) if f"`{f}" not in sections[name]]
        assert not missing, f"docs/cli.md, exactgrasp {name}: flags not described {missing}"
        assert f"exactgrasp {name}" in sections[name], f"no example of exactgrasp {name}"


def test_fixes_are_spelled_as_flags_from_their_fields():
    from exactgrasp.cli.common import GRASP_TERMS
    from exactgrasp.errors import Fix, MeshError

    def via_file(fix, key):
        return fix.replace(file_key=key)

    # a grasp-file key a flag overrides: the flag, then the key
    assert GRASP_TERMS(via_file(Fix("units", "mm", "pass"), "object_units")) == (
        'pass --units mm (or set "object_units": "mm" in the grasp file)'
    )
    assert GRASP_TERMS(via_file(Fix("units", form="where"), "object_units")) == (
        '--units (or "object_units" in the grasp file)'
    )
    assert GRASP_TERMS(via_file(Fix("units", "m", "is"), "object_units")) == "units m"
    # a key no flag overrides keeps the file's words; a Python-only setting is dropped
    assert GRASP_TERMS(via_file(Fix("repair", True, "pass"), "hand.repair")) == (
        'set "hand": {"repair": true} in the grasp file'
    )
    assert GRASP_TERMS(via_file(Fix("check_scale", False, "pass"), "")) is None
    # a Python argument: its flag, or the Python spelling when no flag sets that value
    assert GRASP_TERMS(Fix("repair", True, "Pass")) == "Pass --repair"
    assert GRASP_TERMS(Fix("units", "km")) == "units='km'"
    # the whole message, the same parts in the command's words
    error = MeshError("m: ", Fix("repair", True, "pass"), " to close it")
    assert str(error.respelled(GRASP_TERMS, "A: ")) == "A: m: pass --repair to close it"


# -- --help: fast, with an example --------------------------------------------------------------

#: What ``--help`` must not load: the numerical and optional libraries behind the commands.
HEAVY = ("trimesh", "scipy", "mujoco", "manifold3d", "matplotlib", "plotly", "dask",
         "coal", "fcl", "pyarrow")  # fmt: skip
COMMANDS = ("demo", "descriptor", "compare", "close", "inspect", "show", "overlap", "validate",
            "batch", "separate", "evaluate")  # fmt: skip


def test_help_loads_none_of_the_numerical_libraries():
    """``exactgrasp --help`` and every command's ``--help``, each in a fresh interpreter: the
    modules loaded are read from ``sys.modules`` (benchmarks/cli_help.py times them)."""
    script = textwrap.dedent(
        """
        import contextlib, io, json, sys
        from exactgrasp.cli import main
        argv = sys.argv[1:]
        with contextlib.redirect_stdout(io.StringIO()) as out:
            try:
                main([*argv, "--help"])
            except SystemExit:
                pass
        loaded = sorted({m.split(".")[0] for m in sys.modules})
        print(json.dumps({"loaded": loaded, "help": out.getvalue()}))
        """
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for argv in ([], *([c] for c in COMMANDS)):
        done = subprocess.run(
            [sys.executable, "-c", script, *argv], capture_output=True, text=True, env=env
        )
        assert done.returncode == 0, done.stderr[-2000:]
        result = json.loads(done.stdout)
        assert not set(HEAVY) & set(result["loaded"]), (argv, set(HEAVY) & set(result["loaded"]))
        text = " ".join(result["help"].split())
        assert "docs/cli.md" in text and "docs/tutorial.md" in text, argv
        if argv:
            assert f"Example: exactgrasp {argv[0]} " in text, argv
        if argv and argv[0] in ("demo", "descriptor", "compare", "batch"):
            assert "object_resolution" in text and "broadphase" in text, argv  # --param table


def test_a_missing_palm_frame_has_one_fix_in_the_error_and_in_inspect(tmp_path, capsys):
    """The tutorial's hand without its palm_frame.json: `Hand.from_urdf` and `inspect` give
    the same fix, naming the file to write beside the model."""
    from exactgrasp.datapath import examples_dir

    urdf = tmp_path / "two_finger.urdf"
    urdf.write_text((examples_dir() / "hand" / "two_finger.urdf").read_text())
    with pytest.raises(eg.FrameError) as caught:
        eg.Hand.from_urdf(urdf)
    error = str(caught.value)
    prefix = "two_finger has no palm frame; "
    assert error.startswith(prefix + f"write the palm frame into {tmp_path / 'palm_frame.json'}: ")
    fix, python = error.removeprefix(prefix).removesuffix(".").split(", or ")
    assert python.startswith('pass palm={"origin": [x, y, z], "normal"')
    assert main(["inspect", str(urdf)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert (
        f"  palm frame: none; {fix}, or pass --palm '{python.removeprefix('pass palm=')}'" in lines
    )
    assert '{"origin": [x, y, z], "normal": [x, y, z], "up": [x, y, z], "depth": d}' in fix
    assert "docs/tutorial.md" in fix
    # Written as it says, the model loads, with that frame.
    (tmp_path / "palm_frame.json").write_text(
        json.dumps({"origin": [0, 0, 0.03], "normal": [0, 0, 1], "up": [0, 1, 0], "depth": 0.08})
    )
    assert eg.Hand.from_urdf(urdf).frame.scale == pytest.approx(2 / 0.08)


def test_quick_is_documented_with_the_paths_it_runs():
    from exactgrasp.cli.demo import QUICK_SAMPLER
    from exactgrasp.paths.presets import as_sampler

    quick = as_sampler(QUICK_SAMPLER)
    kinds = dict(zip(*np.unique(quick.paths.kind, return_counts=True), strict=True))
    assert (quick.n_paths, quick.n_steps) == (34, 5)
    assert kinds == {"translation": 6, "rotation": 4, "both": 24}
    assert "a small sampler (34 paths x 5 steps)" in " ".join(_help("demo").split())
    cli_page = " ".join((ROOT / "docs" / "cli.md").read_text().split())
    assert "a small sampler (34 paths x 5 steps: 6 translations, 4 rotations and 24" in cli_page


def test_compare_of_different_samplers_names_each_file(grasp_file, tmp_path, capsys):
    small = '{"n_translations": 3, "n_axes": 2, "n_amounts": 2, "n_steps": 3}'
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    assert main(["descriptor", str(grasp_file), "-o", str(a), "--sampler", small, *COARSE]) == 0
    argv = ["descriptor", str(grasp_file), "-o", str(b), "--sampler", small, "--steps", "4"]
    assert main([*argv, *COARSE]) == 0
    capsys.readouterr()
    err = " ".join(_error(capsys, ["compare", str(a), str(b)]).split())
    assert f"{a} and {b} come from different samplers" in err
    assert f"{a}: 19 paths x 3 steps, sampler " in err and f"{b}: 19 paths x 4 steps" in err
    # The command it suggests gives a descriptor the first one compares with.
    suggested = re.search(r"--sampler '(\{.*?\})'", err).group(1)
    c = tmp_path / "c.npz"
    argv = ["descriptor", str(grasp_file), "-o", str(c), "--sampler", suggested, *COARSE]
    assert main(argv) == 0
    assert main(["compare", str(a), str(c)]) == 0


# -- what the command prints besides its results ---------------------------------------------

#: What the ``exactgrasp`` console script runs.
CONSOLE_SCRIPT = "import sys\nfrom exactgrasp.cli import main\nsys.exit(main())\n"


def console(folder: Path, *args: str, **popen) -> subprocess.Popen:
    """``exactgrasp ARGS`` run as the console script runs it, this checkout imported."""
    script = folder / "exactgrasp"
    script.write_text(CONSOLE_SCRIPT)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "EXACTGRASP_NO_PROGRESS": "1"}
    return subprocess.Popen(
        [sys.executable, str(script), *args], cwd=folder, env=env, text=True, **popen
    )


def test_warnings_print_as_category_and_message_without_a_source_line(tmp_path):
    from tests.test_shells import overlapping_boxes

    v, f = overlapping_boxes()
    write_ply(tmp_path / "two.ply", v * 0.1, f)
    write_ply(tmp_path / "box.ply", *box_arrays([0, 0, 0], [0.01, 0.01, 0.01]))
    run = console(tmp_path, "overlap", "two.ply", "box.ply", stdout=subprocess.PIPE,
                  stderr=subprocess.PIPE)  # fmt: skip
    out, err = run.communicate(timeout=300)
    assert run.returncode == 0, err
    assert float(out.split()[1]) == pytest.approx(1e-6, rel=1e-9)
    assert err.splitlines() == [err.strip()], err  # one line: no source line under it
    assert err.startswith("MeshWarning: two.ply: 2 shells; merged shells 0 (8 vertices)")
    assert "exactgrasp:3" not in err and "sys.exit" not in err


def test_a_closed_pipe_ends_the_command_quietly_with_141(tmp_path):
    goldens = ROOT / "tests" / "goldens"
    a, b = goldens / "builtin_box.exact.npz", goldens / "builtin_box.voxel.npz"
    # The reader goes before the command writes (`exactgrasp compare ... | head` at its end).
    run = console(tmp_path, "compare", str(a), str(b), stdout=subprocess.PIPE,
                  stderr=subprocess.PIPE)  # fmt: skip
    run.stdout.close()
    err = run.stderr.read()
    assert run.wait(timeout=300) == 141
    assert err == ""
    # With a reader, the same command prints its matrices and exits 0.
    done = console(tmp_path, "compare", str(a), str(b), stdout=subprocess.PIPE)
    assert done.communicate(timeout=300)[0].startswith("l2 distances:")
    assert done.returncode == 0
