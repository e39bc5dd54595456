"""Every code block of the README and of the tutorial runs as written, in order.

A page's blocks run in one bash shell in an empty folder: ``bash`` blocks as they are,
``python`` blocks as scripts (each saved to a file of its own and run with ``python``), as a
reader runs them. The shell has the checkout's environment as a reader has it after
``source .venv/bin/activate``: ``python`` is this interpreter and ``exactgrasp`` the command,
both importing this checkout. Blocks marked ``text`` (output shown) and ``json`` (file
contents shown) are not run; the json blocks are checked against the files they show.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.datapath import examples_dir

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)
RUN = ("bash", "python")
SHOWN = ("text", "json")


def blocks(page: Path) -> list[tuple[str, str]]:
    """``(language, code)`` of every fenced block of ``page``, in order."""
    return [(m.group(1), m.group(2)) for m in BLOCK.finditer(page.read_text())]


def shell(page: Path, folder: Path, skip: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
    """Run the page's bash and python blocks in order in ``folder``; blocks starting with one
    of ``skip`` are left out."""
    bin_dir = folder / ".bin"
    bin_dir.mkdir()
    for name, command in (("python", ""), ("exactgrasp", " -m exactgrasp.cli")):
        shim = bin_dir / name
        shim.write_text(f'#!/bin/sh\nexec {shlex.quote(sys.executable)}{command} "$@"\n')
        shim.chmod(0o755)
    script = ["set -euo pipefail"]
    for number, (language, code) in enumerate(blocks(page)):
        if language not in RUN or code.startswith(skip):
            continue
        if language == "python":
            path = bin_dir / f"block{number}.py"
            path.write_text(code)
            script.append(f"python {shlex.quote(str(path))}")
        else:
            script.append(code)
    env = {
        **os.environ,
        "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}",
        "PYTHONPATH": str(ROOT),
        "EXACTGRASP_NO_PROGRESS": "1",
    }
    env.pop("EXAMPLES", None)
    return subprocess.run(
        ["bash", "-c", "\n".join(script)],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=1200,
    )


@pytest.mark.parametrize("page", ["README.md", "docs/tutorial.md"])
def test_every_block_is_run_or_shown(page):
    languages = [language for language, _ in blocks(ROOT / page)]
    assert languages, page
    unknown = [lang for lang in languages if lang not in (*RUN, *SHOWN)]
    if page == "README.md":  # the make lines, run by make itself (test_onboarding checks them)
        assert languages[0] == "" and unknown == [""], languages
    else:
        assert not unknown, f"{page}: blocks of no known kind: {unknown}"


@pytest.mark.slow
def test_the_tutorial_runs_as_written(tmp_path):
    pytest.importorskip("pyarrow", reason="the batch needs the 'batch' extra")
    pytest.importorskip("plotly", reason="exactgrasp show needs the 'view' extra")
    done = shell(ROOT / "docs" / "tutorial.md", tmp_path)
    assert done.returncode == 0, (done.stdout[-3000:], done.stderr[-5000:])
    work = tmp_path / "grasp-tutorial"
    out = done.stdout
    # Step 3: the hand's joints and the objects' volumes, as the page shows them.
    assert "box: 105.0 cm^3, 70 mm long" in out and "can: 87.7 cm^3, 70 mm long" in out
    # Steps 4-6: six grasp files, every descriptor computed, no warning.
    assert len(list((work / "grasps").glob("*.json"))) == 6
    batch = eg.read_batch(work / "run")
    assert len(batch) == 6 and batch.values.shape == (6, 474, 9)
    assert all(meta["warnings"] == [] for meta in batch.metadata)
    assert all(0 < meta["max_value"] < 1 for meta in batch.metadata)
    assert len(eg.read_batch(work / "run-arrays")) == 3
    assert not (work / "run" / "errors.jsonl").read_text().strip()
    # Step 7: the legend under compare's table; step 8 and show: the pictures.
    assert "FP           poses where exact reads 0" in out
    # The figures the page quotes.
    page = (ROOT / "docs" / "tutorial.md").read_text()
    for line in (
        "     voxel     0.39      0.02309     0.2234      1.047    0.0006354   0.9996     0     9",
        "can-0deg-3mm           nearest: can-10deg-3mm (0.008)",
        "juice_box-0deg-20mm    nearest: can-0deg-20mm (1.067)",
        "juice_box-0deg-3mm     max 0.279  warnings: 0",
        "juice_box-10deg-3mm {'left_proximal_joint': 0.083",
    ):
        assert line in page, line
        assert line.split("0.39")[-1] in out, line  # the seconds drift; the values do not
    assert "6 grasps: 6 done, 0 failed" in out
    for picture in ("descriptors.png", "juice_box.png", "all-descriptors.png"):
        assert (work / picture).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (work / "juice_box.html").stat().st_size > 100_000
    assert "UserWarning" not in done.stderr, done.stderr[-3000:]


def test_the_tutorials_palm_frame_is_the_file_it_shows():
    shown = [json.loads(code) for language, code in blocks(ROOT / "docs" / "tutorial.md")
             if language == "json"]  # fmt: skip
    on_disk = json.loads((examples_dir() / "hand" / "palm_frame.json").read_text())
    on_disk.pop("note")
    assert shown == [on_disk]


@pytest.mark.slow
def test_the_readme_runs_as_written(tmp_path):
    pytest.importorskip("plotly", reason="exactgrasp show needs the 'view' extra")
    done = shell(ROOT / "README.md", tmp_path)
    assert done.returncode == 0, (done.stdout[-3000:], done.stderr[-5000:])
    assert "(474, 9)" in done.stdout
    for name in ("box.json", "box.npz", "box-cli.npz", "poses.csv", "box.html"):
        assert (tmp_path / name).is_file(), name
    assert (tmp_path / "demo-output" / "descriptors.png").is_file()
    assert "UserWarning" not in done.stderr, done.stderr[-3000:]


@pytest.mark.slow
def test_the_batch_pages_python_block_runs_as_written(tmp_path):
    """docs/batch.md's block, saved as a script beside a two-grasp grasps.jsonl and run: the
    workers are processes, which its __main__ guard lets start."""
    pytest.importorskip("distributed", reason="the batch needs the 'batch' extra")
    (code,) = [code for lang, code in blocks(ROOT / "docs" / "batch.md") if lang == "python"]
    hand = eg.Hand.from_urdf(examples_dir() / "hand" / "two_finger.urdf")
    can = eg.Solid.from_file(examples_dir() / "objects" / "can.stl", units="mm")
    rows = []
    for i, z in enumerate((0.068, 0.08)):
        pose = np.eye(4)
        pose[2, 3] = z
        eg.Grasp(hand, can, pose, name=f"g{i}").save(tmp_path / f"g{i}.json")
        rows.append(json.dumps({"id": f"g{i}", "grasp": f"g{i}.json"}) + "\n")
    (tmp_path / "grasps.jsonl").write_text("".join(rows))
    (tmp_path / "script.py").write_text(code + "    print(distances.shape, values.shape)\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "EXACTGRASP_NO_PROGRESS": "1"}
    done = subprocess.run(
        [sys.executable, "script.py"], cwd=tmp_path, env=env, capture_output=True, text=True,
        timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    assert "2 grasps: 2 done, 0 failed" in done.stdout
    assert "(2, 2) (2, 474, 9)" in done.stdout
