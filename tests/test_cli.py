import json
import subprocess
import sys

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.cli import main
from tests.conftest import box_arrays


@pytest.fixture
def grasp_file(tmp_path):
    hand = eg.Hand.from_meshes(
        [box_arrays([-0.05, -0.05, 0.0], [0.05, 0.05, 0.02])],
        frame=eg.HandFrame.from_palm([0, 0, 0.02], [0, 0, 1], [0, 1, 0], 0.08),
    )
    obj = eg.Solid(*box_arrays([-0.02, -0.02, -0.02], [0.02, 0.02, 0.02]))
    pose = np.eye(4)
    pose[:3, 3] = [0, 0, 0.03]  # overlaps the palm slab by 1 cm
    return eg.Grasp(hand, obj, pose, name="slab").save(tmp_path / "slab.json")


def test_descriptor_and_compare_commands(grasp_file, tmp_path, capsys):
    out_a = tmp_path / "a.npz"
    assert (
        main(
            [
                "descriptor",
                str(grasp_file),
                "--backend",
                "voxel",
                "-o",
                str(out_a),
                "--steps",
                "3",
                "--param",
                "object_resolution=20",
            ]
        )
        == 0
    )
    d = eg.Descriptor.load(out_a)
    assert d.shape == (474, 3)
    assert d.metadata["backend_params"]["object_resolution"] == 20
    # the command gives the same numbers as the library call it wraps
    api = eg.compute_descriptor(
        eg.Grasp.from_file(grasp_file),
        eg.PathSampler.preset("balanced", n_steps=3),
        backend="voxel",
        object_resolution=20,
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
    assert (
        main(
            [
                "compare",
                str(grasp_file),
                "--backends",
                "voxel,voxel",
                "--steps",
                "2",
                "-o",
                str(table),
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "reference backend: voxel1" in text
    assert len(table.read_text().splitlines()) == 474 * 2 + 1


def test_errors_are_reported_not_raised(tmp_path, capsys):
    assert main(["descriptor", str(tmp_path / "missing.json"), "-o", str(tmp_path / "x.npz")]) == 2
    assert "no such grasp file" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text(
        json.dumps({"object": "nothing.stl", "object_pose_in_hand": np.eye(4).tolist()})
    )
    assert main(["descriptor", str(bad), "-o", str(tmp_path / "x.npz")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["compare", str(tmp_path / "a.txt")]) == 2
    assert "compare takes either" in capsys.readouterr().err


def test_demo_quick(tmp_path, capsys):
    assert main(["demo", "--quick", "--out", str(tmp_path / "demo")]) == 0
    out = capsys.readouterr().out
    summary = json.loads((tmp_path / "demo" / "summary.json").read_text())
    backends = {row["backend"] for row in summary}
    assert backends == eg.available_backends()
    assert {row["grasp"] for row in summary} == {"can", "box", "jug handle"}
    png = (tmp_path / "demo" / "descriptors.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    assert "seconds" in out


def test_console_script_help():
    result = subprocess.run(
        [sys.executable, "-m", "exactgrasp.cli", "--help"], capture_output=True, text=True
    )
    assert result.returncode == 0
    for command in ("demo", "descriptor", "compare"):
        assert command in result.stdout
