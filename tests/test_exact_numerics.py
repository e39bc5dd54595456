"""Numerical robustness of the exact backend: position, slivers, signs, scale.

References are independent of the backend: scipy's half-space intersection, analytic volumes
and exact rational arithmetic (`fractions.Fraction`) where manifold3d itself rounds a small
volume away.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_exact import box, halfspace_volume, hull, moved, rigid, sphere

from exactgrasp.backends.exact import ExactIntersector
from tests.exact_reference import cgal_intersection

#: Outward unit normal of the sliver hand's slanted face x + 2y + 3z = 6.
SLANT = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
#: The object tetrahedron of the sliver tests: face Q0 Q1 Q2 exactly on the slanted plane.
TETRA = np.array([[2.5, 0.25, 1.0], [4.0, 0.25, 0.5], [2.5, 1.0, 0.5], [3.5, 1.5, 2.0]])


def sliver_hand(step):
    """A tetrahedron (0, 6 e_x, 3 e_y, 2 e_z) whose slanted face is split at (1, 1, 1) and at
    a vertex ``19.4 step`` off the segment from (1, 1, 1) to (6, 0, 0), exactly on the plane
    (``step`` a power of two): the face (6, 0, 0), (1, 1, 1), that vertex is a sliver."""
    V = np.array(
        [
            [0.0, 0, 0],
            [6.0, 0, 0],
            [0, 3.0, 0],
            [0, 0, 2.0],
            [1.0, 1, 1],
            [3.5 + step, 0.5 + 16 * step, 0.5 - 11 * step],
        ]
    )
    F = np.array(
        [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 5], [2, 4, 5], [4, 1, 5], [2, 3, 4], [3, 1, 4]]
    )
    return V, F


def slab_volume(depth):
    """Volume of the object tetrahedron within ``depth`` of its face on the slanted plane."""
    height = (TETRA[3] @ (SLANT * np.sqrt(14.0)) - 6.0) / np.sqrt(14.0)
    tet = abs(np.linalg.det(TETRA[1:] - TETRA[0])) / 6.0
    return tet * (1.0 - (1.0 - depth / height) ** 3)


def translations(vectors):
    P = np.tile(np.eye(4), (len(vectors), 1, 1))
    P[:, :3, 3] = vectors
    return P


def test_accuracy_does_not_depend_on_position():
    rng = np.random.default_rng(7)
    A = hull(rng.normal(size=(40, 3)))
    B = hull(rng.normal(size=(30, 3)) * [1.5, 0.7, 1.0])
    P = rigid(rng, 6, tmax=1.0)
    want = np.array([halfspace_volume(A[0], moved(B[0], p)) for p in P])
    assert (want > 1.0).all()
    for offset in (0.0, 1.0, 10.0, 100.0, 1e3):
        o = np.array([1.0, -0.6, 0.3]) * offset
        T, Ti = np.eye(4), np.eye(4)
        T[:3, 3], Ti[:3, 3] = o, -o
        ex = ExactIntersector([(A[0] + o, A[1])], [(B[0] + o, B[1])], broadphase="coal")
        result = ex.intersect(T @ P @ Ti)
        got = result.volumes
        # Measured 5e-14 at 1e3 (the inputs' own rounding there), 2e-16 at the origin.
        assert np.abs(got - want).max() <= 1e-11 * want.max(), offset
        assert result.stats["poses_limit"] == 0


@pytest.mark.parametrize("step", [2.0**-30, 2.0**-44])  # 1.8e-8 and 1.1e-12 off the edge
def test_sliver_hand_touching_is_exactly_zero_and_penetrating_is_analytic(step):
    hand = sliver_hand(step)
    obj = hull(TETRA)
    ex = ExactIntersector([hand], [obj], broadphase=None)
    touching = ex.volumes(translations([0 * SLANT, 1e-15 * SLANT, 1e-9 * SLANT]))
    assert touching.tolist() == [0.0, 0.0, 0.0]
    depths = np.array([1e-3, 1e-4, 1e-5, 1e-6])
    got = ex.volumes(translations(-depths[:, None] * SLANT))
    want = np.array([slab_volume(d) for d in depths])
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=0)


@pytest.mark.parametrize("seed", range(4))
def test_rotated_sliver_hand_contacts_are_exactly_zero(seed):
    """The same scene under a generic rotation: the faces' cross products round, the sliver's
    normal is off by about eps / 1e-8, and the rotated vertices round apart or into each
    other. The contacts (face on face, a vertex on the sliver face) read the exact volume of
    the rounded scene: 0, or a sliver of rounding (CGAL's, within the rounding of its
    output), and exactly 0 once moved apart by 1e-12."""
    R = Rotation.random(random_state=seed).as_matrix()
    hand = sliver_hand(2.0**-30)
    hand = (hand[0] @ R.T, hand[1])
    tip = [3.5 + 2.0**-31, 0.5 + 16 * 2.0**-31, 0.5 - 11 * 2.0**-31]  # inside the sliver face
    vertex = hull(np.array([tip, [4.5, 2, 2], [3, 3, 2], [4, 1, 3]]))
    n = R @ SLANT
    for obj in (hull(TETRA), vertex):
        turned = (obj[0] @ R.T, obj[1])
        ex = ExactIntersector([hand], [turned], broadphase=None)
        got = ex.intersect(translations([0 * n, 1e-15 * n, -1e-15 * n, 1e-12 * n]))
        assert (got.volumes[:3] <= 1e-16 * ex.hand_volume).all() and got.volumes[3] == 0
        want, rounding = cgal_intersection(hand, turned)
        assert abs(got.volumes[0] - want) <= rounding + got.volume_bounds[0]
    ex = ExactIntersector([hand], [(TETRA @ R.T, hull(TETRA)[1])], broadphase=None)
    depths = np.array([1e-3, 1e-5])
    got = ex.volumes(translations(-depths[:, None] * n))
    np.testing.assert_allclose(got, [slab_volume(d) for d in depths], rtol=1e-9, atol=0)


def test_no_negative_volume_and_contacts_exactly_zero():
    rng = np.random.default_rng(3)
    hand = sphere(1.0, np.zeros(3), 2)
    obj = hull(rng.normal(size=(30, 3)) * 0.7)
    ex = ExactIntersector([hand], [obj], broadphase="coal")
    v = ex.volumes(rigid(rng, 300, tmax=1.8))
    assert (v >= 0).all() and (v > 0).sum() > 100 and (v == 0).sum() > 10
    # Vertex contacts with a box face: the object's lowest vertex along x put on x = 1, or
    # within 1e-15 of it. The true volume is a tip 1e-15 deep at most, below the rounding of
    # the rotated scene: it must read exactly 0.
    cube = box([0, 0, 0], [1, 1, 1])
    ex = ExactIntersector([cube], [obj], broadphase="coal")
    P = rigid(rng, 60, tmax=0.0)
    for i, p in enumerate(P):
        x = moved(obj[0], p)
        k = np.argmin(x[:, 0])
        p[:3, 3] = [1.0 - x[k, 0], 0.5 - x[k, 1], 0.5 - x[k, 2]]
        p[0, 3] += (0.0, 1e-15, -1e-15)[i % 3]
    got = ex.volumes(P)
    assert got.tolist() == [0.0] * len(P)


@pytest.mark.parametrize("scale", [1e3, 1e-3])
def test_huge_and_tiny_scales_match_reference(scale):
    rng = np.random.default_rng(11)
    A = hull(rng.normal(size=(40, 3)))
    B = sphere(0.9, np.array([0.3, -0.2, 0.1]), 2)
    P = rigid(rng, 5, tmax=0.8)
    want = np.array([halfspace_volume(A[0], moved(B[0], p)) for p in P]) * scale**3
    Ps = P.copy()
    Ps[:, :3, 3] *= scale
    ex = ExactIntersector([(A[0] * scale, A[1])], [(B[0] * scale, B[1])], broadphase="coal")
    got = ex.volumes(Ps)
    assert (want > 0.1 * scale**3).all()
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=0)


def test_tiny_box_overlaps_match_exact_rationals():
    """Boxes overlapping by 1e-14 to 1e-8 along x: manifold3d reads 1e-14 to 1e-12 as 0; the
    reference is the overlap of the boxes as given, in exact rational arithmetic. Above the
    certified error bound (about 1e-12 for this unit-sized scene) a volume agrees with it to
    1e-9 (`agrees`: relative, floored at 1e-6 of the hand's volume); below it, it reads
    exactly 0, never a negative or a spurious value."""
    hand = box([0, 0, 0], [1, 1, 1])
    for overlap in (1e-14, 1e-13, 1e-12, 3e-12, 1e-10, 1e-8):
        lo = 1.0 - overlap
        want = (Fraction(1) - Fraction(lo)) * Fraction(1, 4)
        obj = box([lo, 0.25, 0.25], [2.0, 0.75, 0.75])
        got = float(ExactIntersector([hand], [obj], broadphase=None).volumes(np.eye(4)))
        close = abs(Fraction(got) - want) <= max(want, Fraction(1, 10**6)) / 10**9
        assert close or (got == 0.0 and want < Fraction(1, 10**12)), overlap


@pytest.mark.parametrize("n", [0, 1, 2, 7, 300])
@pytest.mark.parametrize("high", [1, 4, 10**6])
def test_crossed_edges_are_grouped_in_numpys_stable_order(n, high):
    # The crossed-edge sum groups records by edge with its own heap sort; ties must keep
    # record order, as numpy's stable sort does.
    from exactgrasp.backends.exact._stages import order_by_key

    keys = np.random.default_rng(n + high).integers(0, high, n).astype(np.int64)
    assert np.array_equal(order_by_key(keys), np.argsort(keys, kind="stable"))


def test_hand_vertex_near_a_cell_boundary_is_unknown_when_the_inverse_errs_more():
    # Hand vertices reach the object's grid through R^T, which errs by R's departure from a
    # rotation: a vertex that close to a surface cell may truly lie in it.
    from exactgrasp.backends.exact._stages import hand_statuses
    from exactgrasp.backends.exact.grids import build_grid
    from exactgrasp.backends.exact.tolerances import GRID_MARGIN

    V, F = box(np.zeros(3), np.ones(3))
    h = 0.25
    grid = build_grid(V, F, h)
    n = grid.shape
    status = grid.status.reshape(tuple(n))
    # A known cell beside a surface cell along x, and a point just inside it at their face.
    i, j, k = np.argwhere((status[:-1] >= 0) & (status[1:] < 0))[0]
    point = grid.corner + (np.array([i + 1, j + 0.5, k + 0.5])) * h - [1e-7 * h, 0, 0]
    eye, zero = np.eye(3), np.zeros(3)
    for err, want_status, want_uniform in (
        (0.0, status[i, j, k], True),
        (0.5 * GRID_MARGIN * h, status[i, j, k], True),
        (1e-6 * h, -1, False),
    ):
        S = np.full(1, -7, np.int8)
        uniform = np.zeros(1, np.bool_)
        reps = np.array([[0, 0], [-1, 1]], np.int64)
        hand_statuses(
            S, point[None].copy(), eye, zero, grid, reps, np.zeros(1, np.bool_), True, uniform,
            err,
        )  # fmt: skip
        assert (S[0], uniform[0]) == (want_status, want_uniform), err


@pytest.mark.parametrize("seed", [0, 1])
def test_nearly_rigid_poses_match_the_boolean_of_the_same_matrices(seed):
    # Poses up to 1e-9 from a rotation are accepted; the kernel then works with R^T for the
    # inverse, and must still agree with manifold3d applying the matrices as given.
    from exactgrasp.backends.exact import agrees, plain_volumes

    rng = np.random.default_rng(seed)
    hand = [
        box(np.array([-0.6, -0.6, -0.1]), np.array([0.6, 0.6, 0.1])),
        sphere(0.4, np.array([0.0, 0.0, 0.5]), 2),
    ]
    obj = [sphere(0.5, np.zeros(3), 2)]
    P = rigid(rng, 12, tmax=0.6)
    # Orthonormal to 6e-10 and of determinant within 9e-10 of 1: accepted.
    P[:, :3, :3] *= 1.0 + 3e-10 * rng.uniform(-1.0, 1.0, (12, 1, 1))
    ex = ExactIntersector(hand, obj, broadphase=None)
    result = ex.intersect(P)
    got = result.volumes
    want = plain_volumes(hand, obj, P)
    assert (got > 0).sum() >= 6
    assert agrees(got, want, ex.hand_volume).all()
    assert (np.abs(got - want) <= result.volume_bounds + 1e-9 * ex.hand_volume).all()
