"""Batch workers at full speed: tasks sized from rows and workers, each hand prepared once per
process (counted, not timed), the hand's union volume from its links' overlaps, and a worker
that uses exactly its one core (manifold3d's TBB pool included), measured.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

import exactgrasp as eg
from exactgrasp.batch.manifest import ManifestRow
from exactgrasp.batch.run import task_chunks
from exactgrasp.batch.worker import compute_rows
from exactgrasp.datapath import data_dir
from exactgrasp.geometry.manifold import to_manifold, union_volume, union_volume_by_overlaps
from exactgrasp.hands.prepared import LINK_SOLIDS

SAMPLER = eg.PathSampler(3, 2, 2, n_steps=3)
RECORDS = data_dir() / "barrett-grasps" / "study-records"


def _rows(n: int) -> list[ManifestRow]:
    return [ManifestRow(i, f"r{i}", f"g{i}.json") for i in range(n)]


def test_tasks_shrink_as_the_run_ends_and_stay_inside_parts():
    # 24 rows in one part of 32, 2 workers: ceil(left / 6) rows a task.
    sizes = [len(rows) for _, rows in task_chunks({0: _rows(24)}, 2)]
    assert sizes == [4, 4, 3, 3, 2, 2, 1, 1, 1, 1, 1, 1]
    # Parts of 4: no task crosses a part, rows stay in manifest order.
    rows = _rows(10)
    chunks = task_chunks({0: rows[:4], 1: rows[4:8], 2: rows[8:]}, 2)
    assert [(p, [r.index for r in c]) for p, c in chunks] == [
        (0, [0, 1]),
        (0, [2, 3]),
        (1, [4]),
        (1, [5]),
        (1, [6]),
        (1, [7]),
        (2, [8]),
        (2, [9]),
    ]
    # One worker, or none (in this process): a task per part.
    assert [len(c) for _, c in task_chunks({0: rows[:4], 1: rows[4:]}, 1)] == [4, 6]


def _box(lower, upper):
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    mesh = trimesh.creation.box(upper - lower)
    mesh.apply_translation(0.5 * (lower + upper))
    return to_manifold(mesh.vertices, mesh.faces)


def test_union_by_overlaps_is_inclusion_exclusion_to_the_last_term():
    # A, B, C overlap pairwise and all three together; D is apart; E touches A along an
    # edge (its box meets A's, its overlap has no volume).
    # |A u B u C| = 8 + 8 + 4 - 4 - 3 - 1.5 + 1.5 = 13; + |D| = 1; + |E| = 1.
    solids = [
        _box((0, 0, 0), (2, 2, 2)),
        _box((1, 0, 0), (3, 2, 2)),
        _box((0.5, 0.5, 0), (1.5, 2.5, 2)),
        _box((10, 10, 10), (11, 11, 11)),
        _box((2, 2, 0), (3, 3, 1)),
    ]
    assert union_volume_by_overlaps(solids) == pytest.approx(15.0, rel=1e-14)
    assert union_volume_by_overlaps(solids[:1]) == pytest.approx(8.0, rel=1e-14)


def _hands():
    hands = [eg.hands.barrett({"finger_1_med_joint": 0.3 * i, "finger_3_dist_joint": 0.4 * i})
             for i in range(3)]  # fmt: skip
    records = sorted(RECORDS.rglob("*.json"))[::60]
    hands += [eg.Grasp.from_file(p, repair=True).hand for p in records]
    return hands


def test_hand_volume_from_links_is_the_boolean_union():
    # The union's volume depends on the joints (links overlap at their joints); summed from
    # the links' overlaps it equals manifold3d's union of the posed links to rounding.
    hands = _hands()
    for hand in hands:
        boolean = union_volume(hand.link_arrays())
        assert hand.volume == pytest.approx(boolean, rel=1e-12, abs=0.0)
    volumes = [hand.volume for hand in hands[:3]]
    assert len(set(volumes)) == 3, "the volume changes with the joints"


def test_each_hand_is_prepared_once_per_process(tmp_path):
    # Rows of two hands: the built-in Barrett hand at four joint settings, and a one-link
    # hand from a mesh file at two poses. The Barrett hand has 9 links of 4 distinct meshes
    # (palm, knuckle, proximal, distal: its fingers share theirs), so 4 + 1 solids are made.
    rows = []
    for i in range(4):
        # Joints no other test uses: no posed hand of these rows is in a cache yet.
        joints = {"finger_1_med_joint": 0.3 * i + 0.07, "finger_2_med_joint": 0.2 * i + 0.03}
        hand = eg.hands.barrett(joints)
        grasp = eg.Grasp(hand, eg.objects.box((0.06, 0.1, 0.1)), _pose(i), name=f"b{i}")
        grasp.save(tmp_path / f"b{i}.json")
        rows.append(ManifestRow(len(rows), f"b{i}", f"b{i}.json"))
    trimesh.creation.box((0.1, 0.1, 0.05)).export(tmp_path / "paddle.stl")
    paddle = eg.Hand.from_file(tmp_path / "paddle.stl", frame=eg.HandFrame.identity())
    for i in range(2):
        grasp = eg.Grasp(paddle, eg.objects.box((0.05, 0.05, 0.05)), _pose(i), name=f"p{i}")
        grasp.save(tmp_path / f"p{i}.json")
        rows.append(ManifestRow(len(rows), f"p{i}", f"p{i}.json"))
    LINK_SOLIDS.clear()
    builds, hits = LINK_SOLIDS.builds, LINK_SOLIDS.hits
    first = compute_rows(rows, str(tmp_path), "voxel", SAMPLER.params)
    assert [r["error"] for r in first["results"]] == [None] * 6
    assert first["links_prepared"] == 4 + 1
    assert LINK_SOLIDS.builds - builds == 4 + 1
    # 9 lookups per Barrett row; the paddle's second row, the same posed hand as its first,
    # takes its volume from the voxel backend's cache of hand volumes without a lookup.
    assert LINK_SOLIDS.hits - hits == 4 * 9 - 4
    # The same hands again (new Hand objects, read from the files again): nothing prepared.
    again = compute_rows(rows, str(tmp_path), "voxel", SAMPLER.params)
    assert again["links_prepared"] == 0
    assert [r["values"].tolist() for r in again["results"]] == [
        r["values"].tolist() for r in first["results"]
    ]


def _pose(i: int) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = (0.004 * i, 0.0, 0.11 + 0.004 * i)
    return pose


# -- threads ------------------------------------------------------------------------------------


def _study_rows(tmp_path, n: int):
    pytest.importorskip("coal")
    if not RECORDS.is_dir():
        pytest.skip(f"no study records under {RECORDS} (set EXACTGRASP_DATA)")
    records = sorted((RECORDS / "CerealBox").glob("*.json"))[:n]
    path = tmp_path / "manifest.jsonl"
    path.write_text("".join(json.dumps({"id": p.stem, "grasp": str(p)}) + "\n" for p in records))
    return path


def _cpu_of_the_rows(manifest: str, limited: bool = True) -> dict:
    """Compute the rows on this thread as a worker task does, after the first (which loads the
    hand model: MuJoCo's compiler runs threads of its own, once per model and process); the
    CPU seconds of every thread but the process's main one (in a dask worker, its event loop)
    over this thread's."""
    import threading

    import exactgrasp.batch.worker as worker
    from exactgrasp.batch import read_manifest

    if not limited:  # what workers did before: manifold3d's pool left at every core
        worker.limit_threads = lambda: None
    main = threading.main_thread().native_id

    def main_cpu() -> float:
        if threading.get_native_id() == main:
            return 0.0  # computing on the main thread (a plain process): it is the row's
        fields = Path(f"/proc/self/task/{main}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    m = read_manifest(manifest)
    worker.compute_rows(m.rows[:1], str(m.base_dir), "exact", SAMPLER.params)
    before = time.process_time() - main_cpu()
    outcome = worker.compute_rows(m.rows[1:], str(m.base_dir), "exact", SAMPLER.params)
    assert [r["error"] for r in outcome["results"]] == [None] * (len(m.rows) - 1)
    rows = time.process_time() - main_cpu() - before
    return {"threads": rows / outcome["thread_cpu_seconds"], "outcome": outcome}


def _unlimited(manifest: str, queue) -> None:
    queue.put(_cpu_of_the_rows(manifest, limited=False)["threads"])


def test_a_worker_uses_one_core_manifold3d_included(tmp_path):
    # A worker computes each row on one thread. The CPU time of every thread of the worker
    # process but its event loop's, over the computing thread's, is the threads' worth of
    # CPU the rows used, whatever else runs on the machine: 1 when no library starts helper
    # threads. The exact backend's boolean of the Barrett hand's 62,000 triangles is where
    # manifold3d's TBB pool used to add its threads.
    pytest.importorskip("distributed")
    import cloudpickle

    from exactgrasp.batch.worker import open_pool

    manifest = _study_rows(tmp_path, 4)
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    try:
        with open_pool(1, None) as pool:
            got = pool.client.submit(_cpu_of_the_rows, str(manifest), pure=False).result()
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    used = got["threads"]
    assert used <= 1.02, f"a worker limited to 1 thread used {used:.3f} threads' worth of CPU"
    # The plain ratio, dask's own bookkeeping included, as timings.jsonl records it. The
    # worker reads its clocks inside the call, this test around it: the test's window holds
    # a few more milliseconds of the process's CPU, so its ratio may be the larger by that.
    outcome = got["outcome"]
    assert outcome["cpu_seconds"] / outcome["thread_cpu_seconds"] >= used - 0.005
    if len(os.sched_getaffinity(0)) < 2:
        pytest.skip("one CPU: the unlimited comparison needs two")
    # The same rows in a fresh process without the limit: the measurement sees TBB's threads.
    spawn = multiprocessing.get_context("spawn")
    queue = spawn.Queue()
    process = spawn.Process(target=_unlimited, args=(str(manifest), queue))
    process.start()
    unlimited = queue.get(timeout=600)
    process.join()
    assert unlimited > used + 0.01, (unlimited, used)
