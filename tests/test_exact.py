"""Tests of the exact backend (`exactgrasp.backends.exact`)."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection
from scipy.spatial.transform import Rotation

from exactgrasp.backends.exact import (
    ExactBackend,
    ExactIntersector,
    agrees,
    plain_volumes,
    repeated_poses,
)
from exactgrasp.backends.registry import get_backend
from exactgrasp.datapath import data_dir
from exactgrasp.errors import BackendError, MeshError, MissingDependencyError

DATA = data_dir()


def box(lo, hi):
    """Closed, outward-oriented box mesh."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    V = np.array(
        [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    )
    F = ConvexHull(V).simplices
    return orient_outward(V, F)


def orient_outward(V, F):
    """Flip hull triangles so that their normals point away from the centroid."""
    F = np.array(F, np.int64)
    c = V.mean(0)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    flip = np.einsum("ij,ij->i", n, V[F[:, 0]] - c) < 0
    F[flip] = F[flip][:, ::-1]
    return V, F


def hull(points):
    points = np.asarray(points, float)
    h = ConvexHull(points)
    used = np.unique(h.simplices)
    remap = np.full(len(points), -1)
    remap[used] = np.arange(len(used))
    return orient_outward(points[used], remap[h.simplices])


def sphere(r, centre, subdivisions):
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=r)
    return np.asarray(s.vertices) + centre, np.asarray(s.faces, np.int64)


def rigid(rng, n, tmax=1.0):
    P = np.tile(np.eye(4), (n, 1, 1))
    P[:, :3, :3] = Rotation.random(n, random_state=rng).as_matrix()
    P[:, :3, 3] = rng.uniform(-tmax, tmax, (n, 3))
    return P


def moved(V, P):
    return V @ P[:3, :3].T + P[:3, 3]


def halfspace_volume(Va, Vb):
    """Volume of the intersection of two convex hulls with scipy only (independent check)."""
    eqs = np.vstack([ConvexHull(Va).equations, ConvexHull(Vb).equations])
    # Chebyshev centre: the point deepest inside both.
    norm = np.linalg.norm(eqs[:, :3], axis=1)
    res = linprog(
        [0, 0, 0, -1],
        A_ub=np.hstack([eqs[:, :3], norm[:, None]]),
        b_ub=-eqs[:, 3],
        bounds=[(None, None)] * 3 + [(0, None)],
    )
    if res.x[3] <= 1e-9:
        return 0.0
    pts = HalfspaceIntersection(eqs, res.x[:3]).intersections
    return ConvexHull(pts).volume


def test_boxes_match_analytic_overlap():
    rng = np.random.default_rng(1)
    for _ in range(4):
        lo_a, lo_b = rng.uniform(-1, 0, 3), rng.uniform(-1, 0, 3)
        hi_a, hi_b = lo_a + rng.uniform(0.5, 1.5, 3), lo_b + rng.uniform(0.5, 1.5, 3)
        ex = ExactIntersector([box(lo_a, hi_a)], [box(lo_b, hi_b)], broadphase=None)
        shifts = np.tile(np.eye(4), (5, 1, 1))
        shifts[:, :3, 3] = rng.uniform(-1, 1, (5, 3))
        got = ex.volumes(shifts)
        for v, t in zip(got, shifts[:, :3, 3], strict=True):
            overlap = np.minimum(hi_a, hi_b + t) - np.maximum(lo_a, lo_b + t)
            want = np.prod(np.clip(overlap, 0, None))
            assert abs(v - want) <= 1e-12 * max(want, 1.0)


def test_coincident_faces_fall_back_to_the_boolean():
    # Shared face planes make orientation signs zero: the pose is recomputed by manifold3d.
    ex = ExactIntersector(
        [box([0, 0, 0], [1, 1, 1])], [box([0, 0, 0], [1, 1, 1])], broadphase=None
    )
    P = np.tile(np.eye(4), (2, 1, 1))
    P[1, :3, 3] = [0.5, 0, 0]
    result = ex.intersect(P)
    assert np.allclose(result.volumes, [1.0, 0.5], rtol=1e-12, atol=0)
    assert result.stats["poses_limit"] == 2


def test_pose_sources_and_bounds_say_where_each_volume_came_from():
    hand = [box([0, 0, 0], [1, 1, 1])]
    obj = [sphere(0.3, np.zeros(3), 2)]
    P = np.tile(np.eye(4), (3, 1, 1))
    P[0, :3, 3] = [0.5, 0.5, 0.5]  # inside the hand: the kernel
    P[1, :3, 3] = [0.5, 0.5, 5.0]  # far away: culled, exactly 0
    # At the corner, where the sphere's vertices lie on the box's face planes: the boolean.
    ex = ExactIntersector(hand, obj, broadphase="coal")
    result = ex.intersect(P)
    got, bounds = result.volumes, result.volume_bounds
    ex2 = ExactIntersector(hand, [box([0, 0, 0], [1, 1, 1])], broadphase=None)
    one = ex2.intersect(np.eye(4))  # coincident faces: the boolean
    assert list(result.pose_sources) == ["kernel", "culled", "limit"]
    assert got[1] == 0.0 and bounds[1] == 0.0
    assert 0 < bounds[0] < 1e-12 * got[0]
    assert bounds[2] > bounds[0]
    np.testing.assert_allclose(got[2], got[0] / 8, rtol=1e-9)  # an eighth of the sphere
    assert one.pose_sources.tolist() == "limit" and one.volume_bounds > 0
    # Each call returns its own result; the intersector keeps none of them.
    assert result.pose_sources.shape == (3,) and ex.intersect(P[:1]).pose_sources.shape == (1,)
    assert not {"stats", "pose_sources", "volume_bounds"} & set(vars(ex))


def test_a_full_crossing_buffer_falls_back_to_the_boolean():
    from exactgrasp.backends.exact import plain_volumes

    hand = [box([0, 0, 0], [1, 1, 1])]
    obj = [sphere(0.3, np.zeros(3), 2)]
    P = np.eye(4)
    P[:3, 3] = [0.9, 0.5, 0.5]  # the sphere crosses the hand's face x = 1
    small = ExactIntersector(hand, obj, broadphase=None, capacity=1)
    result = small.intersect(P[None])
    got = result.volumes
    assert result.stats["poses_limit"] == 1 and result.pose_sources.tolist() == ["limit"]
    want = plain_volumes(hand, obj, P[None])
    np.testing.assert_allclose(got, want, rtol=1e-9)
    full = ExactIntersector(hand, obj, broadphase=None)
    result = full.intersect(P[None])
    np.testing.assert_allclose(result.volumes, want, rtol=1e-9)
    assert result.stats["poses_limit"] == 0


def test_crossing_records_grown_pose_by_pose_give_the_same_volumes(monkeypatch):
    # The crossing records start small and double, up to the capacity, when a pose fills
    # them (the pose is computed again): the same volumes to the bit, and a pose needing more
    # than the capacity still goes to the limit.
    from exactgrasp.backends.exact import _kernel

    hand = [box([0, 0, 0], [1, 1, 1])]
    obj = [sphere(0.3, np.zeros(3), 3)]
    poses = np.tile(np.eye(4), (3, 1, 1))
    poses[:, :3, 3] = [[0.9, 0.5, 0.5], [0.5, 0.9, 0.5], [0.5, 0.5, 0.5]]
    want = ExactIntersector(hand, obj, broadphase=None).intersect(poses)
    assert want.volumes.min() > 0 and want.stats["poses_limit"] == 0
    monkeypatch.setattr(_kernel, "CROSSINGS", 2)
    grown = ExactIntersector(hand, obj, broadphase=None).intersect(poses)
    np.testing.assert_array_equal(grown.volumes, want.volumes)
    np.testing.assert_array_equal(grown.volume_bounds, want.volume_bounds)
    assert grown.stats["poses_limit"] == 0
    small = ExactIntersector(hand, obj, broadphase=None, capacity=4).intersect(poses)
    assert small.pose_sources.tolist()[:2] == ["limit", "limit"]


def test_edges_passing_near_each_other_match_the_boolean():
    # An object edge passing within `gap` of a hand edge puts the ends of two faces' crossing
    # segments within rounding of each other: the floating-point decision on the planes'
    # common line must hand such pairs to the exact test (or the boolean), never guess.
    hand = box([0, 0, 0], [1, 1, 1])
    obj = box([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5])
    R = Rotation.from_euler("xyz", [45, 30, 10], degrees=True).as_matrix()
    mid = R @ np.array([0.0, -0.5, -0.5])  # midpoint of the object's edge along x
    gaps = (0.0, 1e-15, 1e-13, 1e-11, 1e-9, 1e-6, 1e-3)
    P = np.tile(np.eye(4), (len(gaps), 1, 1))
    P[:, :3, :3] = R
    for i, g in enumerate(gaps):
        P[i, :3, 3] = np.array([0.5, g, 0.0]) - mid
    ex = ExactIntersector([hand], [obj], broadphase=None)
    got = ex.volumes(P)
    want = plain_volumes([hand], [obj], P)
    assert np.all(want > 0.01)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=0)


def test_random_convex_polytopes_match_halfspace_intersection():
    rng = np.random.default_rng(7)
    for _ in range(6):
        A = hull(rng.normal(size=(40, 3)))
        B = hull(rng.normal(size=(30, 3)) * [1.5, 0.7, 1.0])
        ex = ExactIntersector([A], [B], broadphase=None)
        P = rigid(rng, 4, tmax=1.5)
        result = ex.intersect(P)
        got = result.volumes
        assert result.stats["poses_limit"] == 0  # the certified fast path decided every pose
        for v, p in zip(got, P, strict=True):
            want = halfspace_volume(A[0], moved(B[0], p))
            assert abs(v - want) <= 1e-9 * max(want, 1e-6 * ex.hand_volume)


def test_two_spheres_converge_to_lens_formula():
    r1, r2, d = 1.0, 0.8, 1.2
    lens = (
        np.pi
        * (r1 + r2 - d) ** 2
        * (d**2 + 2 * d * r2 - 3 * r2**2 + 2 * d * r1 + 6 * r1 * r2 - 3 * r1**2)
        / (12 * d)
    )
    errors = []
    for sub in (1, 2, 3, 4):
        a = sphere(r1, [0, 0, 0], sub)
        b = sphere(r2, [0, 0, 0], sub)
        P = np.eye(4)
        P[:3, :3] = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix()
        P[:3, 3] = [d, 0, 0]
        errors.append(abs(ExactIntersector([a], [b], broadphase=None).volumes(P) - lens) / lens)
    assert all(e2 < e1 for e1, e2 in itertools.pairwise(errors))
    assert errors[-1] < 5e-3


def overlapping_hand():
    """Two overlapping link boxes (overlap 0.5 x 1 x 1) and a wedge-shaped object."""
    links = [box([0, 0, 0], [2, 1, 1]), box([1.5, 0, 0], [3, 1, 1])]
    obj = hull(np.random.default_rng(3).normal(size=(25, 3)) * 0.8 + [1.7, 0.5, 0.5])
    return links, [obj]


def test_overlapping_links_count_once_and_match_plain_boolean():
    links, objs = overlapping_hand()
    ex = ExactIntersector(links, objs, broadphase=None)
    assert ex.hand_volume == pytest.approx(3.0, rel=1e-12)
    rng = np.random.default_rng(5)
    P = rigid(rng, 6, tmax=0.3)
    P[0] = np.eye(4)
    got = ex.volumes(P)
    ref = plain_volumes(links, objs, P)
    assert agrees(got, ref, ex.hand_volume).all()
    # Summing per-link booleans would count the overlap twice.
    per_link = sum(plain_volumes([lk], objs, P[:1])[0] for lk in links)
    assert per_link > got[0] + 1e-3


def test_no_overlap_gives_exactly_zero():
    links, objs = overlapping_hand()
    P = np.eye(4)[None].repeat(2, 0)
    P[:, :3, 3] = [[10.0, 0, 0], [0, 0.0, 6.0]]
    for bp in (None, "coal", "fcl"):
        ex = ExactIntersector(links, objs, broadphase=bp)
        result = ex.intersect(P)
        assert result.volumes.tolist() == [0.0, 0.0]
    assert result.stats["poses_culled"] == 2


def test_culling_off_coal_fcl_and_n_jobs_give_identical_volumes():
    links, objs = overlapping_hand()
    rng = np.random.default_rng(11)
    P = rigid(rng, 12, tmax=3.0)
    results = {}
    for bp in (None, "coal", "fcl"):
        for jobs in (1, 2):
            results[bp, jobs] = ExactIntersector(links, objs, broadphase=bp, n_jobs=jobs).volumes(
                P
            )
    base = results[None, 1]
    assert (base > 0).any() and (base == 0).any()
    for v in results.values():
        np.testing.assert_array_equal(v, base)


def test_poses_equal_to_rounding_are_computed_once():
    links, objs = overlapping_hand()
    rng = np.random.default_rng(3)
    P = rigid(rng, 4, tmax=0.3)
    # A rotation by a about w is a rotation by -a about -w: equal up to rounding.
    w, a = np.array([0.2, -0.5, 0.84]), 0.7
    w /= np.linalg.norm(w)
    P[2, :3, :3] = Rotation.from_rotvec(a * w).as_matrix()
    P[3, :3, :3] = Rotation.from_rotvec(-a * -w).as_matrix()
    P[3, :3, 3] = P[2, :3, 3]
    one_ulp = P[0].copy()
    one_ulp[0, 3] = np.nextafter(one_ulp[0, 3], np.inf)
    far = P[0].copy()
    far[0, 3] += 1e-12  # thousands of ulps: a different pose
    poses = np.concatenate([P, P[:1], one_ulp[None], far[None]])
    assert repeated_poses(poses).tolist()[4:] == [0, 0, 6]
    assert repeated_poses(poses)[3] in (2, 3)
    ex = ExactIntersector(links, objs, broadphase=None)
    result = ex.intersect(poses)
    got = result.volumes
    assert result.stats["poses"] == 7
    assert result.stats["poses_repeated"] == 2 + (repeated_poses(poses)[3] == 2)
    alone = np.array([ex.volumes(p[None])[0] for p in poses])
    assert agrees(got, alone, ex.hand_volume, rtol=1e-12).all()
    assert got[4] == got[0] and got[5] == got[0]
    ref = plain_volumes(links, objs, poses)
    assert agrees(got, ref, ex.hand_volume).all()


def corner_dip():
    """A box hand (top face z = 0) and a unit cube tilted so that one corner points down:
    ``pose(d)`` dips that corner to depth d; the overlap is then the simplex of volume
    ``d³ / (6 c1 c2 c3)`` (``c`` the cube's edge directions' z components), an analytic
    reference at every depth below the shortest edge's reach."""
    R = (
        Rotation.from_rotvec([0.15, -0.1, 0.3]).as_matrix()
        @ Rotation.align_vectors([[0, 0, 1]], [[1, 1, 1]])[0].as_matrix()
    )
    c = R[2]
    assert (c > 0.2).all()

    def pose(d):
        P = np.eye(4)
        P[:3, :3] = R
        P[:3, 3] = [0.1, -0.2, -d]
        return P

    def volume(d):
        return d**3 / (6.0 * c[0] * c[1] * c[2])

    return [box([-1, -1, -1], [1, 1, 0])], [box([0, 0, 0], [1, 1, 1])], pose, volume


def test_overlaps_thinner_than_the_bound_are_arranged_exactly_and_every_depth_agrees():
    hand, obj, pose, volume = corner_dip()
    ex = ExactIntersector(hand, obj, broadphase=None)
    depths = 10.0 ** -np.arange(1.0, 7.5, 0.25)
    result = ex.intersect(np.stack([pose(d) for d in depths]))
    got, bound, want = result.volumes, result.volume_bounds, volume(depths)
    # Overlaps above the kernel's bound come from the kernel; those within it from the exact
    # arrangement, which reads 0 only below the rounding of the moved scene (here about 1e-13
    # of the scene's size cubed).
    arranged = result.pose_sources == "arrangement"
    assert arranged.any() and (result.pose_sources == "kernel").sum() == (~arranged).sum() > 0
    assert (np.abs(got - want) <= bound + 1e-14 * want)[~arranged].all()
    assert (got[arranged] > 0).any() and (want[got == 0] <= bound[got == 0]).all()
    assert want[got == 0].max() < 1e-13 * 2.0**3
    # Those read above the rounding agree to the rule of `agrees`; the zeros (overlaps up to
    # 3e-14 here, above that rule's floor of 4e-15) lie within their bound.
    assert agrees(got[got > 0], want[got > 0], ex.hand_volume).all()
    # The bound is far below the scene's size cubed (G = 2 here).
    assert bound.max() <= 1e-12 * 2.0**3


def test_poses_equal_to_rounding_take_the_volume_of_the_first_within_its_bound():
    hand, obj, pose, volume = corner_dip()
    ex = ExactIntersector(hand, obj, broadphase=None)
    for d in (1e-7, 1e-3):  # arranged exactly, and from the kernel
        a, b = pose(d), pose(d * (1 + 2.0**-40))
        assert repeated_poses(np.stack([a, b])).tolist() == [0, 0]
        alone = [ex.intersect(p[None]) for p in (a, b)]
        result = ex.intersect(np.stack([a, b]))
        assert result.volumes.tolist() == [alone[0].volumes[0]] * 2
        assert result.volume_bounds[0] == alone[0].volume_bounds[0]
        assert abs(alone[1].volumes[0] - result.volumes[1]) <= result.volume_bounds[1]
        depths = (d, d * (1 + 2.0**-40))
        for v, e, depth in zip(result.volumes, result.volume_bounds, depths, strict=True):
            assert abs(v - volume(depth)) <= e + 1e-8 * volume(depth)


def test_volumes_invariant_to_object_units_once_normalised():
    links, objs = overlapping_hand()
    rng = np.random.default_rng(2)
    P = rigid(rng, 5, tmax=0.3)
    base = ExactIntersector(links, objs, broadphase="coal").volumes(P)
    s = 1000.0  # the same scene in millimetres instead of metres
    Ps = P.copy()
    Ps[:, :3, 3] *= s
    mm = ExactIntersector(
        [(V * s, F) for V, F in links], [(V * s, F) for V, F in objs], broadphase="coal"
    ).volumes(Ps)
    assert agrees(mm / s**3, base, 3.0).all()


def test_result_shape_follows_poses():
    links, objs = overlapping_hand()
    P = rigid(np.random.default_rng(0), 6, tmax=0.3).reshape(2, 3, 4, 4)
    ex = ExactIntersector(links, objs, broadphase=None)
    assert ex.volumes(P).shape == (2, 3)
    np.testing.assert_array_equal(ex.volumes(P).ravel(), ex.volumes(P.reshape(6, 4, 4)))


def test_open_mesh_refused_with_repair_hint():
    V, F = box([0, 0, 0], [1, 1, 1])
    with pytest.raises(MeshError, match="repair=True"):
        ExactIntersector([(V, F)], [(V, F[:-1])], broadphase=None)
    with pytest.raises(MeshError, match="repair=True"):
        plain_volumes([(V, F[:-2])], [(V, F)], np.eye(4))


def test_backend_validates_parameters(monkeypatch):
    with pytest.raises(BackendError, match="'coal', 'fcl' or None"):
        ExactBackend(broadphase="bullet")
    with pytest.raises(BackendError, match="n_jobs"):
        ExactBackend(n_jobs=0)
    # Its options are the constructor's arguments: an unknown one is Python's TypeError, and
    # through the registry a BackendError naming it.
    with pytest.raises(TypeError, match="voxel"):
        ExactBackend(voxel=3)
    with pytest.raises(BackendError, match=r"bad parameters \['voxel'\]"):
        get_backend("exact", voxel=3)
    import sys

    monkeypatch.setitem(sys.modules, "coal", None)  # makes `import coal` fail
    with pytest.raises(MissingDependencyError, match="coal"):
        ExactBackend(broadphase="coal")
    assert ExactBackend(broadphase=None).params == {"broadphase": None, "n_jobs": None}


class _FakeGrasp:
    def __init__(self, links, objs, key):
        self.links, self.objs, self.geometry_key = links, objs, key
        self.builds = 0

    def canonical_hand_links(self):
        self.builds += 1
        return self.links

    def canonical_object_bodies(self):
        return self.objs


def test_backend_caches_geometry_per_grasp():
    links, objs = overlapping_hand()
    grasp = _FakeGrasp(links, objs, "k1")
    backend = ExactBackend(broadphase="fcl")
    P = rigid(np.random.default_rng(4), 3, tmax=0.3)
    first = backend.volumes(grasp, P)
    second = backend.volumes(grasp, P)
    assert grasp.builds == 1
    np.testing.assert_array_equal(first, second)
    assert agrees(first, plain_volumes(links, objs, P), 3.0).all()
    with pytest.raises(BackendError, match="poses"):
        backend.volumes(grasp, np.eye(3))


@pytest.mark.skipif(
    not (DATA / "barrett-grasps").is_dir(), reason=f"real Barrett data not found at {DATA}"
)
def test_real_spray_bottle_grasp_matches_plain_boolean():
    from exactgrasp import Grasp, PathSampler

    grasp = Grasp.from_file(DATA / "barrett-grasps" / "noise" / "spray_bottle_base.json")
    links, objs = grasp.canonical_hand_links(), grasp.canonical_object_bodies()
    poses = PathSampler.preset("balanced").poses().reshape(-1, 4, 4)
    P = np.concatenate([np.eye(4)[None], poses[[5, 1000, 2500, 4000]]])
    ex = ExactIntersector(links, objs, broadphase="coal")
    result = ex.intersect(P)
    got = result.volumes
    ref = plain_volumes(links, objs, P)
    # The grasp itself penetrates by about 1e-6 of the hand; the path poses overlap deeply.
    assert 0 < got[0] < 1e-5 * ex.hand_volume
    assert (got[1:] > 1e-3 * ex.hand_volume).all()
    assert agrees(got, ref, ex.hand_volume).all()
    assert result.stats["poses_limit"] == 0
    assert json.dumps(result.stats)  # serialisable, for the benchmark


def test_ray_status_agrees_with_winding_number():
    """The exact point test used for shells with no classified vertex (`ray_status`)."""
    from exactgrasp.backends.exact._stages import ray_status
    from exactgrasp.backends.exact.grids import build_grid
    from exactgrasp.geometry.winding import winding_number

    V, F = sphere(1.0, np.zeros(3), 2)
    grid = build_grid(V, F, 0.25)
    stamp = np.full(len(F), -1, np.int64)
    rng = np.random.default_rng(4)
    # Points in a shell around the surface, where cells are touched by it.
    d = rng.normal(size=(400, 3))
    pts = d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(0.8, 1.2, (400, 1))
    got = np.array([ray_status(p, V, F, grid, stamp, k, 0.0) for k, p in enumerate(pts)])
    want = np.array([round(winding_number(p, V, F)) & 1 for p in pts])
    np.testing.assert_array_equal(got, want)
    assert 100 < want.sum() < 300
    # Points known up to a displacement below the cells' margin: the same answers.
    near = [ray_status(p, V, F, grid, stamp, 1000 + k, 1e-13) for k, p in enumerate(pts)]
    np.testing.assert_array_equal(near, want)
    # A point on the surface (a vertex) has no certain status.
    assert ray_status(V[0].copy(), V, F, grid, stamp, 10_000, 0.0) == -1
    # A point that may lie farther from the one meant than the cells' margin: no answer.
    inside = pts[np.flatnonzero(want)[0]]
    assert ray_status(inside, V, F, grid, stamp, 10_001, 1e-3) == -1


def test_small_shell_inside_object_surface_cells_matches_plain_boolean():
    """A hand made of a large box and a tiny separate box just under the object's surface:
    every vertex of the tiny shell lies in a cell the object's surface touches, so its status
    comes from the exact point test, not from the grid."""
    from exactgrasp.backends.exact._stages import point_status

    big = box([0, 0, 0], [2, 2, 2])
    tiny = box([2.302, 0.905, 0.905], [2.312, 0.915, 0.915])
    obj = sphere(0.6, np.array([2.9, 0.91, 0.91]), 4)
    ex = ExactIntersector([big, tiny], [obj], broadphase=None)
    status = [point_status(v - ex.origin, *ex.object_grid[:4]) for v in tiny[0]]
    assert status == [-1] * 8
    P = np.tile(np.eye(4), (4, 1, 1))
    P[:, 0, 3] = [0.0, -0.004, 0.006, -0.35]
    result = ex.intersect(P)
    got = result.volumes
    ref = plain_volumes([big, tiny], [obj], P)
    assert agrees(got, ref, ex.hand_volume).all()
    assert result.stats["poses_limit"] == 0
    # Wholly inside the sphere at the first two poses, partly at the third.
    assert got[0] == pytest.approx(1e-6, rel=1e-9)
    assert got[1] == pytest.approx(1e-6, rel=1e-9)
    assert 0 < got[2] < 1e-6
    assert got[3] > 1e-3


def test_surfaces_cross_is_certain_and_keeps_culling_unchanged():
    """The kernel's cheap test that spares the BVH query: True only where surfaces cross."""
    from exactgrasp.backends.exact._entries import surfaces_cross

    links, objs = overlapping_hand()
    ex = ExactIntersector(links, objs, broadphase="coal")
    P = np.tile(np.eye(4), (3, 1, 1))
    P[1, :3, 3] = [10.0, 0.0, 0.0]  # far away: not known to cross, left to the broad phase
    P[2, :3, 3] = [-1.7, -0.5, -0.5]  # the object's centre near the hand's corner
    crossing = surfaces_cross(
        P, ex.hand_mesh.vertices, *ex.shells[0], ex.hand_grid, ex.object_mesh.vertices,
        *ex.shells[1], ex.object_grid,
    )  # fmt: skip
    assert crossing.tolist() == [True, False, True]
    result = ex.intersect(P)
    got = result.volumes
    assert got[1] == 0.0 and result.stats["poses_culled"] == 1
    np.testing.assert_array_equal(got, ExactIntersector(links, objs, broadphase=None).volumes(P))


def fine_box(lo, hi, subdivisions):
    """Box mesh with 12 * 4**subdivisions triangles (many hand grid cells hold vertices)."""
    import trimesh

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    for _ in range(subdivisions):
        m = m.subdivide()
    return np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)


def test_cells_classified_whole_match_analytic_overlap():
    """A finely tessellated hand box: most of its grid cells are never reached by the object's
    faces and are classified as a whole (inside: their edges' summed weight); the volumes
    still equal the analytic overlap."""
    rng = np.random.default_rng(21)
    hand = fine_box([-1, -1, -1], [1, 1, 1], 4)
    obj_lo, obj_hi = np.array([-0.3, -2.0, -0.7]), np.array([2.0, 0.6, 1.5])
    ex = ExactIntersector([hand], [box(obj_lo, obj_hi)], broadphase=None)
    shifts = np.tile(np.eye(4), (4, 1, 1))
    shifts[:, :3, 3] = rng.uniform(-0.4, 0.4, (4, 3))
    result = ex.intersect(shifts)
    for v, t in zip(result.volumes, shifts[:, :3, 3], strict=True):
        overlap = np.minimum(1.0, obj_hi + t) - np.maximum(-1.0, obj_lo + t)
        want = np.prod(np.clip(overlap, 0, None))
        assert abs(v - want) <= 1e-12 * want
    st = result.stats
    assert st["parts_inside"] > st["parts_clipped"] > 0
    assert st["parts_culled"] > 0 and st["poses_limit"] == 0


def test_cotree_leaves_a_spanning_forest_and_parts_are_connected():
    """The seeds rest on two tables: without its co-tree edges the hand's dual graph (faces
    joined across edges) is a spanning forest, so every cycle of faces crosses a co-tree edge;
    and every part's vertices are joined by the part's own edges."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from exactgrasp.backends.exact.prepare import cotree_edges

    hand = fine_box([-1, -1, -1], [1, 1, 1], 2)
    ring = box([3, -1, -1], [5, 1, 1])
    ex = ExactIntersector([hand, ring], [box([0, 0, 0], [2, 2, 2])], broadphase=None)
    m, t = ex.hand_mesh, ex.hand_tables
    cot = cotree_edges(m)
    np.testing.assert_array_equal(np.sort(cot), np.sort(t.cotree))
    F, E, ET = len(m.faces), len(m.edges), m.edge_faces
    tree = np.setdiff1d(np.arange(E), cot)
    shells, _ = connected_components(
        coo_matrix((np.ones(E), (ET[:, 0], ET[:, 1])), shape=(F, F)), directed=False
    )
    # A forest spanning every shell: one edge fewer than faces per shell, and connected.
    assert len(tree) == F - shells
    parts, _ = connected_components(
        coo_matrix((np.ones(len(tree)), (ET[tree, 0], ET[tree, 1])), shape=(F, F)),
        directed=False,
    )
    assert parts == shells
    reps, epart = t.parts, t.edge_part
    for k in range(len(reps) - 1):
        own = np.flatnonzero(epart == k)
        n = reps[k + 1, 1] - reps[k, 1]
        if n > 1:
            local = m.edges[own] - reps[k, 1]
            count, _ = connected_components(
                coo_matrix((np.ones(len(own)), (local[:, 0], local[:, 1])), shape=(n, n)),
                directed=False,
            )
            assert count == 1


def test_hand_parts_tables_are_consistent():
    """Vertices numbered cell by cell; each part's summed edge weight and the split of every
    vertex's adjacency (edges to other parts first) as the kernel assumes."""
    from exactgrasp.backends.exact.grids import vertex_cells

    hand = fine_box([-1, -1, -1], [1, 1, 1], 3)
    ex = ExactIntersector([hand], [box([0, 0, 0], [2, 2, 2])], broadphase=None)
    m, t = ex.hand_mesh, ex.hand_tables
    V, E, adj_start = m.vertices, m.edges, m.adj_start
    adj_vert, adj_edge = m.adj_vertex, m.adj_edge
    reps, AW, epart = t.parts, t.edge_weights, t.edge_part
    wsum, split = t.part_weights, t.adj_split
    cells = vertex_cells(V, ex.hand_grid.cell)
    assert (np.diff(cells) >= 0).all()
    part = np.repeat(np.arange(len(reps) - 1), np.diff(reps[:, 1]))
    assert (cells[reps[:-1, 1]] == reps[:-1, 0]).all() and len(part) == len(V)
    same = part[E[:, 0]] == part[E[:, 1]]
    np.testing.assert_array_equal(epart, np.where(same, part[E[:, 0]], -1))
    np.testing.assert_allclose(
        wsum[:, 0], np.bincount(part[E[same, 0]], AW[same, 0], len(reps) - 1), rtol=1e-12
    )
    for u in range(len(V)):
        k = np.arange(adj_start[u], adj_start[u + 1])
        np.testing.assert_array_equal(epart[adj_edge[k]] == -1, k < split[u])
        assert set(adj_vert[k]) == set(E[adj_edge[k]].ravel()) - {u}


def test_triangle_box_test_against_linear_programme():
    """`tri_box_xyz` (any half sizes) against an LP: does a point of the triangle lie in the
    box?"""
    from exactgrasp.backends.exact._stages import tri_box_xyz

    rng = np.random.default_rng(8)
    hits = 0
    for _ in range(300):
        T = rng.normal(size=(3, 3))
        c, h = rng.normal(scale=0.5, size=3), rng.uniform(0.05, 0.8, 3)
        # Barycentric weights w >= 0, sum 1, with c - h <= T^T w <= c + h.
        res = linprog(
            np.zeros(3),
            A_ub=np.vstack([T.T, -T.T]),
            b_ub=np.concatenate([c + h, h - c]),
            A_eq=np.ones((1, 3)),
            b_eq=[1.0],
            bounds=[(0, None)] * 3,
        )
        want = res.status == 0
        got = tri_box_xyz(*c, *h, *T.ravel())
        assert got == want
        hits += want
    assert 50 < hits < 250


def test_bounds_apart_is_the_sphere_to_box_distance_against_radius_and_gap():
    from exactgrasp.backends.exact.culling import bounding_sphere, bounds_apart

    centre, radius = bounding_sphere(box([1.0, 1.0, 1.0], [1.2, 1.2, 1.2])[0])
    np.testing.assert_allclose(centre, [1.1, 1.1, 1.1])
    assert radius == pytest.approx(0.1 * np.sqrt(3), rel=1e-15)
    hand = (np.zeros(3), np.ones(3))
    gap = 1e-7
    # Rotated a quarter turn about z, then moved: the sphere's centre goes to (-1.1, 1.1, 1.1)
    # + t; t puts it beyond the box's face x = 1, or its edge (x, y) = (1, 1), by s.
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    poses, expected = [], []
    for s, apart in ((radius + 2 * gap, True), (radius + 0.5 * gap, False), (0.5, True)):
        for target, direction in (([1.0, 0.5, 0.5], [1, 0, 0]), ([1.0, 1.0, 0.5], [1, 1, 0])):
            pose = np.eye(4)
            pose[:3, :3] = turn
            unit = np.array(direction, float) / np.linalg.norm(direction)
            pose[:3, 3] = np.array(target) + s * unit - turn @ centre
            poses.append(pose)
            expected.append(apart)
    inside = np.eye(4)
    inside[:3, 3] = -centre + 0.5
    poses.append(inside)
    expected.append(False)
    assert bounds_apart(np.array(poses), hand, (centre, radius), gap).tolist() == expected


@pytest.mark.parametrize("engine", ["coal", "fcl"])
def test_far_means_farther_than_the_gap(engine):
    """`MeshPair.far`: true at twice the gap, false at half of it, false when crossing."""
    from exactgrasp.geometry.bvh import MeshPair

    gap = 1e-3
    pair = MeshPair(engine, *box([0, 0, 0], [1, 1, 1]), *box([0, 0, 0], [1, 1, 1]), gap=gap)
    got = []
    for shift in (1 + 2 * gap, 1 + 0.5 * gap, 0.5):
        pose = np.eye(4)
        pose[0, 3] = shift
        got.append(pair.far(pose))
    assert got == [True, False, False]


def test_culling_decides_a_shell_with_no_known_cell_by_its_winding_number():
    """A tiny cube beside the hand's face, inside the grid cells the face crosses (no vertex of
    known status): just outside it is culled (volume exactly 0), just inside it is not (its
    whole volume), as without a broad phase."""
    from exactgrasp.backends.exact import culling

    hand = [box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])]
    side = 0.002
    obj = [box([0.0, 0.0, 0.0], [side, side, side])]
    P = np.tile(np.eye(4), (4, 1, 1))
    P[:, :3, 3] = [[1.003, 0.5, 0.5], [1.005, 0.3, 0.6], [0.995, 0.5, 0.5], [0.993, 0.3, 0.6]]
    windings = []
    real = culling.winding_number

    def counted(*args):
        windings.append(1)
        return real(*args)

    for engine in ("coal", "fcl"):
        ex = ExactIntersector(hand, obj, broadphase=engine)
        try:
            culling.winding_number = counted
            result = ex.intersect(P)
        finally:
            culling.winding_number = real
        assert result.pose_sources.tolist() == ["culled", "culled", "kernel", "kernel"]
        assert result.volumes[:2].tolist() == [0.0, 0.0]
        assert result.volumes[2:] == pytest.approx(side**3, rel=1e-9)
        np.testing.assert_array_equal(
            result.volumes, ExactIntersector(hand, obj, broadphase=None).volumes(P)
        )
    assert windings  # the shells were decided by winding numbers, not by grid cells
