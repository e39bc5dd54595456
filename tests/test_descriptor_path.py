"""The descriptor path does no wasted work: each distinct pose computed once, the BVH built only
when it pays, the hand volume from the exact backend's own union, progress from inside one call,
and the threads ``n_jobs=None`` means (every core, one in a batch worker)."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest
import trimesh

import exactgrasp as eg
from exactgrasp.backends import defaults
from exactgrasp.backends.base import default_threads, repeated_poses, thread_limit
from exactgrasp.backends.exact import ExactBackend, ExactIntersector
from exactgrasp.batch import compute_rows
from exactgrasp.batch.manifest import ManifestRow
from exactgrasp.descriptor import compute_volumes
from tests.conftest import box_arrays, box_grasp


class CountingBackend(eg.Backend):
    """Records every pose it is given and the threads ``n_jobs=None`` means while it runs;
    volume = squared x-translation."""

    name = "counting"

    def __init__(self):
        self.received: list[np.ndarray] = []
        self.threads: list[int] = []

    @property
    def params(self):
        return {}

    def volumes(self, grasp, poses):
        poses = eg.backends.check_poses(poses)
        self.received.append(poses.reshape(-1, 4, 4))
        self.threads.append(default_threads())
        return poses[..., 0, 3] ** 2


@pytest.fixture
def grasp():
    return box_grasp()


def translations(*shifts):
    P = np.tile(np.eye(4), (len(shifts), 1, 1))
    P[:, :3, 3] = shifts
    return P


@pytest.mark.parametrize("progress", [False, True])
def test_each_distinct_pose_of_a_descriptor_reaches_the_backend_once(grasp, progress):
    sampler = eg.PathSampler.preset("balanced")
    every = sampler.poses().reshape(-1, 4, 4)
    distinct = len(np.unique(repeated_poses(every)))
    assert (len(every), distinct) == (4266, 3186)
    backend = CountingBackend()
    volumes = compute_volumes(grasp, sampler.poses(), backend, progress)
    got = np.concatenate(backend.received)
    assert len(got) == distinct
    np.testing.assert_array_equal(repeated_poses(got), np.arange(distinct))
    if not progress:
        assert len(backend.received) == 1
    # Every pose, repeats included, gets the volume of its own (or an equal) pose.
    np.testing.assert_allclose(volumes.ravel(), every[:, 0, 3] ** 2, rtol=1e-12, atol=1e-28)
    # The whole descriptor: no sampler pose twice, every one there.
    backend = CountingBackend()
    d = eg.compute_descriptor(grasp, sampler, backend, progress=progress)
    got = np.concatenate(backend.received)
    assert (repeated_poses(got) == np.arange(len(got))).all()
    assert (repeated_poses(np.concatenate([got, every]))[len(got) :] < len(got)).all()
    want = every[:, 0, 3] ** 2 / grasp.canonical_hand_volume
    np.testing.assert_allclose(d.values.ravel(), want, rtol=1e-12, atol=1e-28)


def test_exact_progress_comes_from_inside_one_call_and_adds_up(monkeypatch):
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    obj = [box_arrays([0.2, 0.2, 0.2], [0.6, 0.6, 0.6])]
    rng = np.random.default_rng(3)
    P = translations(*rng.uniform(-1, 1, (300, 3)))
    P = np.concatenate([P, P[:40]])  # repeats count for the pose they stand for
    calls, threads = [], set()

    def advance(k):
        calls.append(k)
        threads.add(threading.get_ident())

    for jobs in (1, 2):
        calls.clear()
        ex = ExactIntersector(hand, obj, broadphase=None, n_jobs=jobs)
        got = ex.volumes(P, progress=advance)
        assert sum(calls) == len(P) and len(calls) > 1
        assert threads == {threading.get_ident()}
        np.testing.assert_array_equal(got, ExactIntersector(hand, obj, broadphase=None).volumes(P))


def test_n_jobs_none_is_every_core_and_a_thread_limit_pins_it(monkeypatch):
    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    hand = [box_arrays([0, 0, 0], [1, 1, 1])]
    P = translations(*[[0.1 * k, 0, 0] for k in range(8)])
    assert defaults.EXACT_N_JOBS is None and ExactBackend().n_jobs is None
    ex = ExactIntersector(hand, hand, broadphase=None)
    base = ex.intersect(P)
    assert base.stats["threads"] == 3 == default_threads()
    with thread_limit(1):
        assert default_threads() == 1
        limited = ex.intersect(P)
        np.testing.assert_array_equal(limited.volumes, base.volumes)
        assert limited.stats["threads"] == 1
        # An explicit number, or -1 (every core), is not the limit's to change.
        every_core = ExactIntersector(hand, hand, broadphase=None, n_jobs=-1)
        assert every_core.intersect(P).stats["threads"] == 3
    assert ex.intersect(P).stats["threads"] == 3


@pytest.mark.parametrize(("single_thread", "threads"), [(True, 1), (False, 3)])
def test_batch_workers_decide_the_threads(monkeypatch, tmp_path, grasp, single_thread, threads):
    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    grasp.save(tmp_path / "g.json")
    backend = CountingBackend()
    sampler = eg.PathSampler(2, 1, 2, n_steps=3)
    rows = [ManifestRow(0, "g", "g.json")]
    outcome = compute_rows(
        rows, str(tmp_path), backend, sampler.params, single_thread=single_thread
    )
    assert outcome["results"][0]["error"] is None, outcome["results"][0]["message"]
    assert backend.threads and set(backend.threads) == {threads}
    assert default_threads() == 3  # only inside the worker's rows


def _fine_sphere(centre):
    mesh = trimesh.creation.icosphere(subdivisions=4, radius=0.5)
    return np.asarray(mesh.vertices) + centre, np.asarray(mesh.faces)


def test_the_bvh_is_built_only_with_a_broad_phase_and_enough_open_poses():
    hand = [_fine_sphere([0.0, 0.0, 0.0])]  # 5,120 triangles: the BVH is not free
    obj = [box_arrays([-0.1, -0.1, -0.1], [0.1, 0.1, 0.1])]
    inside, far = translations([0, 0, 0]), translations([5.0, 0, 0], [0, 6.0, 0])
    # In the corner of the hand's bounding box, off its sphere: neither apart by the bounds
    # nor crossing, so only the BVHs can cull them.
    corner = translations(*[[0.48 + 0.0002 * k, 0.48, 0] for k in range(170)])
    for bp in (None, "coal"):
        ex = ExactIntersector(hand, obj, broadphase=bp)
        assert ex.cull is None  # nothing is built before a call
        result = ex.intersect(np.concatenate([inside, far]))
        # The far poses need no BVH: the bounds tell them apart.
        assert ex.cull is None and result.stats["poses_culled"] == (0 if bp is None else 2)
    triangles = len(ex.hand_mesh.faces) + len(ex.object_mesh.faces)
    assert len(corner) * defaults.EXACT_CULL_TRIANGLES_PER_POSE >= triangles
    result = ex.intersect(corner)
    assert ex.cull is not None and result.stats["poses_culled"] == len(corner)
    assert (result.volumes == 0).all()
    # Once built it serves every later call, and culling never changes a bit of a result.
    assert ex.intersect(corner[:3]).stats["poses_culled"] == 3
    plain = ExactIntersector(hand, obj, broadphase=None)
    P = np.concatenate([inside, far, corner])
    np.testing.assert_array_equal(ex.volumes(P), plain.volumes(P))
    assert plain.cull is None


@pytest.mark.filterwarnings("ignore:grasp 'g'")  # the object sits inside the hand
def test_the_exact_descriptor_takes_the_hand_volume_from_the_intersector(grasp):
    backend = ExactBackend(broadphase=None)
    d = eg.compute_descriptor(grasp, eg.PathSampler(2, 1, 2, n_steps=3), backend)
    built = backend.intersector(grasp).hand_volume
    assert d.metadata["hand_volume_canonical"] == built == backend.hand_volume(grasp)
    assert built == pytest.approx(grasp.canonical_hand_volume, rel=1e-12)
    assert d.metadata["hand_volume_m3"] == pytest.approx(grasp.hand.volume, rel=1e-12)


def test_the_default_progress_hook_computes_in_progress_pieces(grasp):
    from exactgrasp.backends.base import PROGRESS_PIECES

    backend = CountingBackend()
    poses = translations(*[(x, 0, 0) for x in np.linspace(-1, 1, 100)])
    done: list[int] = []
    volumes = backend.volumes_with_progress(grasp, poses, done.append)
    assert PROGRESS_PIECES == 20
    assert done == [5] * 20 and [len(p) for p in backend.received] == [5] * 20
    np.testing.assert_array_equal(volumes, poses[:, 0, 3] ** 2)
    backend = CountingBackend()
    np.testing.assert_array_equal(backend.volumes_with_progress(grasp, poses), volumes)
    assert [len(p) for p in backend.received] == [100]  # no hook: one call
