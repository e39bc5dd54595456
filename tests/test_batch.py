"""`exactgrasp batch`: a 2-worker local cluster, a run killed and resumed, bad rows, the same
bytes for 1 and 2 workers, and manifest errors caught before any work.

Small on purpose (CI has 2 cores): 19 paths x 3 steps, coarse voxel grids, 7 good grasps of the
built-in hand and 4 bad rows, parts of 2 rows.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

import exactgrasp as eg
from exactgrasp import hands, objects
from exactgrasp.backends.voxel import VoxelBackend
from exactgrasp.batch import BatchError, read_batch, read_manifest, run_batch
from exactgrasp.batch.store import run_lock
from exactgrasp.cli import main

DOCS = Path(__file__).resolve().parents[1] / "docs"

SAMPLER = eg.PathSampler(3, 2, 2, n_steps=3)
BACKEND_PARAMS = {"object_resolution": 16, "hand_resolution": 24}
PART_SIZE = 2
GOOD = ["g0", "g1", "inline", "g2", "g3", "g4", "g5"]
BAD = {"missing-file": "GraspFileError", "no-grasp": "BatchError", "7": "GraspFileError"}
BAD["bad-joint"] = "JointError"
#: Files whose bytes depend only on the manifest and the parameters.
DETERMINISTIC = ("run.json", "descriptors.parquet", "errors.jsonl")


def _cli_args(manifest: Path, out: Path, workers: int) -> list[str]:
    args = ["batch", str(manifest), "--out", str(out), "--workers", str(workers)]
    args += ["--sampler", json.dumps(SAMPLER.params), "--part-size", str(PART_SIZE)]
    for key, value in BACKEND_PARAMS.items():
        args += ["--param", f"{key}={value}"]
    return args


def _run(manifest: Path, out: Path, workers: int | None, **kwargs):
    return run_batch(
        manifest,
        out,
        sampler=SAMPLER,
        backend=VoxelBackend(**BACKEND_PARAMS),
        workers=workers,
        part_size=PART_SIZE,
        **kwargs,
    )


def _deterministic_files(out: Path) -> dict[str, bytes]:
    files = {name: (out / name).read_bytes() for name in DETERMINISTIC}
    for part in sorted((out / "parts").iterdir()):
        files[f"parts/{part.name}"] = part.read_bytes()
    return files


@pytest.fixture(scope="module")
def manifest(tmp_path_factory) -> Path:
    """Seven good rows (six grasp files, one inline) with four bad ones among them."""
    folder = tmp_path_factory.mktemp("manifest")
    rows = []
    for i in range(6):
        pose = np.eye(4)
        pose[:3, 3] = (0.004 * i, 0.0, 0.11 + 0.004 * i)
        hand = hands.barrett({"finger_1_med_joint": 0.25 * i, "finger_3_med_joint": 0.2 * i})
        grasp = eg.Grasp(hand, objects.box((0.06, 0.1, 0.1)), pose, name=f"g{i}")
        grasp.save(folder / "grasps" / f"g{i}.json")
        rows.append({"id": f"g{i}", "grasp": f"grasps/g{i}.json"})
    inline = json.loads((folder / "grasps" / "g0.json").read_text())
    inline["object"] = "grasps/" + inline.pop("object")
    del inline["name"]
    rows.insert(2, {"id": "inline", "grasp": inline})
    rows.insert(4, {"id": "missing-file", "grasp": "grasps/nowhere.json"})
    rows.insert(6, {"id": "bad-joint", "grasp": {**inline, "joints": {"finger_1_med_joint": 5}}})
    rows.append({"id": "no-grasp"})
    not_rigid = [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]]
    rows.append({"id": 7, "grasp": {**inline, "object_pose_in_hand": not_rigid}})
    path = folder / "manifest.jsonl"
    path.write_text("".join(json.dumps(row) + "\n" for row in rows))
    return path


@pytest.fixture(scope="module")
def run_one(manifest, tmp_path_factory):
    out = tmp_path_factory.mktemp("one") / "out"
    return out, _run(manifest, out, workers=1)


@pytest.fixture(scope="module")
def run_two(manifest, tmp_path_factory):
    out = tmp_path_factory.mktemp("two") / "out"
    return out, _run(manifest, out, workers=2)


def test_two_worker_local_cluster(run_two, manifest):
    out, summary = run_two
    assert summary.workers == 2
    assert (summary.done, summary.failed, summary.computed) == (len(GOOD), len(BAD), 11)
    batch = read_batch(out)
    ids, values, metadata = batch.ids, batch.values, batch.metadata
    assert ids == GOOD
    assert values.shape == (len(GOOD), SAMPLER.n_paths, SAMPLER.n_steps)
    assert all("seconds" not in m for m in metadata)
    # The batch value is the library's value for the same grasp, bit for bit.
    grasp = eg.Grasp.from_file(manifest.parent / "grasps" / "g3.json")
    direct = eg.compute_descriptor(grasp, SAMPLER, VoxelBackend(**BACKEND_PARAMS))
    np.testing.assert_array_equal(values[GOOD.index("g3")], direct.values)
    assert values.max() > 0


def test_each_worker_prepares_the_hand_once(run_two, manifest):
    # Every good row is the built-in Barrett hand at its own joints: 9 links of 4 distinct
    # meshes (the fingers share theirs). A worker makes the 4 solids for its first good row
    # and reuses them for every later one.
    out, _ = run_two
    good = {row.index for row in read_manifest(manifest).rows if row.id in GOOD}
    tasks = [json.loads(line) for line in (out / "timings.jsonl").read_text().splitlines()]
    tasks = [t for t in tasks if "part" in t]
    assert sum(t["rows"] for t in tasks) == len(GOOD) + len(BAD)
    prepared: dict[str, int] = {}
    computed_good: dict[str, bool] = {}
    for t in tasks:
        rows = set(range(t["first_row"], t["first_row"] + t["rows"]))
        prepared[t["worker"]] = prepared.get(t["worker"], 0) + t["links_prepared"]
        computed_good[t["worker"]] = computed_good.get(t["worker"], False) or bool(rows & good)
    assert prepared == {w: 4 if computed_good[w] else 0 for w in prepared}
    assert sum(prepared.values()) >= 4


def test_one_and_two_workers_give_identical_bytes(run_one, run_two):
    assert run_one[1].workers == 1
    one, two = _deterministic_files(run_one[0]), _deterministic_files(run_two[0])
    assert sorted(one) == sorted(two)
    for name in one:
        assert one[name] == two[name], f"{name} differs between 1 and 2 workers"


def test_bad_rows_are_reported_and_never_written(run_two):
    out, summary = run_two
    assert summary.exit_status == 1 and not summary.ok
    lines = [json.loads(line) for line in (out / "errors.jsonl").read_text().splitlines()]
    assert {line["id"]: line["error"] for line in lines} == BAD
    assert [line["row"] for line in lines] == sorted(line["row"] for line in lines)
    messages = {line["id"]: line["message"] for line in lines}
    assert "nowhere.json" in messages["missing-file"]
    assert "finger_1_med_joint" in messages["bad-joint"]
    batch = read_batch(out)
    ids, values = batch.ids, batch.values
    assert not set(ids) & set(BAD)
    assert np.all(np.isfinite(values))


def test_cli_exit_status(manifest, tmp_path, capsys):
    good = tmp_path / "good.jsonl"
    lines = manifest.read_text().splitlines()
    good.write_text("\n".join(line for line in lines if '"g0"' in line or '"g1"' in line) + "\n")
    (tmp_path / "grasps").symlink_to(manifest.parent / "grasps")
    assert main(_cli_args(good, tmp_path / "ok", workers=0)) == 0
    assert "2 done, 0 failed" in capsys.readouterr().out
    assert main(_cli_args(manifest, tmp_path / "bad", workers=0)) == 1
    assert f"{len(BAD)} failed" in capsys.readouterr().out


def test_killed_run_resumes_without_recomputing(manifest, run_one, tmp_path):
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-c",
        "import sys; from exactgrasp.cli import main; sys.exit(main())",
    ]
    command += _cli_args(manifest, out, workers=1)
    env = {**os.environ, "EXACTGRASP_NO_PROGRESS": "1"}
    # A new process group (start_new_session), so the kill takes the cluster's workers with it.
    process = subprocess.Popen(command, env=env, start_new_session=True)
    deadline = time.monotonic() + 120
    try:
        while not list((out / "parts").glob("*.parquet")):
            assert process.poll() is None, "the batch run ended before writing a part"
            assert time.monotonic() < deadline, "no part written in 120 s"
            time.sleep(0.01)
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    assert not (out / "descriptors.parquet").exists(), "the run finished before the kill"
    before = {p.name: p.stat().st_mtime_ns for p in (out / "parts").glob("*.parquet")}
    (out / "parts" / "part-000004.parquet.tmp-half-written").write_bytes(b"PAR1 half")

    resumed = subprocess.run(command, env=env, capture_output=True, text=True, timeout=180)
    assert resumed.returncode == 1, resumed.stderr  # the bad rows, not a crash
    record = json.loads((out / "timings.jsonl").read_text().splitlines()[-1])["run"]
    assert record["skipped"] == PART_SIZE * len(before)
    assert record["computed"] == 11 - record["skipped"]
    after = {p.name: p.stat().st_mtime_ns for p in (out / "parts").glob("*.parquet")}
    assert {name: after[name] for name in before} == before, "a finished part was rewritten"
    assert not list((out / "parts").glob("*.tmp-*"))
    assert _deterministic_files(out) == _deterministic_files(run_one[0])


def test_damaged_part_and_retry_failed(manifest, run_one, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(run_one[0], out)
    (out / "parts" / "part-000001.parquet").write_bytes(b"truncated")
    summary = _run(manifest, out, workers=0)
    assert summary.computed == PART_SIZE and summary.skipped == 11 - PART_SIZE
    assert _deterministic_files(out) == _deterministic_files(run_one[0])
    summary = _run(manifest, out, workers=0, retry_failed=True)
    errors = (out / "errors.jsonl").read_text().splitlines()
    failed_parts = {json.loads(line)["row"] // PART_SIZE for line in errors}
    assert summary.computed == sum(min(PART_SIZE, 11 - p * PART_SIZE) for p in failed_parts)
    assert _deterministic_files(out) == _deterministic_files(run_one[0])


def test_parquet_manifest_gives_the_same_run(manifest, run_one, tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = [json.loads(line) for line in manifest.read_text().splitlines()]
    grasps = [r.get("grasp") for r in rows]
    column = [g if g is None or isinstance(g, str) else json.dumps(g) for g in grasps]
    path = manifest.parent / "manifest.parquet"
    pq.write_table(pa.table({"id": [str(r["id"]) for r in rows], "grasp": column}), path)
    assert read_manifest(path).sha256 == read_manifest(manifest).sha256
    _run(path, tmp_path / "out", workers=0)
    assert _deterministic_files(tmp_path / "out") == _deterministic_files(run_one[0])


@pytest.mark.parametrize(
    ("lines", "match"),
    [
        (['{"id": "a", "grasp": "x.json"}', '{"id": "a", "grasp": "y.json"}'], "line 2.*dup"),
        (['{"id": "a", "grasp": "x.json"}', '{"grasp": "y.json"}'], "line 2.*'id' is missing"),
        (['{"id": "a", "grasp": "x.json"}', "", '{"id": "b", '], "line 3.*not valid JSON"),
        (['{"id": "", "grasp": "x.json"}'], "line 1.*empty"),
        (
            ['{"id": [1], "grasp": "x.json"}'],
            "line 1: 'id' is a list; every row needs a string or",
        ),
        (['{"id": "a", "grasp": "x.json"}', "[1, 2]"], "line 2: expected a JSON object with 'id'"),
        ([], "no rows"),
    ],
)
def test_manifest_errors_before_any_work(tmp_path, lines, match):
    path = tmp_path / "m.jsonl"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(BatchError, match=match):
        _run(path, tmp_path / "out", workers=0)
    assert not (tmp_path / "out").exists()


def test_reformatted_manifest_keeps_its_hash(tmp_path):
    pose = np.eye(4).tolist()
    one = tmp_path / "one.jsonl"
    one.write_text(
        json.dumps({"id": "g1", "grasp": "x.json"})
        + "\n"
        + json.dumps({"id": 2, "grasp": {"object": "o.stl", "object_pose_in_hand": pose}})
        + "\n"
    )
    other = tmp_path / "other.ndjson"  # blank lines, spacing, key order, "2" for 2
    other.write_text(
        '\n{ "grasp" : "x.json",   "id" : "g1" }\n\n'
        + json.dumps({"grasp": {"object_pose_in_hand": pose, "object": "o.stl"}, "id": "2"})
        + "\n"
    )
    assert read_manifest(one).sha256 == read_manifest(other).sha256
    changed = tmp_path / "changed.jsonl"
    changed.write_text(one.read_text().replace("x.json", "y.json"))
    assert read_manifest(changed).sha256 != read_manifest(one).sha256


def test_manifest_errors_on_the_command_line(tmp_path, capsys):
    path = tmp_path / "m.jsonl"
    path.write_text('{"id": 1, "grasp": "x.json"}\n{"id": "1", "grasp": "y.json"}\n')
    assert main(_cli_args(path, tmp_path / "out", workers=0)) == 2
    assert "line 2: duplicate id '1'" in capsys.readouterr().err
    parquet = tmp_path / "m.parquet"
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.table({"name": ["a"], "grasp": ["x.json"]}), parquet)
    with pytest.raises(BatchError, match="columns 'id' and 'grasp'"):
        read_manifest(parquet)


def test_resume_with_other_parameters_is_refused(manifest, run_one, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(run_one[0], out)
    with pytest.raises(BatchError, match="different: .*n_paths.*sampler"):
        run_batch(
            manifest,
            out,
            sampler=eg.PathSampler(2, 1, 2, n_steps=3),
            workers=0,
            backend=VoxelBackend(**BACKEND_PARAMS),
            part_size=PART_SIZE,
        )
    with pytest.raises(BatchError, match="backend_params"):
        run_batch(manifest, out, sampler=SAMPLER, workers=0, part_size=PART_SIZE)
    with pytest.raises(BatchError, match="part_size"):
        run_batch(
            manifest,
            out,
            sampler=SAMPLER,
            backend=VoxelBackend(**BACKEND_PARAMS),
            part_size=3,
            workers=0,
        )
    with run_lock(out), pytest.raises(BatchError, match="in use"):
        _run(manifest, out, workers=0)
    assert _deterministic_files(out) == _deterministic_files(run_one[0])


def test_workers_with_other_code_fail_their_rows(manifest):
    from exactgrasp.batch import compute_rows

    rows = read_manifest(manifest).rows[:2]
    expected = [eg.__version__, {"object_resolution": 1}]
    outcome = compute_rows(rows, str(manifest.parent), "voxel", SAMPLER.params, None, expected)
    assert [r["error"] for r in outcome["results"]] == ["BatchError", "BatchError"]
    assert "install the same exactgrasp" in outcome["results"][0]["message"]
    assert all(r["values"] is None for r in outcome["results"])


def test_units_and_repair_override_the_grasp_files(tmp_path):
    # A grasp file whose object mesh is in millimetres but says nothing about units.
    box = trimesh.creation.box((60.0, 100.0, 100.0))
    trimesh.Trimesh(box.vertices, box.faces[:-2], process=False).export(tmp_path / "box_mm.stl")
    pose = np.eye(4)
    pose[2, 3] = 0.11
    record = eg.Grasp(hands.barrett(), objects.box((0.06, 0.1, 0.1)), pose).to_dict(tmp_path)
    record.update(object="box_mm.stl")
    (tmp_path / "g.json").write_text(json.dumps(record))
    manifest = tmp_path / "manifest.jsonl"
    manifest.write_text(json.dumps({"id": "g", "grasp": "g.json"}) + "\n")
    as_is = _run(manifest, tmp_path / "as-is", workers=0)
    assert as_is.failed == 1  # 100 m long, and open
    with pytest.warns(UserWarning, match="repaired"):
        fixed = _run(manifest, tmp_path / "fixed", workers=0, units="mm", repair=True)
    assert fixed.done == 1
    values = read_batch(tmp_path / "fixed").values
    # The same repair was warned about above: once per process.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        grasp = eg.Grasp.from_file(tmp_path / "g.json", units="mm", repair=True)
    assert grasp.object.volume == pytest.approx(0.06 * 0.1 * 0.1, rel=1e-9)
    expected = eg.compute_descriptor(grasp, SAMPLER, VoxelBackend(**BACKEND_PARAMS)).values
    np.testing.assert_allclose(np.asarray(values[0]).reshape(expected.shape), expected, rtol=1e-6)
    with pytest.raises(BatchError, match="units must be one of"):
        _run(manifest, tmp_path / "bad", workers=0, units="furlong")


def test_a_script_without_the_main_guard_is_told_the_fix(tmp_path):
    """docs/batch.md's block without its `if __name__ == "__main__":`: each spawned worker
    re-runs the script; its run_batch call says what is wrong and the fix, instead of a
    message about the output folder being in use."""
    pytest.importorskip("distributed")
    pose = np.eye(4)
    pose[2, 3] = 0.125
    eg.Grasp(hands.barrett(), objects.box((0.06, 0.1, 0.1)), pose, name="g0").save(
        tmp_path / "g0.json"
    )
    (tmp_path / "grasps.jsonl").write_text('{"id": "g0", "grasp": "g0.json"}\n')
    (tmp_path / "script.py").write_text(
        "from exactgrasp.batch import run_batch\n\n"
        'summary = run_batch("grasps.jsonl", "run2", sampler={"n_translations": 3, '
        '"n_axes": 2, "n_amounts": 2, "n_steps": 3}, workers=1)\n'
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    done = subprocess.run(
        [sys.executable, "script.py"], cwd=tmp_path, env=env, capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert done.returncode != 0
    script = tmp_path / "script.py"
    assert f"run_batch was called while a worker process imported {script}" in done.stderr
    assert 'put the call under `if __name__ == "__main__":`' in done.stderr
    assert "in use by another" not in done.stderr


def test_the_local_cluster_runs_with_the_quiet_settings():
    # The profiler off and the housekeeping timers slowed, in the scheduler and in every worker
    # the nannies start: what `WORKER_CONFIG` asks for reaches each process.
    import dask

    from exactgrasp.batch.worker import WORKER_CONFIG, open_pool

    assert WORKER_CONFIG["distributed.worker.profile.enabled"] is False
    assert WORKER_CONFIG["distributed.admin.tick.interval"] == "500ms"

    def settings():
        return {key: dask.config.get(key) for key in WORKER_CONFIG}

    def scheduler_settings(dask_scheduler):
        # The scheduler runs in this process, where the settings held only while it started.
        return dask_scheduler._tick_interval, dask_scheduler.WORKER_SATURATION

    with open_pool(2, None) as pool:
        workers = pool.client.run(settings)
        scheduler = pool.client.run_on_scheduler(scheduler_settings)
    assert len(workers) == 2
    assert all(seen == WORKER_CONFIG for seen in workers.values())
    assert scheduler == (0.5, 1.0)


def test_the_cluster_recipe_exports_the_local_clusters_settings():
    import dask

    from exactgrasp.batch.worker import WORKER_CONFIG, cluster_environment

    env = cluster_environment()
    # What dask reads back from those variables is the local cluster's settings.
    read = dask.config.collect_env(env)
    assert {key: dask.config.get(key, config=read) for key in WORKER_CONFIG} == WORKER_CONFIG
    assert env["OMP_NUM_THREADS"] == env["OPENBLAS_NUM_THREADS"] == "1"
    assert not any(name.startswith("NUMBA") for name in env)
    exports = " ".join(
        line.removeprefix("export ")
        for line in (DOCS / "batch.md").read_text().splitlines()
        if line.startswith("export ")
    ).split()
    assert sorted(exports) == sorted(f"{key}={value}" for key, value in env.items())
