import json

import numpy as np
import pytest
import scipy.linalg

from exactgrasp.errors import SamplerError
from exactgrasp.geometry.se3 import exp_se3, invert_rigid, is_rigid, twist_matrix
from exactgrasp.paths import PathSampler, as_sampler
from exactgrasp.paths.sampler import GOLDEN_ANGLE, rotation_amounts, sphere_points, step_times


@pytest.mark.parametrize(
    ("preset", "n_paths"), [("balanced", 474), ("translations", 434), ("rotations", 318)]
)
def test_preset_counts(preset, n_paths):
    sampler = PathSampler.preset(preset)
    assert sampler.n_paths == n_paths
    assert sampler.n_poses == 9 * n_paths
    assert sampler.poses().shape == (n_paths, 9, 4, 4)
    assert len(sampler.paths.kind) == n_paths


def test_path_counts_formula():
    sampler = PathSampler(n_translations=5, n_axes=3, n_amounts=2, n_steps=4)
    table = sampler.paths
    assert sampler.n_paths == 5 * 3 * 2 + 5 + 3 * 2
    assert np.sum(table.kind == "both") == 30
    assert np.sum(table.kind == "translation") == 5
    assert np.sum(table.kind == "rotation") == 6
    assert np.all(table.amount[table.kind == "translation"] == 0)
    assert np.all(np.linalg.norm(table.direction[table.kind == "rotation"], axis=1) == 0)


def test_phyllotaxis_formula():
    n = 7
    points = sphere_points(n)
    i = 3
    lat = np.arccos(1 - 2 * i / (n - 1))
    lon = i * GOLDEN_ANGLE
    expected = [np.sin(lat) * np.cos(lon), np.sin(lat) * np.sin(lon), np.cos(lat)]
    np.testing.assert_allclose(points[i], expected, atol=1e-15)
    np.testing.assert_allclose(points[0], [0, 0, 1], atol=1e-15)  # both poles included
    np.testing.assert_allclose(points[-1], [0, 0, -1], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(sphere_points(50), axis=1), 1.0, atol=1e-15)
    assert GOLDEN_ANGLE == pytest.approx(2.399963229728653)
    np.testing.assert_allclose(sphere_points(1), [[0, 0, 1]])


def test_rotation_amounts_rules():
    np.testing.assert_allclose(rotation_amounts(6), [-6 / 7, -4 / 7, -2 / 7, 2 / 7, 4 / 7, 6 / 7])
    np.testing.assert_allclose(rotation_amounts(7), [-0.75, -0.5, -0.25, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_allclose(rotation_amounts(4), [-0.8, -0.4, 0.4, 0.8])
    for n in range(1, 12):
        amounts = rotation_amounts(n)
        assert len(amounts) == n and np.all(amounts != 0)
        # symmetric in sign on the circle: every amount's mirror is present (1 is its own)
        mirrored = np.where(amounts == 1.0, 1.0, -amounts)
        np.testing.assert_allclose(np.sort(mirrored), amounts)
    # the authors' code: linspace, including 0 for odd n
    np.testing.assert_allclose(rotation_amounts(7, "linspace"), np.linspace(-1, 1, 7))
    assert 0.0 in rotation_amounts(7, "linspace")


def test_step_time_conventions():
    np.testing.assert_allclose(step_times(9, "paper"), np.arange(1, 10) / 9)
    np.testing.assert_allclose(step_times(9, "code"), np.arange(1, 10) / 10)
    sampler = PathSampler(2, 1, 2, n_steps=9, steps="code")
    assert sampler.times[-1] == pytest.approx(0.9)


def test_exp_matches_scipy_expm():
    rng = np.random.default_rng(1)
    omega = rng.normal(size=(200, 3)) * rng.uniform(0, 4, size=(200, 1))
    omega[:5] *= 1e-7  # the small-angle branch
    omega[5] = 0.0
    v = rng.normal(size=(200, 3))
    ours = exp_se3(omega, v)
    for k in range(200):
        expected = scipy.linalg.expm(twist_matrix(omega[k], v[k]))
        np.testing.assert_allclose(ours[k], expected, atol=1e-12, rtol=0)


def test_sampler_poses_match_expm_and_are_rigid():
    sampler = PathSampler(n_translations=3, n_axes=2, n_amounts=3, n_steps=4)
    poses = sampler.poses()
    table = sampler.paths
    for p in range(sampler.n_paths):
        for k, t in enumerate(sampler.times):
            m = twist_matrix(table.omega[p] * t, table.direction[p] * t)
            np.testing.assert_allclose(poses[p, k], scipy.linalg.expm(m), atol=1e-12)
            assert is_rigid(poses[p, k], atol=1e-12)
    # translation-only paths move by t along the unit direction
    i = np.flatnonzero(table.kind == "translation")[0]
    np.testing.assert_allclose(poses[i, -1, :3, 3], table.direction[i] * sampler.times[-1])
    np.testing.assert_allclose(poses[i, -1, :3, :3], np.eye(3))


def test_poses_deterministic_and_inverse():
    a = PathSampler.preset("balanced").poses()
    b = PathSampler.preset("balanced").poses()
    assert np.array_equal(a, b)
    identity = invert_rigid(a) @ a
    np.testing.assert_allclose(identity, np.broadcast_to(np.eye(4), a.shape), atol=1e-12)


def test_params_round_trip():
    sampler = PathSampler(4, 2, 3, n_steps=5, amounts=[-0.5, 0.5, 1.0], steps="code")
    again = PathSampler.from_params(sampler.params)
    assert np.array_equal(again.poses(), sampler.poses())


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_translations": 0}, "n_translations must be a positive integer"),
        ({"n_steps": 2.5}, "n_steps must be a positive integer"),
        ({"amounts": "spiral"}, "amount rule 'spiral' is unknown"),
        ({"amounts": [0.5, 0.0, 1.0, 0.2, 0.3, 0.4]}, "must be non-zero"),
        ({"amounts": [0.5]}, "amounts must be 6 finite numbers"),
        ({"steps": "matlab"}, "step rule 'matlab' is unknown"),
        ({"steps": [0.0] * 9}, "steps must be 9 times in (0, 1]"),
    ],
)
def test_bad_parameters(kwargs, message):
    with pytest.raises(SamplerError, match=message.replace("(", r"\(").replace(")", r"\)")):
        PathSampler(**kwargs)


def test_unknown_preset():
    with pytest.raises(SamplerError, match="unknown preset 'fast'"):
        PathSampler.preset("fast")


def test_as_sampler_takes_every_form():
    small = PathSampler(3, 2, 2, n_steps=4)
    assert as_sampler().params == PathSampler.preset("balanced").params
    assert as_sampler(small) is small
    assert as_sampler(small, n_steps=4) is small
    assert as_sampler("rotations").params == PathSampler.preset("rotations").params
    assert as_sampler("rotations", n_steps=3).n_steps == 3
    assert as_sampler(None, n_steps=2).params == PathSampler.preset("balanced", n_steps=2).params
    assert as_sampler(small.params).params == small.params
    assert as_sampler(json.dumps(small.params), n_steps=5).params == {**small.params, "n_steps": 5}


@pytest.mark.parametrize(
    ("value", "n_steps", "message"),
    [
        ("fast", None, "unknown preset 'fast'"),
        ('{"n_axes": 2', None, "not valid JSON"),
        ({"n_axes": 2, "speed": 3}, None, "unknown parameter.* speed"),
        (3, None, "sampler 3 is a int; give None"),
        (PathSampler(3, 2, 2, n_steps=4), 5, "already built with n_steps=4"),
        ("balanced", 0, "n_steps must be a positive integer"),
    ],
)
def test_as_sampler_refuses_with_the_accepted_forms(value, n_steps, message):
    with pytest.raises(SamplerError, match=message):
        as_sampler(value, n_steps=n_steps)


def test_as_sampler_reads_a_json_file(tmp_path):
    from exactgrasp.paths import as_sampler

    params = {"n_translations": 4, "n_axes": 2, "n_amounts": 2, "n_steps": 3}
    path = tmp_path / "sampler.json"
    path.write_text(json.dumps(params))
    for value in (path, str(path)):
        sampler = as_sampler(value, n_steps=5)
        assert (sampler.n_steps, sampler.params["n_translations"]) == (5, 4)
    with pytest.raises(SamplerError, match="cannot be read"):
        as_sampler(tmp_path / "missing.json")
    path.write_text("[1, 2]")
    with pytest.raises(SamplerError, match="not a JSON object"):
        as_sampler(path)
