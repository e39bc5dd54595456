"""Closed meshes of primitive shapes: closed, outward, volumes converging to the formulas."""

import math

import numpy as np
import pytest

from exactgrasp.errors import MeshError
from exactgrasp.geometry import primitives


def _volume(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)


def _assert_closed_shell(V, F):
    assert V.dtype == np.float64 and F.dtype == np.int64
    assert len(np.unique(V, axis=0)) == len(V), "duplicate vertices"
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    directed = {tuple(e) for e in edges.tolist()}
    assert len(directed) == len(edges), "an edge is used twice in the same direction"
    assert all((b, a) in directed for a, b in directed), "open edge"
    assert _volume(V, F) > 0, "faces point inwards"


SHAPES = {
    "sphere": (lambda n: primitives.sphere(0.7, n), 4 / 3 * math.pi * 0.7**3),
    "ellipsoid": (lambda n: primitives.ellipsoid((0.5, 1.0, 2.0), n), 4 / 3 * math.pi),
    "cylinder": (lambda n: primitives.cylinder(0.3, 0.8, n), math.pi * 0.09 * 1.6),
    "capsule": (
        lambda n: primitives.capsule(0.3, 0.8, n),
        math.pi * 0.09 * 1.6 + 4 / 3 * math.pi * 0.027,
    ),
}


def test_box_is_exact():
    V, F = primitives.box((0.1, 0.2, 0.3))
    _assert_closed_shell(V, F)
    assert _volume(V, F) == pytest.approx(0.048, rel=1e-12)
    assert np.allclose(V.max(axis=0), (0.1, 0.2, 0.3))


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_curved_shapes_are_closed_and_converge(name):
    build, exact = SHAPES[name]
    errors = []
    for n in (8, 16, 32, 64, 128):
        V, F = build(n)
        _assert_closed_shell(V, F)
        errors.append(exact - _volume(V, F))
    errors = np.array(errors) / exact
    assert np.all(errors > 0), "inscribed meshes lie inside the true solid"
    assert np.all(np.diff(errors) < 0), errors
    assert errors[2] < 0.02 and errors[-1] < 1.5e-3, errors
    # Quadratic convergence: doubling the segments divides the error by about 4.
    assert 3.0 < errors[-2] / errors[-1] < 5.0


def test_vertices_lie_on_the_surface():
    V, _ = primitives.ellipsoid((0.5, 1.0, 2.0), 24)
    assert np.allclose(((V / (0.5, 1.0, 2.0)) ** 2).sum(axis=1), 1.0)
    V, _ = primitives.capsule(0.3, 0.8, 24)
    axis_z = np.clip(V[:, 2], -0.8, 0.8)
    assert np.allclose(np.linalg.norm(V - np.c_[0 * V[:, :2], axis_z], axis=1), 0.3)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (
            lambda: primitives.box((1, 0, 1)),
            r"half_extents must be finite and > 0, got \(1, 0, 1\)",
        ),
        (lambda: primitives.box((1, 1)), r"half_extents must have 3 values, got shape \(2,\)"),
        (
            lambda: primitives.sphere(-1.0),
            r"radii must be finite and > 0, got \(-1\.0, -1\.0, -1\.0\)",
        ),
        (
            lambda: primitives.cylinder(1.0, math.nan),
            r"half_height must be finite and > 0, got nan",
        ),
        (
            lambda: primitives.capsule(1.0, 1.0, segments=3),
            r"segments must be an integer >= 4, got 3",
        ),
        (
            lambda: primitives.ellipsoid((1, 1, 1), segments=8.5),
            r"segments must be an integer >= 4, got 8\.5",
        ),
    ],
)
def test_bad_parameters(call, message):
    with pytest.raises(MeshError, match=f"^{message}$"):
        call()


def test_volume_errors_at_32_and_64_segments():
    """The figures of the hand-model docs: the inscribed meshes' volume errors."""
    errors = {}
    for name, (build, exact) in SHAPES.items():
        errors[name] = [(_volume(*build(n)) - exact) / exact for n in (32, 64)]
    assert errors["sphere"] == pytest.approx([-0.016, -0.004], abs=1e-4)
    assert errors["ellipsoid"] == pytest.approx(errors["sphere"], abs=1e-12)
    assert errors["cylinder"] == pytest.approx([-0.0064, -0.0016], abs=1e-4)
    # A capsule is a cylinder with a sphere's ends: between the two.
    for k in (0, 1):
        assert errors["sphere"][k] < errors["capsule"][k] < errors["cylinder"][k]
