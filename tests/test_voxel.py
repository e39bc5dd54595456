"""The paper's voxel-count estimator: grids, samples, counts and the backend."""

from __future__ import annotations

import numba
import numpy as np
import pytest
import trimesh

from exactgrasp.backends.voxel import (
    VoxelBackend,
    estimate_counts,
    estimate_counts_numpy,
    estimate_volumes,
    estimate_volumes_numpy,
)
from exactgrasp.backends.voxel.grids import hand_occupancy, occupancy_grid
from exactgrasp.backends.voxel.points import object_points, poisson_disk_surface, surface_area
from exactgrasp.errors import BackendError
from exactgrasp.geometry.solid import Solid
from exactgrasp.geometry.winding import winding_inside_lattice
from tests.conftest import box_arrays


class ArrayGrasp:
    """The part of `Grasp` a backend reads, over plain arrays."""

    def __init__(self, links, bodies, samples=None, key="g"):
        self.links, self.bodies, self.samples = links, bodies, samples
        self.hand_key, self.object_key = f"hand-{key}", f"object-{key}"

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


def test_numba_and_numpy_counts_are_identical():
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


def test_counts_do_not_depend_on_the_thread_count(box_hand):
    obj = object_points([sphere(0.5)], 40)
    poses = random_poses(200, 1.2, seed=5)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        single = estimate_counts(box_hand, obj, poses)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(single, estimate_counts(box_hand, obj, poses))


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
    grasp = ArrayGrasp([hand], [(bottle.vertices, bottle.faces)], samples=samples, key="spray")
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
