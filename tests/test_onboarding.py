"""What a new user meets first: the README's example and commands, the data folder, and a
batch read back into what the distance functions take."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp import datapath
from exactgrasp.cli import main

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def first_python_block() -> str:
    match = re.search(r"^```python\n(.*?)^```", README, re.S | re.M)
    assert match, "README.md has no ```python block"
    return match.group(1)


def cli_lines() -> list[list[str]]:
    """The ``exactgrasp`` lines of the README's command-line block, comments dropped."""
    section = README.split("## Command line", 1)[1]
    block = re.search(r"^```bash\n(.*?)^```", section, re.S | re.M).group(1)
    lines = []
    for line in block.splitlines():
        words = shlex.split(line, comments=True)
        if words and words[0] == "exactgrasp":
            lines.append(words[1:])
    return lines


# -- the README ---------------------------------------------------------------------------------


def test_readme_starts_with_make_demo_and_make_test():
    assert README.startswith("```\nmake demo\nmake test\n```\n")
    makefile = (ROOT / "Makefile").read_text()
    assert re.search(r"^demo:", makefile, re.M) and re.search(r"^test:", makefile, re.M)


def test_make_demo_sets_up_by_installing_only():
    """The set-up step (the stamp) builds the kernels by installing the package, and runs
    nothing after: no kernel compiles at a first call, so `make demo` needs no warm-up."""
    makefile = (ROOT / "Makefile").read_text()
    setup = makefile.split("$(STAMP): pyproject.toml\n", 1)[1].split("\n\n", 1)[0]
    lines = [line.strip() for line in setup.splitlines() if not line.strip().startswith("@#")]
    assert lines[-2] == '$(BIN)/python -m pip install --quiet --no-build-isolation -e ".[all,dev]"'
    assert lines[-3].endswith("\\") and lines[-1] == "touch $(STAMP)"
    assert "exactgrasp " not in setup
    assert re.search(r"^demo: \$\(STAMP\)\n\t\$\(BIN\)/exactgrasp demo", makefile, re.M)


def test_readme_install_line_works_from_a_checkout():
    assert 'pip install ".[all]"' in README
    assert 'pip install "exactgrasp[all]"' not in README  # not on an index
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert "all" in extras["optional-dependencies"]
    assert ".venv/bin/exactgrasp" in README and "source .venv/bin/activate" in README
    # "in any folder" and the command that runs it agree: python of the activated environment.
    assert "in any folder you like" in README and "run `python first.py` in that folder" in README


def test_readme_first_example_needs_nothing_but_the_package():
    code = first_python_block()
    for absent in ("../shared", "shared/data", "other.npz", "from_file("):
        assert absent not in code, f"the first example must not need {absent!r}"


@pytest.fixture(scope="module")
def example_folder(tmp_path_factory) -> Path:
    """A fresh folder where the README's first example ran, as a user runs it."""
    folder = tmp_path_factory.mktemp("first-steps")
    (folder / "first.py").write_text(first_python_block())
    done = subprocess.run(
        [sys.executable, "first.py"], cwd=folder, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "(474, 9)" in done.stdout
    assert "UserWarning" not in done.stderr, done.stderr[-3000:]  # normal grasps: no warning
    return folder


def test_readme_first_example_runs_in_an_empty_folder(example_folder):
    d = eg.Descriptor.load(example_folder / "box.npz")
    assert d.shape == (474, 9) and d.values.max() > 0
    assert d.metadata["warnings"] == []
    assert (example_folder / "box.json").is_file()


def test_readme_command_lines_run_on_the_example_files(example_folder, monkeypatch):
    monkeypatch.chdir(example_folder)
    lines = cli_lines()
    assert [words[0] for words in lines][:2] == ["demo", "descriptor"]
    ran = 0
    for words in lines:
        # The descriptor and the distance lines; demo, the backend comparison and show have
        # tests of their own.
        if words[0] == "descriptor" or (words[0] == "compare" and "--backends" not in words):
            assert main(words) == 0, words
            ran += 1
    assert ran == 2
    assert eg.Descriptor.load("box-cli.npz").shape == (474, 9)


# -- the data folder ----------------------------------------------------------------------------


def test_data_dir_defaults_to_shared_data_beside_the_checkout(monkeypatch):
    monkeypatch.delenv(datapath.ENV_VAR, raising=False)
    assert datapath.data_dir() == ROOT.parent.joinpath("shared", "data")
    monkeypatch.setenv(datapath.ENV_VAR, "  ")
    assert datapath.data_dir() == ROOT.parent.joinpath("shared", "data")


def test_data_dir_follows_the_environment_variable(monkeypatch, tmp_path):
    monkeypatch.setenv(datapath.ENV_VAR, str(tmp_path / "elsewhere"))
    assert datapath.data_dir() == tmp_path / "elsewhere"
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv(datapath.ENV_VAR, "~/data")
    assert datapath.data_dir() == tmp_path / "data"


def test_validate_reads_the_data_folder_from_the_environment(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv(datapath.ENV_VAR, str(tmp_path / "nowhere"))
    assert main(["validate", "--out", str(tmp_path / "report")]) == 2
    err = capsys.readouterr().err
    assert "nowhere" in err and "does not exist" in err and "EXACTGRASP_DATA" in err
    # --data still wins over the variable.
    assert main(["validate", "--data", str(tmp_path), "--out", str(tmp_path / "r")]) == 2
    assert "lacks" in capsys.readouterr().err


def test_tests_and_benchmarks_find_the_data_through_one_helper():
    from conftest import SHARED_DATA

    assert SHARED_DATA == datapath.data_dir()
    for folder in ("tests", "benchmarks", "exactgrasp"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path.name == "datapath.py":
                continue
            text = path.read_text()
            assert not re.search(r"""["']shared["']\s*/\s*["']data["']""", text), (
                f"{path.relative_to(ROOT)} builds the shared data path itself; use "
                "exactgrasp.datapath.data_dir()"
            )


# -- a batch, read back -------------------------------------------------------------------------


def test_read_batch_gives_what_pairwise_distances_takes(tmp_path):
    pytest.importorskip("pyarrow")
    sampler = eg.PathSampler(3, 2, 2, n_steps=3)
    params = {"object_resolution": 16, "hand_resolution": 24}
    rows = []
    for i, z in enumerate((0.125, 0.13, 0.135)):
        pose = np.eye(4)
        pose[2, 3] = z
        grasp = eg.Grasp(eg.hands.barrett(), eg.objects.box((0.06, 0.1, 0.1)), pose, f"g{i}")
        grasp.save(tmp_path / f"g{i}.json")
        rows.append(json.dumps({"id": f"g{i}", "grasp": f"g{i}.json"}) + "\n")
    (tmp_path / "manifest.jsonl").write_text("".join(rows))
    backend = eg.get_backend("voxel", **params)
    eg.run_batch(tmp_path / "manifest.jsonl", tmp_path / "out", sampler=sampler, backend=backend,
                 workers=0)  # fmt: skip
    ids, descriptors, metadata = eg.read_batch(tmp_path / "out")
    assert ids == ["g0", "g1", "g2"]
    distances = eg.pairwise_distances(descriptors)
    assert distances.shape == (3, 3) and distances[0, 1] > 0
    np.testing.assert_allclose(distances, distances.T)
    assert eg.distance(descriptors[0], descriptors[2]) == pytest.approx(distances[0, 2])
    batch = eg.read_batch(tmp_path / "out")
    assert batch.values.shape == (3, sampler.n_paths, sampler.n_steps) and len(batch) == 3
    np.testing.assert_array_equal(batch.values[1], descriptors[1].values)
    assert descriptors[1].metadata == metadata[1] and "seconds" not in metadata[1]
    assert descriptors[0].sampler.params == sampler.params
    direct = eg.compute_descriptor(eg.Grasp.from_file(tmp_path / "g2.json"), sampler, backend)
    np.testing.assert_array_equal(descriptors[2].values, direct.values)


def test_read_batch_of_an_unfinished_run_says_so(tmp_path):
    pytest.importorskip("pyarrow")
    with pytest.raises(eg.BatchError, match="finished batch run"):
        eg.read_batch(tmp_path)
