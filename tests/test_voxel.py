"""The paper's voxel-count estimator: grids, samples, counts and the backend."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
import trimesh

from exactgrasp.backends.base import thread_limit
from exactgrasp.backends.voxel import (
    VoxelBackend,
    estimate_counts,
    estimate_counts_numpy,
    estimate_volumes,
    estimate_volumes_numpy,
)
from exactgrasp.backends.voxel.grids import (
    hand_occupancy,
    occupancy_grid,
    summed_table,
    tile_any,
)
from exactgrasp.backends.voxel.points import (
    dart_throw,
    object_points,
    point_tree,
    poisson_disk_surface,
    surface_area,
)
from exactgrasp.errors import BackendError
from exactgrasp.geometry.solid import Solid
from exactgrasp.geometry.winding import winding_inside_lattice
from tests.conftest import box_arrays


def content_key(*arrays):
    """A hash of arrays, standing in for `Grasp`'s geometry hashes."""
    digest = hashlib.sha256()
    for array in arrays:
        if array is not None:
            digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
    return digest.hexdigest()


class ArrayGrasp:
    """The part of `Grasp` a backend reads, over plain arrays."""

    def __init__(self, links, bodies, samples=None):
        self.links, self.bodies, self.samples = links, bodies, samples
        self.hand_key = content_key(*(array for link in links for array in link))
        self.object_key = content_key(*(array for body in bodies for array in body), samples)

    def canonical_hand_links(self):
        return self.links

    def canonical_object_bodies(self):
        return self.bodies

    def canonical_object_surface_samples(self):
        return self.samples


def sphere(radius=1.0, centre=(0.0, 0.0, 0.0), subdivisions=5):
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return mesh.vertices + np.asarray(centre), mesh.faces


def translation(x, y=0.0, z=0.0):
    pose = np.eye(4)
    pose[:3, 3] = x, y, z
    return pose


def random_poses(n, spread, seed=0):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, :3] = np.stack(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    ).transpose(2, 0, 1)
    poses[:, :3, 3] = rng.uniform(-spread, spread, size=(n, 3))
    return poses


HAND_BOX = [box_arrays([-1, -1, -1], [1, 1, 1])]


def cap_volume(radius, height):
    return np.pi * height**2 * (3 * radius - height) / 3


# -- grids ------------------------------------------------------------------------------------


def test_grid_layout_follows_the_resolution_rule():
    grid = occupancy_grid([box_arrays([0, 0, 0], [2.0, 1.0, 0.5])], 50, pad=0)
    assert grid.shape == (50, 25, 12)
    assert grid.spacing == pytest.approx(0.04)
    padded = occupancy_grid([box_arrays([0, 0, 0], [2.0, 1.0, 0.5])], 50, pad=1)
    assert padded.shape == (52, 27, 14)
    assert padded.values[0].sum() == padded.values[:, 0].sum() == padded.values[..., -1].sum() == 0


def test_rays_through_edges_and_vertices_count_once():
    # Box corners on integer columns: many columns run exactly along face diagonals, edges and
    # vertices. The tie rule puts the low faces inside and the high faces outside.
    vertices, faces = box_arrays([1, 1, 1], [5, 5, 5])
    inside = winding_inside_lattice(vertices[faces].astype(float), 7, 7, 7)
    expected = np.zeros((7, 7, 7), np.uint8)
    expected[1:5, 1:5, 1:5] = 1
    np.testing.assert_array_equal(inside, expected)


def test_overlapping_links_count_once():
    single = occupancy_grid(HAND_BOX, 40)
    halves = [box_arrays([-1, -1, -1], [0.3, 1, 1]), box_arrays([-0.3, -1, -1], [1, 1, 1])]
    union = occupancy_grid(halves, 40)
    np.testing.assert_array_equal(union.values, single.values)
    # An inward-facing shell (a hole) cancels what it covers.
    inverted = box_arrays([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5])
    hollow = occupancy_grid([HAND_BOX[0], (inverted[0], inverted[1][:, ::-1])], 40)
    assert hollow.values.sum() == single.values.sum() - 20**3


def test_sphere_grid_volume():
    grid = occupancy_grid([sphere(1.0)], 100, pad=0)
    assert grid.values.sum() * grid.spacing**3 == pytest.approx(4 / 3 * np.pi, rel=0.01)


def box_sum(table, lo, hi):
    """Sum over the box ``lo:hi`` from a summed table, in the table's wrap-around arithmetic."""
    total = 0
    for corner in np.ndindex(2, 2, 2):
        index = tuple(h if c else low for low, h, c in zip(lo, hi, corner, strict=True))
        total += (-1) ** (3 - sum(corner)) * int(table[index])
    return total % 2**64


@pytest.mark.parametrize("resolution", [30, 300])
def test_hand_tables_count_occupied_and_full_tiles(resolution):
    hand = hand_occupancy([sphere(1.0, subdivisions=3)], resolution)
    codes, shift = hand.cell_codes, hand.tile_shift
    assert hand.grid.values[[0, -1]].sum() == hand.grid.values[:, [0, -1]].sum() == 0
    assert max(-(-n >> shift) for n in codes.shape) <= 128 and (shift > 0) == (resolution > 128)
    occupied = tile_any(codes != 0, 1 << shift)
    full = ~tile_any(codes != 255, 1 << shift)
    rng = np.random.default_rng(0)
    for _ in range(50):
        lo = [rng.integers(0, n) for n in occupied.shape]
        hi = [rng.integers(a + 1, n + 1) for a, n in zip(lo, occupied.shape, strict=True)]
        box = tuple(slice(a, b) for a, b in zip(lo, hi, strict=True))
        total = box_sum(hand.tiles, lo, hi)
        assert total & 0xFFFFFFFF == occupied[box].sum()
        assert total >> 32 == full[box].sum()


def test_summed_table():
    values = np.random.default_rng(1).integers(0, 3, (4, 5, 6)).astype(np.uint64)
    table = summed_table(values)
    assert table.shape == (5, 6, 7) and table.dtype == np.uint64
    assert table[4, 5, 6] == values.sum() and table[2, 3, 1] == values[:2, :3, :1].sum()
    assert not table[0].any() and not table[:, 0].any() and not table[..., 0].any()


# -- surface samples --------------------------------------------------------------------------


def test_poisson_disk_samples_are_spaced_on_surface_and_seeded():
    vertices, faces = box_arrays([0, 0, 0], [1, 2, 3])
    triangles = vertices[faces]
    points = poisson_disk_surface(triangles, 0.1, seed=3)
    again = poisson_disk_surface(triangles, 0.1, seed=3)
    np.testing.assert_array_equal(points, again)
    assert not np.array_equal(points, poisson_disk_surface(triangles, 0.1, seed=4))
    gaps = np.linalg.norm(points[:, None] - points[None], axis=-1) + np.eye(len(points)) * 9
    assert gaps.min() >= 0.1
    on_face = np.isclose(points, 0).any(1) | np.isclose(points, [1, 2, 3]).any(1)
    assert on_face.all()
    # About 0.565 samples per spacing**2 of area (the calibration behind the default count).
    assert len(points) == pytest.approx(0.565 * surface_area(triangles) / 0.01, rel=0.1)


def greedy_disk_indices(points, spacing):
    """Points accepted in order when no accepted point is closer than `spacing` (plain)."""
    accepted = []
    for index, point in enumerate(points):
        if all(np.sum((point - points[other]) ** 2) >= spacing**2 for other in accepted):
            accepted.append(index)
    return np.array(accepted, np.int64)


@pytest.mark.parametrize("extent", [(1.0, 1.0, 1.0), (200.0, 0.01, 0.01), (5.0, 3.0, 0.0)])
def test_dart_throwing_is_the_plain_greedy_rule(extent):
    # The last two need cells wider than one spacing (a sparse extent) or have a flat side.
    points = np.random.default_rng(2).random((600, 3)) * extent
    for spacing in (0.05, 0.3):
        np.testing.assert_array_equal(
            dart_throw(points, spacing), greedy_disk_indices(points, spacing)
        )


def test_default_sample_count_is_near_the_authors():
    obj = object_points([sphere(1.0, subdivisions=4)], 50)
    assert 6800 < obj.n_surface < 7800


# -- the estimator ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def box_hand():
    return hand_occupancy(HAND_BOX, 100)


def test_box_in_box_overlaps(box_hand):
    obj = object_points([box_arrays([-0.5, -0.3, -0.4], [0.5, 0.3, 0.4])], 50)
    shifts = np.array([0.0, 0.6, 1.0, 1.3])
    poses = np.stack([translation(d) for d in shifts])
    exact = np.minimum(1.0, 1.5 - shifts) * 0.6 * 0.8
    np.testing.assert_allclose(estimate_volumes(box_hand, obj, poses), exact, rtol=0.05)


def test_box_inside_sphere_any_rotation():
    hand = hand_occupancy([sphere(1.0)], 100)
    obj = object_points([box_arrays([-0.2, -0.2, -0.2], [0.2, 0.2, 0.2])], 50)
    poses = random_poses(5, 0.2, seed=1)
    np.testing.assert_allclose(estimate_volumes(hand, obj, poses), 0.064, rtol=0.05)


def test_sphere_cap_overlap_and_convergence(box_hand):
    # A sphere of radius 0.5 poking 0.3 out through the face x = 1 of the box hand.
    exact = 4 / 3 * np.pi * 0.125 - cap_volume(0.5, 0.3)
    pose = translation(0.8)[None]
    errors = []
    for hand_res, obj_res in [(25, 12), (50, 25), (100, 50), (200, 100)]:
        hand = box_hand if hand_res == 100 else hand_occupancy(HAND_BOX, hand_res)
        obj = object_points([sphere(0.5)], obj_res, surface_mode="none")
        errors.append(abs(estimate_volumes(hand, obj, pose)[0] / exact - 1))
    assert errors[2] < 0.05
    assert errors[3] < errors[1] < errors[0]
    full = object_points([sphere(0.5)], 50)
    assert estimate_volumes(box_hand, full, pose)[0] == pytest.approx(exact, rel=0.05)


def test_compiled_and_numpy_counts_are_identical():
    hand = hand_occupancy(
        [sphere(1.0, subdivisions=3), box_arrays([0.5, -0.3, -0.3], [1.8, 0.3, 0.3])], 60
    )
    obj = object_points([sphere(0.6, (0.3, 0, 0), subdivisions=3)], 30)
    poses = random_poses(300, 1.5, seed=2).reshape(3, 100, 4, 4)
    fast = estimate_counts(hand, obj, poses)
    assert fast.shape == (3, 100, 2)
    assert (fast.sum(-1) > 0).mean() > 0.5
    np.testing.assert_array_equal(
        fast, estimate_counts_numpy(hand, obj, poses, chunk_elements=10**5)
    )
    np.testing.assert_array_equal(
        estimate_volumes(hand, obj, poses), estimate_volumes_numpy(hand, obj, poses)
    )


def test_point_tree_partitions_the_points_by_kind():
    interior = np.random.default_rng(3).random((500, 3)) * 2
    surface = np.random.default_rng(4).random((300, 3)) * 2 - 0.5
    tree = point_tree([interior, surface], np.zeros(3), 0.1, levels=(8, 4, 2))
    points, boxes, ranges = tree["points"], tree["node_boxes"], tree["node_ranges"]
    np.testing.assert_array_equal(np.sort(points[:500], axis=0), np.sort(interior, axis=0))
    np.testing.assert_array_equal(np.sort(points[500:], axis=0), np.sort(surface, axis=0))
    roots, first_leaf = tree["n_roots"], tree["first_leaf"]
    # The roots, and every node's children, tile its points in order.
    assert ranges[0, 0] == 0 and ranges[roots - 1, 1] == len(points)
    assert np.array_equal(ranges[1:roots, 0], ranges[: roots - 1, 1])
    for node, (start, end, child_start, child_end) in enumerate(ranges):
        inside = points[start:end]
        assert start < end and (end <= 500 or start >= 500), "a node holds one kind"
        assert np.all(np.abs(inside - boxes[:3, node]) <= boxes[3:, node] + 1e-15)
        if node < first_leaf:
            assert child_start < child_end
            assert ranges[child_start, 0] == start and ranges[child_end - 1, 1] == end
        else:
            assert child_start == child_end == 0


@pytest.mark.parametrize("hand_resolution", [40, 200])
def test_compiled_and_numpy_counts_agree_across_the_grid_border(hand_resolution):
    # Poses that put the object across every face of the hand grid, and fine grids whose
    # tables tile several cells together.
    hand = hand_occupancy(
        [sphere(0.9, subdivisions=3), box_arrays([-1.0, -0.2, -1.0], [1.0, 0.2, -0.4])],
        hand_resolution,
    )
    obj = object_points([sphere(0.7, (0.2, 0, 0), subdivisions=3)], 25)
    poses = random_poses(400, 1.6, seed=7)
    fast = estimate_counts(hand, obj, poses)
    assert (fast.sum(-1) > 0).mean() > 0.5
    np.testing.assert_array_equal(fast, estimate_counts_numpy(hand, obj, poses))


def test_counts_do_not_depend_on_the_thread_count(box_hand):
    obj = object_points([sphere(0.5)], 40)
    # Enough poses for several threads; a few go on the calling thread alone.
    poses = random_poses(600, 1.2, seed=5)
    single = estimate_counts(box_hand, obj, poses, n_jobs=1)
    np.testing.assert_array_equal(single, estimate_counts(box_hand, obj, poses, n_jobs=3))
    with thread_limit(1):
        np.testing.assert_array_equal(single, estimate_counts(box_hand, obj, poses))
    np.testing.assert_array_equal(single[:5], estimate_counts(box_hand, obj, poses[:5]))


def test_far_pose_gives_exactly_zero(box_hand):
    obj = object_points([sphere(0.5)], 50)
    poses = np.stack([translation(3.0), translation(0, -50, 7), translation(1e6)])
    assert np.all(estimate_volumes(box_hand, obj, poses) == 0.0)
    assert np.all(estimate_volumes_numpy(box_hand, obj, poses) == 0.0)


# -- the backend ------------------------------------------------------------------------------


def test_backend_volumes_cache_and_params():
    backend = VoxelBackend(hand_resolution=60, object_resolution=30)
    grasp = ArrayGrasp(HAND_BOX, [box_arrays([-0.5, -0.3, -0.4], [0.5, 0.3, 0.4])])
    poses = np.stack([translation(1.0), translation(5.0)]).reshape(1, 2, 4, 4)
    volumes = backend.volumes(grasp, poses)
    assert volumes.shape == (1, 2)
    assert volumes[0, 0] == pytest.approx(0.24, rel=0.05) and volumes[0, 1] == 0
    assert backend.hand_grid(grasp) is backend.hand_grid(grasp)
    assert backend.object_point_set(grasp) is backend.object_point_set(grasp)
    assert backend.params == {
        "hand_resolution": 60,
        "object_resolution": 30,
        "surface_spacing": None,
        "surface_samples": None,
        "surface_weight": "paper",
        "seed": 0,
        "grid": "floor",
    }
    assert backend.name == "voxel" and "VoxelBackend(hand_resolution=60" in repr(backend)


def test_each_backend_owns_its_grids_and_points_and_shared_ones_share_them():
    import pickle

    from exactgrasp.backends import shared_backend

    grasp = ArrayGrasp(HAND_BOX, [box_arrays([-0.5, -0.3, -0.4], [0.5, 0.3, 0.4])])
    first = shared_backend("voxel", hand_resolution=30)
    assert shared_backend("voxel", hand_resolution=30) is first
    assert first.hand_grid(grasp) is first.hand_grid(grasp)
    assert first.object_point_set(grasp) is first.object_point_set(grasp)
    own = VoxelBackend(hand_resolution=30)
    assert own.hand_grid(grasp) is not first.hand_grid(grasp)
    assert first._hand_grids.builds == 1 and first._hand_grids.hits == 2
    moved = ArrayGrasp(HAND_BOX, [box_arrays([-0.4, -0.3, -0.4], [0.5, 0.3, 0.4])])
    assert first.object_point_set(moved) is not first.object_point_set(grasp)
    # A copy (as a batch task carries) has the parameters and none of the cached geometry;
    # the copies made in one process share their caches.
    copy = pickle.loads(pickle.dumps(first))
    assert copy.params == first.params and len(copy._hand_grids) == 0
    again = pickle.loads(pickle.dumps(first))
    assert again._hand_grids is copy._hand_grids and again._hand_grids is not first._hand_grids


def test_volumes_with_progress_reports_every_pose():
    backend = VoxelBackend(hand_resolution=40, object_resolution=20)
    grasp = ArrayGrasp(HAND_BOX, [box_arrays([-0.5, -0.3, -0.4], [0.5, 0.3, 0.4])])
    poses = random_poses(9000, 1.0, seed=8).reshape(3000, 3, 4, 4)
    done = []
    volumes = backend.volumes_with_progress(grasp, poses, done.append)
    assert volumes.shape == (3000, 3) and sum(done) == 9000 and len(done) == 2
    np.testing.assert_array_equal(volumes, backend.volumes(grasp, poses))
    np.testing.assert_array_equal(backend.volumes_with_progress(grasp, poses[:2]), volumes[:2])


def test_hand_volume_is_computed_once_per_hand_and_backend():
    class CountingGrasp(ArrayGrasp):
        unions = 0

        @property
        def canonical_hand_volume(self):
            CountingGrasp.unions += 1
            return 8.0

    grasp = CountingGrasp([box_arrays([-1, -1, -1], [1, 1, 1.5])], HAND_BOX)
    backend = VoxelBackend()
    assert backend.hand_volume(grasp) == 8.0
    assert backend.hand_volume(CountingGrasp(grasp.links, [])) == 8.0
    assert CountingGrasp.unions == 1


def test_backend_surface_options():
    body = [box_arrays([0, 0, 0], [1, 1, 1])]
    given = np.random.default_rng(0).random((123, 3))
    grasp = ArrayGrasp(HAND_BOX, body, samples=given)
    assert VoxelBackend().object_point_set(grasp).n_surface == 123
    generated = VoxelBackend(surface_samples="generate").object_point_set(grasp)
    assert 6800 < generated.n_surface < 7800
    assert VoxelBackend(surface_samples="none").object_point_set(grasp).n_surface == 0
    assert VoxelBackend(surface_samples=500).object_point_set(grasp).n_surface == pytest.approx(
        500, rel=0.1
    )
    coarse = VoxelBackend(surface_samples="generate", surface_spacing=2.0)
    obj = coarse.object_point_set(grasp)
    assert obj.n_surface == pytest.approx(0.565 * 6 / 0.04**2, rel=0.1)
    assert obj.surface_weight == pytest.approx(obj.voxel_volume / 32)
    area = VoxelBackend(surface_weight="area").object_point_set(grasp)
    assert area.surface_weight == pytest.approx((6 / 123) ** 1.5 / 2)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"hand_resolution": 1}, "hand_resolution must be an integer from 2 to 1000, got 1 "),
        ({"hand_resolution": 50.0}, "hand_resolution must be an integer .* got 50.0"),
        ({"object_resolution": True}, "object_resolution must be an integer .* got True"),
        ({"object_resolution": 5000}, "object_resolution must be an integer from 2 to 1000"),
        ({"surface_spacing": -1.0}, "surface_spacing must be a number from 0.05 to 1000 or None"),
        ({"surface_spacing": "fine"}, "surface_spacing must be a number .* got 'fine'"),
        (
            {"surface_samples": "meshlab"},
            "surface_samples must be None, an integer from 1 to 10,000,000, 'generate' or 'none'",
        ),
        ({"surface_samples": 0}, "surface_samples must be None, an integer from 1 .* got 0"),
        ({"surface_samples": 100, "surface_spacing": 1.0}, "give either .* not both"),
        ({"surface_samples": "none", "surface_spacing": 1.0}, "surface_spacing has no effect"),
        ({"surface_weight": "volume"}, "surface_weight must be 'paper' or 'area', got 'volume'"),
        ({"seed": -1}, "seed must be a non-negative integer, got -1"),
        ({"grid": "ceil"}, "grid must be 'floor' or 'round', got 'ceil'"),
    ],
)
def test_parameter_validation(kwargs, message):
    with pytest.raises(BackendError, match=f"^VoxelBackend: {message}"):
        VoxelBackend(**kwargs)


def test_bad_poses_are_rejected():
    grasp = ArrayGrasp(HAND_BOX, [box_arrays([0, 0, 0], [1, 1, 1])])
    with pytest.raises(BackendError, match="poses must have shape"):
        VoxelBackend(hand_resolution=20, object_resolution=10).volumes(grasp, np.eye(3))


# -- real data --------------------------------------------------------------------------------


def test_spray_bottle_with_published_samples(shared_data):
    manifold3d = pytest.importorskip("manifold3d")
    objects = shared_data / "osu-objects"
    bottle = trimesh.load(objects / "SprayBottle.STL")
    samples = np.asarray(trimesh.load(objects / "SprayBottle_P.ply").vertices)
    lo, hi = bottle.bounds
    # A box hand holding the middle third of the bottle (millimetres throughout).
    hand_lo = lo - 5
    hand_hi = hi + 5
    hand_lo[1], hand_hi[1] = lo[1] + (hi[1] - lo[1]) / 3, lo[1] + 2 * (hi[1] - lo[1]) / 3
    hand = box_arrays(hand_lo, hand_hi)
    grasp = ArrayGrasp([hand], [(bottle.vertices, bottle.faces)], samples=samples)
    backend = VoxelBackend()
    obj = backend.object_point_set(grasp)
    assert obj.n_surface == len(samples) == 7295
    shifts = [0.0, 40.0]
    estimate = backend.volumes(grasp, np.stack([translation(0, d) for d in shifts]))

    def as_manifold(vertices, faces):
        mesh = manifold3d.Mesh(
            vert_properties=np.asarray(vertices, np.float32),
            tri_verts=np.asarray(faces, np.uint32),
        )
        return manifold3d.Manifold(mesh)

    exact = [
        (
            as_manifold(*hand) ^ as_manifold(bottle.vertices + np.array([0, d, 0]), bottle.faces)
        ).volume()
        for d in shifts
    ]
    np.testing.assert_allclose(estimate, exact, rtol=0.05)


def test_public_api_grasp():
    import exactgrasp as eg

    hand = eg.Hand.from_meshes(
        [box_arrays([-0.05] * 3, [0.05] * 3)], frame=eg.HandFrame.identity()
    )
    grasp = eg.Grasp(hand, eg.Solid(*box_arrays([-0.02] * 3, [0.02] * 3)))
    backend = eg.get_backend("voxel")
    assert isinstance(backend, VoxelBackend)
    volumes = backend.volumes(grasp, np.stack([np.eye(4), translation(0.05)]))
    np.testing.assert_allclose(volumes, [0.04**3, 0.02 * 0.04**2], rtol=0.05)


def test_grid_rules_on_the_flat_cereal_box(shared_data):
    """The authors' floor rule leaves up to a voxel of each short side out; "round" does not."""
    from exactgrasp.backends.voxel.points import object_points

    obj = Solid.from_file(shared_data / "osu-objects" / "CerealBox.STL", units="mm")
    bodies = [(obj.vertices, obj.faces)]
    errors = {}
    for rule in ("floor", "round"):
        points = object_points(bodies, 50, surface_mode="none", grid_rule=rule)
        errors[rule] = points.n_interior * points.voxel_volume / obj.volume - 1
    # 51 x 197 x 285 mm at 5.7 mm voxels: floor keeps 8 x 34 x 50, round 9 x 35 x 50
    assert errors["floor"] == pytest.approx(8 * 34 * 50 * 5.7**3 / (51 * 197 * 285) - 1, abs=1e-9)
    assert errors["floor"] < -0.12
    assert abs(errors["round"]) < 0.02
    with pytest.raises(BackendError, match="grid must be 'floor' or 'round'"):
        VoxelBackend(grid="ceil")
