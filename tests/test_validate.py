"""``exactgrasp validate``: bad input, the statistics, and a quick run on the shared data."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from exactgrasp.cli import main
from exactgrasp.report import roc_auc
from exactgrasp.report.descriptors import neighbour_agreement
from exactgrasp.report.estimator import error_summary
from exactgrasp.report.noise import separation
from exactgrasp.report.write import clean


def test_missing_data_folder_is_a_clear_error(tmp_path, capsys):
    status = main(["validate", "--data", str(tmp_path / "nowhere"), "--out", str(tmp_path)])
    assert status == 2
    err = capsys.readouterr().err
    assert "nowhere" in err and "does not exist" in err and "--data" in err


def test_incomplete_data_folder_names_what_is_missing(tmp_path, capsys):
    (tmp_path / "osu-objects").mkdir()
    assert main(["validate", "--data", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    assert "barrett-grasps/grasps" in capsys.readouterr().err


def test_roc_auc_matches_pair_counting():
    rng = np.random.default_rng(3)
    within, between = rng.normal(0, 1, 40), rng.normal(1, 1, 70)
    within[:5] = between[:5]  # ties count one half
    pairs = between[None, :] - within[:, None]
    expected = (np.sum(pairs > 0) + 0.5 * np.sum(pairs == 0)) / pairs.size
    assert roc_auc(within, between) == pytest.approx(expected)
    assert roc_auc([0.1, 0.2], [0.3, 0.4]) == 1.0
    assert roc_auc([0.3, 0.4], [0.1, 0.2]) == 0.0
    assert roc_auc([1.0], [1.0]) == 0.5


def test_separation_reports_overlap():
    s = separation(np.array([0.1, 0.2, 0.5]), np.array([0.4, 0.6, 0.9]))
    assert s["max_within"] == 0.5 and s["min_between"] == 0.4
    assert s["gap"] == pytest.approx(-0.1)
    assert s["overlap_within"] == 1 and s["overlap_between"] == 1
    assert 0.0 <= s["auc"] <= 1.0


def test_error_summary_signs_and_false_positives():
    exact = np.array([0.0, 0.0, 0.01, 0.02, 0.5])
    estimate = np.array([0.0, 0.003, 0.012, 0.02, 0.45])
    s = error_summary(estimate, exact)
    assert s["false_positive_poses"] == 1 and s["n_zero"] == 2
    assert s["false_positive_rate"] == 0.5
    assert s["max_abs_rel"] == pytest.approx(0.2)
    assert s["n_compared"] == 3
    assert s["fraction_over"] == pytest.approx(1 / 3)


def test_neighbour_agreement():
    a = np.array([[0, 1, 5], [1, 0, 2], [5, 2, 0]], float)
    assert neighbour_agreement(a, a)["nn_agreement"] == 1.0
    # a: 0->1, 1->0, 2->1; b: 0->2, 1->0, 2->0: only grasp 1 keeps its neighbour.
    b = np.array([[0, 2, 1], [2, 0, 3], [1, 3, 0]], float)
    assert neighbour_agreement(a, b)["nn_agreement"] == pytest.approx(1 / 3)


def test_clean_makes_strict_json():
    out = clean({"a": float("nan"), "b": [np.float64(1.5), np.int64(2)], "c": float("inf")})
    assert json.dumps(out, allow_nan=False) == '{"a": null, "b": [1.5, 2], "c": null}'


@pytest.fixture(scope="module")
def quick_report(shared_data, tmp_path_factory):
    out = tmp_path_factory.mktemp("validate")
    status = main(
        ["validate", "--data", str(shared_data), "--out", str(out), "--quick", "--quiet"]
    )
    assert status == 0
    return out


def _finite(value) -> bool:
    return value is not None and np.isfinite(value)


@pytest.mark.slow
def test_quick_report_numbers_are_sane(quick_report):
    summary = json.loads((quick_report / "summary.json").read_text())
    assert summary["meta"]["config"]["name"] == "quick"
    assert summary["findings"], "the report must state its findings"
    backends = summary["meta"]["backends"]
    assert "voxel" in backends

    if "exact" in backends:
        est = summary["estimator"]
        overall = est["overall"]
        for key in ("median_abs_rel", "p95_abs_rel", "max_abs_rel", "mean_signed_rel"):
            assert _finite(overall[key]), key
        assert 0 <= overall["median_abs_rel"] <= overall["p95_abs_rel"] <= overall["max_abs_rel"]
        assert 0 <= overall["false_positive_rate"] <= 1
        assert 0 <= overall["fraction_over"] <= 1
        assert overall["n_compared"] > 0
        for row in est["resolution"]["configs"].values():
            assert row["median_abs_rel"] >= 0 and row["seconds_per_descriptor"] > 0
        assert est["seconds_per_descriptor"]["exact"] > 0
        for kind in ("l2", "l2_diff"):
            d = summary["descriptors"][kind]
            assert -1 <= d["spearman"] <= 1
            assert 0 <= d["nn_agreement"] <= 1

    pose = summary["noise"]["object_pose"]
    main_sampler = summary["meta"]["config"]["noise_samplers"][0]
    for backend in backends:
        levels = pose[main_sampler]["backends"][backend]["l2"]
        for level, v in levels.items():
            assert 0 <= v["auc"] <= 1, level
            assert v["n_within"] > 0 and v["n_between"] > 0
            assert _finite(v["max_within"]) and _finite(v["min_between"])
            assert v["min_between"] >= 0
        # The smallest noise level: copies of one grasp are closer than different grasps.
        first = next(iter(levels.values()))
        assert first["mean_within"] < first["mean_between"]
        joints = summary["noise"]["joints"]["backends"][backend]
        assert joints["draws"] > 0
        for level in joints["levels"].values():
            assert level["mean"] >= 0 and _finite(level["max"])
    assert summary["headline"]
    assert summary["meta"]["compute"]["voxel"] > 0


@pytest.mark.slow
def test_quick_report_html_links_existing_files(quick_report):
    page = (quick_report / "index.html").read_text()
    images = re.findall(r"<img src='([^']+)'", page)
    assert len(images) >= 5
    for src in images:
        assert src.endswith(".png") and (quick_report / src).is_file(), src
    for link in re.findall(r"<a href='([^']+)'", page):
        assert (quick_report / link).is_file(), link
    markdown = (quick_report / "summary.md").read_text()
    for src in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", markdown):
        assert (quick_report / src).is_file(), src
    assert (quick_report / "figures" / "figure1_paths.png").stat().st_size > 10_000


@pytest.mark.slow
def test_quick_report_rerun_reads_the_cache(quick_report, shared_data):
    status = main(
        ["validate", "--data", str(shared_data), "--out", str(quick_report), "--quick", "--quiet"]
    )
    assert status == 0
    meta = json.loads((quick_report / "summary.json").read_text())["meta"]
    assert meta["descriptors_computed"] == 0
    assert meta["descriptors_from_cache"] > 0


def test_validate_is_listed_in_the_command(capsys):
    with pytest.raises(SystemExit):
        main(["validate", "--help"])
    out = capsys.readouterr().out
    assert "--quick" in out and "--data" in out


def test_descriptor_cache_never_reads_a_file_of_other_settings(tmp_path):
    import exactgrasp as eg
    from exactgrasp.report.cache import DescriptorCache
    from tests.conftest import box_arrays

    hand = eg.Hand.from_meshes(
        [box_arrays([-0.05, -0.05, 0.0], [0.05, 0.05, 0.02])],
        frame=eg.HandFrame.from_palm([0, 0, 0.02], [0, 0, 1], [0, 1, 0], 0.08),
    )
    pose = np.eye(4)
    pose[2, 3] = 0.0295  # 0.5 mm into the slab
    grasp = eg.Grasp(hand, eg.objects.box((0.02, 0.02, 0.02)), pose, name="slab")
    sampler = eg.PathSampler(2, 1, 2, n_steps=2)
    cache = DescriptorCache(tmp_path)
    first = cache.descriptor(grasp, sampler, "voxel", object_resolution=12, hand_resolution=20)
    again = cache.descriptor(grasp, sampler, "voxel", object_resolution=12, hand_resolution=20)
    assert (cache.computed, cache.loaded) == (1, 1)
    assert np.array_equal(again.values, first.values)
    # Any setting that changes the values is a new file; the sampler too; n_jobs is not.
    cache.descriptor(grasp, sampler, "voxel", object_resolution=13, hand_resolution=20)
    longer = eg.PathSampler(2, 1, 2, n_steps=3)
    cache.descriptor(grasp, longer, "voxel", object_resolution=12, hand_resolution=20)
    shifted = pose.copy()
    shifted[0, 3] = 0.001
    moved = eg.Grasp(hand, grasp.object, shifted, name="slab")
    cache.descriptor(moved, sampler, "voxel", object_resolution=12, hand_resolution=20)
    assert (cache.computed, cache.loaded) == (4, 1)
    exact = cache.backend("exact", n_jobs=1)
    assert cache.path(grasp, exact, sampler) == cache.path(grasp, cache.backend("exact"), sampler)
    assert len(list((tmp_path / "voxel").glob("*.npz"))) == 4
