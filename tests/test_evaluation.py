"""Evaluation of descriptor distances against labelled pairs: AUC, bootstrap, distances,
starting configurations, baselines, the CSV reader and the ``evaluate`` command."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.stats import mannwhitneyu

import exactgrasp as eg
from exactgrasp.cli.main import main
from exactgrasp.evaluation import (
    EvaluationError,
    auc,
    baseline_matrix,
    bootstrap_auc,
    distance_matrix,
    escape_times,
    evaluate,
    evaluate_matrix,
    object_symmetries,
    pairs_from_groups,
    read_pairs,
    roc_curve,
)
from exactgrasp.evaluation.distances import configuration_values
from exactgrasp.evaluation.symmetry import (
    SYMMETRIES,
    as_symmetries,
    hand_symmetry_mismatch,
    symmetric_poses,
)
from exactgrasp.geometry import objects

TINY = {"n_translations": 4, "n_axes": 2, "n_amounts": 2, "n_steps": 3}

# -- AUC ------------------------------------------------------------------------------------


def test_auc_known_values():
    assert auc([1, 2, 3, 4], [1, 1, 0, 0]) == 1.0
    assert auc([1, 2, 3, 4], [0, 0, 1, 1]) == 0.0
    # same {1, 3}, different {2, 4}: of the four (same, different) pairs, 3 have the
    # different one farther apart.
    assert auc([1, 3, 2, 4], [1, 1, 0, 0]) == 0.75
    # every distance tied: chance
    assert auc([5, 5, 5, 5], [1, 0, 1, 0]) == 0.5


def test_auc_matches_mann_whitney_with_ties():
    rng = np.random.default_rng(3)
    same = rng.integers(0, 6, 40).astype(float)
    different = rng.integers(2, 9, 55).astype(float)
    u = mannwhitneyu(different, same).statistic
    value = auc(np.concatenate([same, different]), np.r_[np.ones(40), np.zeros(55)])
    assert value == pytest.approx(u / (40 * 55), abs=1e-12)


def test_graded_labels_give_the_concordance():
    # grades 2 > 1 > 0 with distances in the same order: fully concordant
    assert auc([0.1, 0.2, 0.3], [2, 1, 0]) == 1.0
    # grade pairs (2,1): 1 of 1 concordant; (2,0): 1 of 1; (1,0): 0 of 1 -> 2/3
    assert auc([0.1, 0.5, 0.3], [2, 1, 0]) == pytest.approx(2 / 3)


def test_roc_curve_area_equals_auc_with_ties():
    d = np.array([1, 1, 2, 3, 3, 3, 4, 5])
    same = np.array([1, 0, 1, 1, 0, 0, 1, 0], bool)
    fpr, tpr, thresholds = roc_curve(d, same)
    assert (fpr[0], tpr[0], fpr[-1], tpr[-1]) == (0, 0, 1, 1)
    assert len(thresholds) == 6  # -inf and the five distinct distances
    assert np.trapezoid(tpr, fpr) == pytest.approx(auc(d, same))


def test_auc_refuses_one_class_and_bad_lengths():
    with pytest.raises(EvaluationError, match="same label"):
        auc([1, 2], [1, 1])
    with pytest.raises(EvaluationError, match="one label per pair"):
        auc([1, 2, 3], [1, 0])


def _clustered(n_per=4, n_groups=4, noise=0.6, seed=0):
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(n_groups, 3)) * 2
    groups = np.repeat(np.arange(n_groups), n_per)
    x = centres[groups] + rng.normal(size=(len(groups), 3)) * noise
    matrix = np.linalg.norm(x[:, None] - x[None], axis=-1)
    return matrix, pairs_from_groups([f"g{i}" for i in range(len(x))], groups.astype(str))


def test_bootstrap_is_seeded_and_brackets_the_auc():
    matrix, pairs = _clustered()
    d = matrix[pairs.first, pairs.second]
    a = bootstrap_auc(d, pairs.label, pairs.first, pairs.second, n_boot=300, seed=1)
    b = bootstrap_auc(d, pairs.label, pairs.first, pairs.second, n_boot=300, seed=1)
    assert a == b
    assert a["low"] <= a["auc"] <= a["high"]
    assert a["auc"] == auc(d, pairs.label)
    assert a["unit"] == "grasp" and a["n_valid"] <= 300


def test_resampling_grasps_is_wider_than_resampling_pairs():
    # Pairs sharing a grasp are dependent; the grasp bootstrap must see that.
    matrix, pairs = _clustered(n_per=5, n_groups=3, noise=1.2, seed=4)
    d = matrix[pairs.first, pairs.second]
    args = (d, pairs.label, pairs.first, pairs.second, pairs.grasp_group)
    grasp = bootstrap_auc(*args, unit="grasp", n_boot=400)
    pair = bootstrap_auc(*args, unit="pair", n_boot=400)
    group = bootstrap_auc(*args, unit="group", n_boot=400)
    assert grasp["std"] > pair["std"]
    assert group["std"] > pair["std"]
    with pytest.raises(EvaluationError, match="groups="):
        bootstrap_auc(d, pairs.label, pairs.first, pairs.second, unit="group")


# -- pairs ----------------------------------------------------------------------------------

#: Grasps per cluster of the 34 cereal-box grasps (barrett-grasps/README.md).
CEREAL_CLUSTERS = {"1": 14, "2": 1, "5": 5, "9": 2, "17": 3, "20": 7, "30": 2}


def test_pairs_from_groups_counts_the_cereal_box_pairs():
    groups = [c for c, n in CEREAL_CLUSTERS.items() for _ in range(n)]
    pairs = pairs_from_groups([f"g{i}" for i in range(34)], groups)
    assert len(pairs) == 561
    assert pairs.n_same == 127


def _grasp_file(folder: Path, name: str, shift: float) -> Path:
    grasp = eg.Grasp(
        eg.hands.parallel_gripper({"finger_1_joint": 0.03}),
        objects.box((0.04, 0.04, 0.04)),
        object_pose=np.array(
            [[1, 0, 0, shift], [0, 1, 0, 0], [0, 0, 1, 0.03], [0, 0, 0, 1]], float
        ),
        name=name,
    )
    return grasp.save(folder / f"{name}.json")


def test_read_pairs_and_its_errors(tmp_path):
    for name, shift in (("a", 0.0), ("b", 0.001), ("c", 0.02)):
        _grasp_file(tmp_path, name, shift)
    csv = tmp_path / "pairs.csv"
    csv.write_text("a,b,label,group\na.json,b.json,same,x\na.json,c.json,different,x\n")
    pairs, sources = read_pairs(csv)
    assert pairs.names == ["a.json", "b.json", "c.json"]
    assert pairs.label.tolist() == [1.0, 0.0] and pairs.pair_group == ["x", "x"]
    assert [Path(s).name for s in sources] == ["a.json", "b.json", "c.json"]

    bad = tmp_path / "bad.csv"
    bad.write_text("a,b,lab\na.json,b.json,same\n")
    with pytest.raises(EvaluationError, match="missing column"):
        read_pairs(bad)
    bad.write_text("a,b,label\na.json,b.json,maybe\n")
    with pytest.raises(EvaluationError, match=r"line 2: label 'maybe'"):
        read_pairs(bad)
    bad.write_text("a,b,label\na.json,zz.json,same\n")
    with pytest.raises(EvaluationError, match="'zz.json' does not exist"):
        read_pairs(bad)
    bad.write_text("a,b,label\na.json,a.json,same\n")
    with pytest.raises(EvaluationError, match="with itself"):
        read_pairs(bad)


def test_read_pairs_by_manifest_id(tmp_path):
    for name, shift in (("a", 0.0), ("b", 0.001)):
        _grasp_file(tmp_path, name, shift)
    manifest = tmp_path / "m.jsonl"
    manifest.write_text('{"id": "A", "grasp": "a.json"}\n{"id": "B", "grasp": "b.json"}\n')
    csv = tmp_path / "pairs.csv"
    csv.write_text("a,b,label\nA,B,1\n")
    pairs, sources = read_pairs(csv, manifest)
    assert pairs.names == ["A", "B"] and Path(sources[1]).name == "b.json"
    csv.write_text("a,b,label\nA,C,1\n")
    with pytest.raises(EvaluationError, match="'C' is not in the manifest"):
        read_pairs(csv, manifest)


# -- distances ------------------------------------------------------------------------------


def test_escape_times_interpolate_between_steps():
    times = np.array([1 / 3, 2 / 3, 1.0])
    values = np.array(
        [
            [0.0, 0.02, 0.04],  # passes 0.01 half-way between 1/3 and 2/3
            [0.02, 0.03, 0.04],  # already past at the first step: half-way from 0 to 1/3
            [0.0, 0.0, 0.005],  # never: one step past the end
        ]
    )
    np.testing.assert_allclose(escape_times(values, times, 0.01), [0.5, 1 / 6, 4 / 3])


def test_distance_matrix_takes_the_minimum_over_configurations():
    times = np.array([0.5, 1.0])
    v = [np.array([[0.0, 1.0]]), np.array([[3.0, 1.0]]), np.array([[0.0, 5.0]])]
    w = [np.array([[3.0, 1.0]]), np.array([[0.0, 1.0]]), np.array([[0.0, 5.0]])]
    stacks = [np.stack([a, b]) for a, b in zip(v, w, strict=True)]
    plain = distance_matrix(stacks, "l2", times, use_configurations=False)
    assert plain[0, 1] == 3.0 and plain[0, 2] == 4.0 and plain[1, 2] == 5.0
    best = distance_matrix(stacks, "l2", times)
    assert best[0, 1] == 0.0  # grasp 1 is grasp 0 seen through the symmetry
    assert best[0, 2] == 4.0 and best[1, 2] == 4.0  # min(5, |w1 - v2| = 4)
    np.testing.assert_array_equal(best, best.T)
    cbrt = distance_matrix(stacks, "cbrt", times, use_configurations=False)
    assert cbrt[0, 1] == pytest.approx(3 ** (1 / 3))
    with pytest.raises(EvaluationError, match="unknown"):
        distance_matrix(stacks, "l3", times)
    with pytest.raises(EvaluationError, match="threshold"):
        distance_matrix(stacks, "escape:x", times)


def test_symmetric_poses_mirror_the_paths():
    sampler = eg.PathSampler(**TINY)
    poses = sampler.poses()
    mirrored = symmetric_poses(poses, SYMMETRIES["mirror-x"])
    np.testing.assert_allclose(np.linalg.det(mirrored[..., :3, :3]), 1.0)
    np.testing.assert_allclose(mirrored[..., 0, 3], -poses[..., 0, 3])
    np.testing.assert_allclose(mirrored[..., 1:3, 3], poses[..., 1:3, 3])
    # a rotation about z turns the other way in the mirror
    table = sampler.paths
    k = int(np.argmax(np.abs(table.axis[:, 2]) * (table.kind == "rotation")))
    np.testing.assert_allclose(mirrored[k, :, :3, :3], poses[k, :, :3, :3].transpose(0, 2, 1))
    with pytest.raises(EvaluationError, match="unknown"):
        as_symmetries("mirror-w")


def test_builtin_hands_are_mirror_symmetric():
    gripper = eg.hands.parallel_gripper()
    for name in ("mirror-x", "mirror-y", "turn-z"):
        assert hand_symmetry_mismatch(gripper, SYMMETRIES[name]) < 1e-9
    assert hand_symmetry_mismatch(gripper, SYMMETRIES["mirror-z"]) > 1.0
    assert hand_symmetry_mismatch(eg.hands.barrett(), SYMMETRIES["mirror-x"]) < 1e-9


def _gripper_grasp(pose, name):
    hand = eg.hands.parallel_gripper({"finger_1_joint": 0.02})
    return eg.Grasp(hand, objects.box((0.03, 0.05, 0.07)), object_pose=pose, name=name)


def test_a_mirrored_grasp_is_at_distance_zero_over_the_mirror():
    # The mirror image of a grasp of a mirror-symmetric object with a mirror-symmetric hand:
    # its descriptor is the original's along the mirrored paths (exact backend: to rounding).
    turn = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
    pose = np.eye(4)
    pose[:3, :3] = turn
    pose[:3, 3] = [0.01, 0.0, 0.05]
    m = np.diag([-1.0, 1.0, 1.0, 1.0])
    a, b = _gripper_grasp(pose, "a"), _gripper_grasp(m @ pose @ m, "b")
    sampler = eg.PathSampler(**TINY)
    backend = eg.get_backend("exact")
    da = eg.compute_descriptor(a, sampler, backend=backend)
    db = eg.compute_descriptor(b, sampler, backend=backend)
    sym = as_symmetries("mirror-x")
    sa = configuration_values(a, da, sampler, backend, sym)
    sb = configuration_values(b, db, sampler, backend, sym)
    assert np.abs(da.values - db.values).max() > 1e-3  # the plain descriptors differ
    np.testing.assert_allclose(sa[1], db.values, atol=1e-12)
    matrix = distance_matrix([sa, sb], "l2", sampler.times)
    assert matrix[0, 1] < 1e-10


def test_object_symmetries_leave_the_descriptor_unchanged():
    box = objects.box((0.03, 0.05, 0.07))
    turns = object_symmetries(box)
    assert len(turns) == 4  # identity and three half turns
    pose = np.eye(4)
    pose[:3, 3] = [0.005, 0.0, 0.05]
    sampler = eg.PathSampler(**TINY)
    backend = eg.get_backend("exact")
    base = eg.compute_descriptor(_gripper_grasp(pose, "a"), sampler, backend=backend)
    for turn in turns[1:]:
        other = eg.compute_descriptor(_gripper_grasp(pose @ turn, "b"), sampler, backend=backend)
        np.testing.assert_allclose(other.values, base.values, atol=1e-12)
    corners = [[0, 0, 0], [0.03, 0, 0], [0, 0.05, 0], [0, 0, 0.07]]
    lopsided = eg.Solid.from_trimesh(trimesh.convex.convex_hull(corners))
    assert len(object_symmetries(lopsided)) == 1


def test_pose_baseline_is_zero_across_object_symmetries():
    box = objects.box((0.03, 0.05, 0.07))
    turns = object_symmetries(box)
    pose = np.eye(4)
    pose[:3, 3] = [0.005, 0.0, 0.05]
    shifted = pose.copy()
    shifted[0, 3] += 0.01
    grasps = [
        _gripper_grasp(pose, "a"),
        _gripper_grasp(pose @ turns[2], "b"),
        _gripper_grasp(shifted, "c"),
    ]
    scale = grasps[0].frame.scale  # canonical units per metre
    pose_d = baseline_matrix(grasps, "pose")
    assert pose_d[0, 1] == pytest.approx(0.0, abs=1e-9)
    assert pose_d[0, 2] == pytest.approx(0.01 * scale)
    assert baseline_matrix(grasps, "origin")[0, 2] == pytest.approx(0.01 * scale)
    joints = baseline_matrix(grasps, "joints")
    assert joints[0, 1] == 0.0
    barrett = eg.Grasp(eg.hands.barrett(), box, object_pose=pose, name="barrett")
    with pytest.raises(EvaluationError, match="one hand only"):
        baseline_matrix([*grasps, barrett], "joints")


def test_evaluate_descriptors_of_separated_groups():
    rng = np.random.default_rng(0)
    sampler = eg.PathSampler(**TINY)
    shape = (sampler.n_paths, sampler.n_steps)
    centres = rng.uniform(0, 0.5, size=(3, *shape))
    items = [
        eg.Descriptor(centres[g] + rng.uniform(0, 0.01, shape), {"sampler": sampler.params})
        for g in (0, 0, 1, 1, 2, 2)
    ]
    pairs = pairs_from_groups([str(i) for i in range(6)], ["a", "a", "b", "b", "c", "c"])
    result = evaluate(items, pairs, distances=("l2", "escape:0.1"), n_boot=50)
    ev = result.evaluations["l2"]
    assert ev.auc == 1.0 and (ev.n_same, ev.n_different) == (3, 12)
    assert set(ev.groups) == {"a", "b", "c"} and ev.groups["a"]["n_different"] == 8
    assert "baseline: joints" not in result.evaluations
    with pytest.raises(EvaluationError, match="shape"):
        evaluate_matrix(np.zeros((2, 2)), pairs)


# -- the command ----------------------------------------------------------------------------


def test_evaluate_command_writes_the_report(tmp_path, capsys):
    for name, shift in (("a", 0.0), ("b", 0.0005), ("c", 0.012), ("d", 0.0125)):
        _grasp_file(tmp_path, name, shift)
    csv = tmp_path / "pairs.csv"
    csv.write_text(
        "a,b,label\n"
        "a.json,b.json,same\nc.json,d.json,same\n"
        "a.json,c.json,different\na.json,d.json,different\n"
        "b.json,c.json,different\nb.json,d.json,different\n"
    )
    out = tmp_path / "out"
    status = main(
        [
            "evaluate",
            str(csv),
            "-o",
            str(out),
            "--sampler",
            json.dumps(TINY),
            "--distance",
            "l2",
            "--baseline",
            "position",
            "--n-boot",
            "50",
        ]
    )
    assert status == 0
    data = json.loads((out / "evaluation.json").read_text())
    assert set(data["evaluations"]) == {"l2", "baseline: position"}
    assert data["evaluations"]["baseline: position"]["auc"] == 1.0
    assert data["n_pairs"] == 6
    assert (out / "roc.png").stat().st_size > 1000
    assert "| baseline: position | 1.000 |" in (out / "evaluation.md").read_text()
    assert re.search(r"l2\s+AUC", capsys.readouterr().out)

    csv.write_text("a,b,label\na.json,b.json,perhaps\n")
    assert main(["evaluate", str(csv), "-o", str(out)]) == 2
    assert "label 'perhaps'" in capsys.readouterr().err


# -- the shared data ------------------------------------------------------------------------


def test_cereal_box_clusters_joint_baseline(shared_data):
    from exactgrasp.evaluation.study import cereal_grasps

    grasps, clusters = cereal_grasps(shared_data / "barrett-grasps", variant="adjusted")
    assert sorted({c: clusters.count(c) for c in clusters}.items()) == sorted(
        CEREAL_CLUSTERS.items()
    )
    pairs = pairs_from_groups([g.name for g in grasps], clusters)
    ev = evaluate_matrix(baseline_matrix(grasps, "joints"), pairs, n_boot=100)
    assert ev.auc == pytest.approx(0.882, abs=5e-4)
    # the box file's origin is a corner: its position also tells which way round the box is
    origin = evaluate_matrix(baseline_matrix(grasps, "origin"), pairs, n_boot=100)
    assert origin.auc == pytest.approx(0.898, abs=5e-4)
    centre = evaluate_matrix(baseline_matrix(grasps, "position"), pairs, n_boot=100)
    assert centre.auc == pytest.approx(0.637, abs=5e-4)


# -- the report's rules ---------------------------------------------------------------------


def _entry(value):
    return {"auc": value}


def test_default_rule_needs_noise_auc_0_99_then_the_best_cluster_auc():
    from exactgrasp.evaluation.study import choose_default

    names = ["l2", "l2 min mirror-x", "cbrt", "cbrt min mirror-x", "escape:0.05"]
    voxel = dict(zip(names, [0.80, 0.90, 0.85, 0.86, 0.95], strict=True))
    exact = dict(zip(names, [0.80, 0.90, 0.85, 0.86, 0.95], strict=True))
    clusters = {
        "backends": {
            "voxel": {"distances": {k: _entry(v) for k, v in voxel.items()}},
            "exact": {"distances": {k: _entry(v) for k, v in exact.items()}},
        }
    }
    # escape separates noisy copies worse than l2 and the mirror minimum slightly worse
    noise_auc = dict(zip(names, [0.99, 0.985, 0.995, 0.985, 0.9], strict=True))
    noise = {"levels": {"a": {k: _entry(v) for k, v in noise_auc.items()}}}
    chosen = choose_default(clusters, noise)
    assert chosen["default"] == "cbrt"
    assert [r["name"] for r in chosen["rows"] if not r["qualifies"]] == [
        "l2 min mirror-x",
        "cbrt min mirror-x",
        "escape:0.05",
    ]
    # within 0.005 of the best, the plain distance earlier in the list wins
    voxel["cbrt min mirror-x"] = exact["cbrt min mirror-x"] = 0.80
    noise_auc["l2 min mirror-x"] = 0.99
    noise = {"levels": {"a": {k: _entry(v) for k, v in noise_auc.items()}}}
    clusters["backends"]["voxel"]["distances"]["l2"] = _entry(0.898)
    clusters["backends"]["exact"]["distances"]["l2"] = _entry(0.898)
    assert choose_default(clusters, noise)["default"] == "l2"


def test_smallest_sampler_within_the_largest_interval():
    from exactgrasp.evaluation.text import smallest_within_interval

    def row(n, auc, low, backend="voxel", steps=9):
        return {
            "n_paths": n,
            "n_steps": steps,
            "backend": backend,
            "auc": {"auc": auc, "low": low, "high": 1.0},
        }

    rows = [row(24, 0.70, 0.6), row(98, 0.83, 0.7), row(474, 0.85, 0.75), row(2498, 0.86, 0.8)]
    rows.append(row(474, 0.99, 0.9, steps=3))  # other step counts are not sizes
    found = smallest_within_interval(rows, "voxel")
    assert found["smallest"]["n_paths"] == 98 and found["largest"]["n_paths"] == 2498
    assert smallest_within_interval(rows, "exact") is None


def test_paired_difference_of_two_distances():
    matrix, pairs = _clustered(n_per=5, n_groups=3, noise=1.0, seed=2)
    d = matrix[pairs.first, pairs.second]
    noisy = d + np.random.default_rng(0).normal(0, 1.0, d.size)
    out = bootstrap_auc(d, pairs.label, pairs.first, pairs.second, n_boot=300, reference=noisy)[
        "difference"
    ]
    assert out["value"] == pytest.approx(auc(d, pairs.label) - auc(noisy, pairs.label))
    assert out["low"] <= out["value"] <= out["high"]
    same = bootstrap_auc(d, pairs.label, pairs.first, pairs.second, n_boot=50, reference=d)
    assert same["difference"] == {"value": 0.0, "low": 0.0, "high": 0.0, "below_zero": 0.0}


def test_the_recommended_distance_is_a_descriptor_distance_kind():
    from exactgrasp.evaluation.distances import RECOMMENDED_DISTANCE

    sampler = eg.PathSampler(**TINY)
    rng = np.random.default_rng(5)
    a, b = (
        eg.Descriptor(rng.uniform(0, 0.2, (sampler.n_paths, 3)), {"sampler": sampler.params})
        for _ in range(2)
    )
    matrix = distance_matrix([a.values[None], b.values[None]], RECOMMENDED_DISTANCE, sampler.times)
    assert eg.distance(a, b, RECOMMENDED_DISTANCE) == pytest.approx(matrix[0, 1])
    assert eg.distance(a, b, "cbrt") == pytest.approx(
        np.linalg.norm(np.cbrt(a.values) - np.cbrt(b.values))
    )


def test_the_names_listed_without_the_code_are_the_code_s():
    from exactgrasp.evaluation import names, symmetry

    assert tuple(symmetry.SYMMETRIES) == names.SYMMETRY_NAMES
    assert set(names.DEFAULT_DISTANCES) <= set(names.DISTANCES)


# -- the report "What the descriptor tells you" ---------------------------------------------

REPORT = Path(__file__).resolve().parents[1] / "docs" / "reports" / "descriptor-meaning"


def test_the_committed_report_is_the_text_of_its_summary():
    from exactgrasp.evaluation.text import report_markdown

    summary = json.loads((REPORT / "summary.json").read_text())
    assert report_markdown(summary) == (REPORT / "report.md").read_text()
    hands = summary["hands"]
    assert hands["hands"] == ["barrett", "gripper", "adroit"]
    assert set(hands["groups"]) == {
        "barrett / gripper",
        "barrett / adroit",
        "gripper / adroit",
        "barrett / gripper / adroit",
    }


def test_across_hand_pairs_are_same_placement_against_one_hand():
    from exactgrasp.evaluation.study import across_hand_pairs

    hand = np.repeat(["a", "b", "c"], 2)
    placement = np.tile(np.arange(2), 3)
    names = [f"{h}{p}" for h, p in zip(hand, placement, strict=True)]
    pairs = across_hand_pairs(names, hand, placement)
    assert pairs.n_same == 6 and len(pairs) == 9  # 3 hand pairs x 2 placements; 3 in one hand
    across = hand[pairs.first] != hand[pairs.second]
    assert np.all(pairs.label[across] == 1) and np.all(pairs.label[~across] == 0)


def test_report_sections_option_needs_known_names_and_the_existing_summary(tmp_path):
    from exactgrasp.evaluation.run import build_report

    with pytest.raises(EvaluationError, match="unknown sections"):
        build_report(tmp_path, tmp_path / "out", tmp_path / "cache", sections=("handz",))
    with pytest.raises(EvaluationError, match="existing summary.json"):
        build_report(tmp_path, tmp_path / "out", tmp_path / "cache", sections=("hands",))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "summary.json").write_text(json.dumps({"quick": False}))
    with pytest.raises(EvaluationError, match="same --quick setting"):
        build_report(
            tmp_path, tmp_path / "out", tmp_path / "cache", quick=True, sections=("hands",)
        )
