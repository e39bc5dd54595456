"""The exact fallback's search for contacts split in two: the pairs of the hand's own faces
found once (`ArrangedHand.contacts`), the pairs with an object face searched at each pose
(`crossings.find_contacts_near`). The pairs are `find_contacts`' own, and the arrangement,
its volume and its triangles are the same as with every pair searched at once."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from exactgrasp.backends.exact.arranged import ArrangedHand, arranged_volume
from exactgrasp.geometry.crossings import find_contacts, find_contacts_near
from tests.touching_meshes import scenes

GOLDEN = np.load("tests/kernel_goldens/numba_crossings.npz")
CASES = sorted(
    k[:-2] for k in GOLDEN if k.endswith("/V") and k.split("/")[0] in ("built", "fuzz", "intake")
)


def _pairs(t: np.ndarray, u: np.ndarray) -> set[tuple[int, int]]:
    return set(zip(np.minimum(t, u).tolist(), np.maximum(t, u).tolist(), strict=True))


def test_contacts_near_are_find_contacts_pairs():
    across = 0
    for case in CASES:
        V, F, ident = (GOLDEN[f"{case}/{k}"] for k in ("V", "F", "ident"))
        if len(F) < 2:
            continue
        want = _pairs(*find_contacts(V, F, ident))
        for first in sorted({1, len(F) // 3, len(F) // 2, len(F) - 1}):
            known = find_contacts(V, F[:first], ident)
            t, u = find_contacts_near(V, F, ident, first, known)
            assert _pairs(t, u) == want, (case, first)
            assert len(t) == len(want) and np.all(t < u)
            assert np.all(np.diff(t * len(F) + u) > 0), "sorted by t, then u"
            across += sum((a < first) != (b < first) for a, b in want)
    # The split cuts through many contacts: the pairs searched at each pose are not empty.
    assert across > 1000


def _area_vectors(found, faces: int) -> np.ndarray:
    """Each source face's part of the boundary: the sum of its triangles' area vectors."""
    a, b, c = (found.triangles[:, k] for k in range(3))
    out = np.zeros((faces, 3))
    np.add.at(out, found.sources, 0.5 * np.cross(b - a, c - a))
    return out


def _same_arrangement(hand, obj, pose) -> None:
    whole = arranged_volume(hand[0], hand[1], obj[0], obj[1], pose, 1e-18, 2.0)
    split = ArrangedHand(*hand).volume(obj[0], obj[1], pose, 1e-18, 2.0)
    # The volume is exact, then rounded once: the same bits.
    assert whole[:2] == split[:2]
    assert whole[2].volume == split[2].volume
    # The cut faces may be tiled otherwise (the pairs met in another order): the same parts.
    faces = len(hand[1]) + len(obj[1])
    want, got = (_area_vectors(f[2], faces) for f in (whole, split))
    scale = np.abs(np.concatenate([hand[0], obj[0]])).max() ** 2
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * scale)


def test_the_arranged_hand_gives_the_whole_arrangement():
    ball = trimesh.creation.icosphere(1, radius=0.3)
    ball = (np.asarray(ball.vertices), np.asarray(ball.faces))
    done = 0
    for label, solid, obj, poses, _ in scenes(np.random.default_rng(5), ball, n_ball=2):
        if label.split(", ")[1] not in ("as built", "far from the origin"):
            continue
        if poses is None and not label.endswith(("+ 0", "+ 0.0625")):
            continue
        for pose in np.eye(4)[None] if poses is None else poses:
            _same_arrangement(solid, obj, pose)
            done += 1
    assert done > 50


def test_the_arranged_hand_keeps_its_own_contacts_from_the_first_pose():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    ball = trimesh.creation.icosphere(2, radius=0.4)
    hand = ArrangedHand(np.asarray(box.vertices), np.asarray(box.faces))
    assert hand.contacts is None
    poses = np.tile(np.eye(4), (3, 1, 1))
    poses[:, 0, 3] = (0.5, 0.55, 0.3)
    for pose in poses:
        _same_arrangement((hand.vertices, hand.faces), (ball.vertices, ball.faces), pose)
        got = hand.volume(np.asarray(ball.vertices), np.asarray(ball.faces), pose)
        whole = arranged_volume(hand.vertices, hand.faces, ball.vertices, ball.faces, pose)
        assert got[:2] == whole[:2] and got[0] > 0.0
    # The box's own faces meet only along the edges and corners they share.
    t, u = hand.contacts
    assert len(t) == len(u) and set(zip(t.tolist(), u.tolist(), strict=True)) <= set(
        zip(*find_contacts(box.vertices, box.faces, np.arange(8)), strict=True)
    )


@pytest.mark.parametrize("shift", [0.25, 0.5 - 2.0**-40])
def test_the_arranged_hand_on_boxes_reads_the_overlap(shift):
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    pose = np.eye(4)
    pose[0, 3] = shift
    hand = (np.asarray(box.vertices), np.asarray(box.faces))
    volume, bound, _ = ArrangedHand(*hand).volume(hand[0], hand[1], pose)
    assert volume == 1.0 - shift
    assert bound == np.spacing(1.0 - shift) / 2
