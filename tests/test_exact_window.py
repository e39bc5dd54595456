"""The exact fallback's arrangement cut near the moved object only (`ArrangedHand`,
`exact_window.window_regions`): the same exact volume as the whole surfaces' arrangement
(`level_set` of both surfaces, every face cut and asked), and the same boundary, on touching
solids, far from the origin, on objects deep inside a hand whose faces all miss the object's
box (the rays alone see the hand), and on rays that run along the hand's edges."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import trimesh

from exactgrasp.backends.exact.arranged import ArrangedHand, moved_like_the_kernel
from exactgrasp.geometry.level_sets import level_set
from tests.conftest import box_arrays
from tests.touching_meshes import scenes


def _whole(hand, obj, pose):
    """Level 2 of both surfaces, the whole arrangement."""
    moved = moved_like_the_kernel(np.asarray(obj[0], float), pose)
    V = np.concatenate([hand[0], moved])
    F = np.concatenate([hand[1], np.asarray(obj[1], np.int64) + len(hand[0])])
    return level_set(V, F, 2)


def _area_vectors(found, faces: int) -> np.ndarray:
    """Each source face's part of the boundary: the sum of its triangles' area vectors."""
    a, b, c = (found.triangles[:, k] for k in range(3))
    out = np.zeros((faces, 3))
    np.add.at(out, found.sources, 0.5 * np.cross(b - a, c - a))
    return out


def _same_arrangement(hand, obj, pose, arranged=None) -> Fraction:
    """The windowed arrangement's volume and boundary against the whole one's."""
    whole = _whole(hand, obj, pose)
    arranged = ArrangedHand(*hand) if arranged is None else arranged
    volume, bound, window = arranged.volume(np.asarray(obj[0], float), obj[1], pose)
    assert window.volume == whole.volume
    assert volume == float(whole.volume) and bound == float(np.spacing(volume)) / 2
    # The cut faces may be tiled otherwise (other pairs were met): the same parts.
    faces = len(hand[1]) + len(obj[1])
    want, got = (_area_vectors(f, faces) for f in (whole, window))
    scale = np.abs(np.concatenate([hand[0], obj[0]])).max() ** 2
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * scale)
    return whole.volume


def test_the_window_gives_the_whole_arrangement_on_touching_solids():
    ball = trimesh.creation.icosphere(1, radius=0.3)
    ball = (np.asarray(ball.vertices), np.asarray(ball.faces))
    done, positive = 0, 0
    for label, solid, obj, poses, _ in scenes(np.random.default_rng(5), ball, n_ball=2):
        if label.split(", ")[1] not in ("as built", "far from the origin"):
            continue
        if poses is None and not label.endswith(("+ 0", "+ 0.0625")):
            continue
        arranged = ArrangedHand(*solid)
        for pose in np.eye(4)[None] if poses is None else poses:
            positive += _same_arrangement(solid, obj, pose, arranged) > 0
            done += 1
    assert done > 50 and positive > 20


def _grid_box(lo, hi, times: int):
    """An axis-aligned box subdivided ``times`` (4 ** times triangles per two of a side):
    dyadic corners, edges along grid lines and diagonals."""
    mesh = trimesh.Trimesh(*box_arrays(lo, hi), process=False)
    for _ in range(times):
        mesh = mesh.subdivide()
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def test_an_object_deep_inside_the_hand_is_seen_by_the_rays_alone():
    hand = _grid_box([-2.0, -2.0, -2.0], [2.0, 2.0, 2.0], 3)
    ball = trimesh.creation.icosphere(2, radius=0.25)
    obj = (np.asarray(ball.vertices), np.asarray(ball.faces))
    arranged = ArrangedHand(*hand)
    for shift in (0.0, 0.5, -1.0):
        pose = np.eye(4)
        pose[:3, 3] = (shift, 0.25, -shift)
        volume = _same_arrangement(hand, obj, pose, arranged)
        assert (
            volume == Fraction(*ball.volume.as_integer_ratio())
            or abs(float(volume) - ball.volume) <= 1e-15
        )
    # No hand face meets the ball's box: the hand is seen by the rays only.
    corners = hand[0][hand[1]]
    assert not np.any(np.all((corners.min(1) <= 0.5) & (corners.max(1) >= -0.5), axis=1))


@pytest.mark.parametrize("corner", [(-0.5, -0.5, -0.5), (-0.5, -0.5, 1.75), (1.5, -0.5, 0.25)])
def test_rays_along_the_hands_edges(corner):
    # The object's faces' centroids lie on the hand's grid lines ((x0 + 2 x1) / 3 for
    # x0 = -0.5, x1 = 0.25 is 0), so each ray runs along hand edges and through its corners.
    hand = _grid_box([-2.0, -2.0, -2.0], [2.0, 2.0, 2.0], 4)
    obj = box_arrays(np.array(corner), np.array(corner) + 0.75)
    pose = np.eye(4)
    volume = _same_arrangement(hand, obj, pose)
    inside = np.clip(np.array(corner) + 0.75, -2, 2) - np.clip(corner, -2, 2)
    assert volume == Fraction(*float(np.prod(inside)).as_integer_ratio())


@pytest.mark.parametrize("shift", [0.25, 0.5 - 2.0**-40])
def test_the_arranged_hand_on_boxes_reads_the_overlap(shift):
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    pose = np.eye(4)
    pose[0, 3] = shift
    hand = (np.asarray(box.vertices), np.asarray(box.faces))
    volume, bound, _ = ArrangedHand(*hand).volume(hand[0], hand[1], pose)
    assert volume == 1.0 - shift
    assert bound == np.spacing(1.0 - shift) / 2


def _random_hand(rng, shift: float):
    """The solid of one to three boxes on a grid of eighths (overlapping, touching, or
    apart; some subdivided), moved by ``shift``: its boundary, a 2-manifold."""
    from exactgrasp.geometry.exact_solid import solid_boundary

    meshes = []
    for _ in range(int(rng.integers(1, 4))):
        box = trimesh.creation.box(rng.integers(1, 5, 3) / 4)
        box.apply_translation(rng.integers(-4, 5, 3) / 8)
        meshes.append(box.subdivide() if rng.random() < 0.5 else box)
    union = trimesh.util.concatenate(meshes)
    V, F, _ = solid_boundary(np.asarray(union.vertices) + shift, np.asarray(union.faces))
    return V, F


def test_the_window_gives_the_whole_arrangement_on_random_boxes_and_balls():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(7)
    positive = 0
    for _ in range(60):
        shift = float(rng.choice([0.0, 1e3, 12345.5]))
        hand = _random_hand(rng, shift)
        ball = trimesh.creation.icosphere(int(rng.integers(0, 2)), float(rng.uniform(0.05, 0.6)))
        pose = np.eye(4)
        if rng.random() < 0.7:
            pose[:3, :3] = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
        # Half of them on the boxes' grid: the ball's vertices on their faces' planes.
        step = rng.integers(-4, 5, 3) / 8 if rng.random() < 0.5 else rng.uniform(-0.8, 0.8, 3)
        pose[:3, 3] = shift + step
        obj = (np.asarray(ball.vertices), np.asarray(ball.faces))
        positive += _same_arrangement(hand, obj, pose) > 0
    assert positive > 20
