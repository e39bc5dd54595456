"""Volumes under the kernel's certified bound, exactly: slivers one unit in the last place
thick far from the origin and at huge and tiny scales, and a body smaller than the bound inside
the hand, against rational volumes computed by hand; the exact arrangement's level volumes
against rational volumes and CGAL."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import trimesh

from exactgrasp.backends.exact import ExactIntersector
from exactgrasp.backends.exact.arranged import moved_like_the_kernel
from exactgrasp.geometry.level_sets import level_set
from tests.conftest import box_arrays
from tests.exact_reference import cgal_intersection, rational_volume


def box_overlap(lo_a, hi_a, lo_b, hi_b) -> Fraction:
    """The exact volume of two axis-aligned boxes' overlap."""
    sides = [
        max(Fraction(0), min(Fraction(ha), Fraction(hb)) - max(Fraction(la), Fraction(lb)))
        for la, ha, lb, hb in zip(lo_a, hi_a, lo_b, hi_b, strict=True)
    ]
    return sides[0] * sides[1] * sides[2]


def ulps_below(x: float, k: int) -> float:
    for _ in range(k):
        x = float(np.nextafter(x, -np.inf))
    return x


@pytest.mark.parametrize("where", [0.0, 0.3, 700.3, -9.1e5])
@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
@pytest.mark.parametrize("ulps", [1, 5])
def test_a_sliver_some_units_in_the_last_place_thick_has_its_exact_volume(where, scale, ulps):
    lo = np.array([where, where + 0.5 * scale, where - 0.25 * scale])
    hi = lo + np.array([1.0, 0.75, 0.5]) * scale
    lo_b = np.array([ulps_below(hi[0], ulps), lo[1] + 0.2 * scale, lo[2] + 0.1 * scale])
    hi_b = lo_b + np.array([1.0, 0.3, 0.2]) * scale
    want = box_overlap(lo, hi, lo_b, hi_b)
    hand = box_arrays(lo, hi)
    result = ExactIntersector([hand], [box_arrays(lo_b, hi_b)]).intersect(np.eye(4)[None])
    assert want > 0
    error = abs(Fraction(result.volumes[0]) - want)
    assert error <= Fraction(result.volume_bounds[0])
    # The rule "exact" is held to: 1e-9 of the volume, or of 1e-6 of the hand's volume.
    assert error <= Fraction(1e-9) * max(want, Fraction(1e-6) * rational_volume(*hand))
    if abs(where) > 1 and result.pose_sources[0] == "arrangement":
        # Far from the origin every shift to local coordinates is exact (Sterbenz): nothing
        # is left to rounding, and the sliver, thinner than the kernel's bound, is exact.
        assert result.volumes[0] == float(want)


def test_far_slivers_go_to_the_arrangement_and_others_stay_in_the_kernel():
    lo = np.array([700.3, 650.1, 812.7])
    hi = lo + np.array([1.0, 0.75, 0.5])
    thin = np.array([ulps_below(hi[0], 1), lo[1] + 0.2, lo[2] + 0.1])
    deep = np.array([hi[0] - 0.25, lo[1] + 0.2, lo[2] + 0.1])
    ex = ExactIntersector(
        [box_arrays(lo, hi)], [box_arrays(thin, thin + np.array([1.0, 0.3, 0.2]))]
    )
    shift = np.eye(4)
    shift[0, 3] = deep[0] - thin[0]
    result = ex.intersect(np.stack([np.eye(4), shift]))
    assert result.pose_sources.tolist() == ["arrangement", "kernel"]
    assert result.stats["poses_arranged"] == 1
    assert result.volumes[1] == pytest.approx(0.25 * 0.3 * 0.2, rel=1e-12)


def test_a_body_smaller_than_the_bound_inside_the_hand_is_not_read_as_zero():
    side = 2.0**-20
    lo = np.array([0.25, 0.5, 0.375])
    result = ExactIntersector([box_arrays([0, 0, 0], [1, 1, 1])], [box_arrays(lo, lo + side)])
    got = result.intersect(np.eye(4)[None])
    assert got.volumes[0] == side**3
    assert got.pose_sources[0] in ("kernel", "arrangement")


def test_level_volumes_of_overlapping_boxes_are_rational_volumes():
    a = box_arrays([0, 0, 0], [1, 1, 1])
    b = box_arrays([0.5, 0.25, -0.5], [1.5, 0.75, 0.5])
    V = np.concatenate([a[0], b[0]])
    F = np.concatenate([a[1], b[1] + len(a[0])])
    assert level_set(V, F, 2).volume == Fraction(1, 8)
    assert level_set(V, F, 1).volume == rational_volume(*a) + rational_volume(*b) - Fraction(1, 8)
    # Touching along a face, the same way and opposite ways.
    c = box_arrays([1, 0, 0], [2, 1, 1])
    V = np.concatenate([a[0], c[0]])
    F = np.concatenate([a[1], c[1] + len(a[0])])
    assert level_set(V, F, 2).volume == 0
    assert level_set(V, F, 1).volume == 2


@pytest.mark.parametrize("seed", range(4))
def test_level_volumes_of_a_ball_and_a_link_agree_with_cgal(seed):
    pytest.importorskip("igl.copyleft.cgal", reason="libigl (the dev extra) not installed")
    rng = np.random.default_rng(seed)
    ball = trimesh.creation.icosphere(1, radius=0.4)
    hand = trimesh.creation.capsule(1.0, 0.3, count=[8, 8])
    pose = np.eye(4)
    pose[:3, :3] = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
    pose[:3, 3] = rng.uniform(-0.5, 0.5, 3)
    moved = moved_like_the_kernel(np.asarray(ball.vertices), pose)
    V = np.concatenate([hand.vertices, moved])
    F = np.concatenate([hand.faces, ball.faces + len(hand.vertices)])
    want, rounding = cgal_intersection((hand.vertices, hand.faces), (moved, ball.faces))
    assert want > 1e-3
    assert abs(float(level_set(V, F, 2).volume) - want) <= 1e-12 * want + rounding
