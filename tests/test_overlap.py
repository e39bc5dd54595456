"""`intersection_volume` and ``exactgrasp overlap``: exact volumes of two arbitrary meshes."""

from __future__ import annotations

import json
from dataclasses import astuple

import manifold3d
import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import exactgrasp as eg
from exactgrasp.backends.exact import ExactBackend
from exactgrasp.backends.voxel import VoxelBackend
from exactgrasp.cli.main import main
from exactgrasp.errors import BackendError, MeshError
from exactgrasp.geometry import primitives
from exactgrasp.overlap import as_solid, intersection, intersection_volume
from tests.conftest import box_arrays


def translation(x=0.0, y=0.0, z=0.0) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = (x, y, z)
    return pose


def boolean_volume(a, b, pose) -> float:
    """manifold3d's double-precision volume of a ∩ (b moved by pose)."""

    def solid(mesh):
        V, F = mesh
        return manifold3d.Manifold(
            manifold3d.Mesh64(
                vert_properties=np.array(V, dtype=np.float64),
                tri_verts=np.array(F, dtype=np.uint64),
            )
        )

    return (solid(a) ^ solid(b).transform(pose[:3, :])).volume()


# -- analytic volumes -------------------------------------------------------------------------


def test_overlapping_boxes_give_the_box_intersection():
    a = box_arrays([0, 0, 0], [0.1, 0.08, 0.06])
    b = box_arrays([0, 0, 0], [0.05, 0.05, 0.05])
    volume, bound = astuple(intersection(a, b, translation(0.07, 0.05, 0.03)))
    assert isinstance(volume, float) and isinstance(bound, float)
    expected = 0.03 * 0.03 * 0.03
    assert abs(volume - expected) <= bound + 1e-15 * expected
    assert 0 <= bound < 1e-9 * expected


def test_icosphere_inside_a_box_gives_its_volume():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    volume, bound = astuple(intersection(box, sphere, translation(0.01, -0.005, 0.002)))
    assert volume == pytest.approx(sphere.volume, rel=1e-12)
    assert abs(volume - sphere.volume) <= bound + 1e-14 * sphere.volume


def test_disjoint_meshes_give_exactly_zero():
    a = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    b = trimesh.creation.icosphere(radius=0.02)
    volume, bound = astuple(intersection(a, b, translation(0.5, 0, 0)))
    assert volume == 0.0 and bound == 0.0


@pytest.mark.parametrize(
    "offset", [(0.1, 0, 0), (0.1, 0.1, 0), (0.1, 0.1, 0.1), (0, 0, -0.05)], ids=str
)
def test_touching_meshes_give_zero(offset):
    """Face, edge and corner contact of two boxes (and of a box with a half-size box)."""
    a = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    b = box_arrays([0, 0, 0], [0.1, 0.1, 0.1] if offset[2] >= 0 else [0.05, 0.05, 0.05])
    assert intersection_volume(a, b, translation(*offset)) == 0.0


def test_a_stack_of_translations():
    """A 0.04 m cube sliding through a 0.1 m box along x: overlap length times 0.04^2."""
    a = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    b = box_arrays([0, 0.03, 0.03], [0.04, 0.07, 0.07])
    xs = np.array([[-0.06, -0.03, -0.01], [0.02, 0.08, 0.13]])
    poses = np.stack([translation(x) for x in xs.ravel()]).reshape(2, 3, 4, 4)
    volumes, bounds = astuple(intersection(a, b, poses))
    assert volumes.shape == bounds.shape == (2, 3)
    length = np.clip(np.minimum(xs + 0.04, 0.1) - np.maximum(xs, 0.0), 0.0, None)
    expected = length * 0.04**2
    assert np.all(np.abs(volumes - expected) <= bounds + 1e-15)
    assert volumes[0, 0] == 0.0 and volumes[1, 2] == 0.0


def test_an_empty_stack_gives_an_empty_array():
    a = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    out = intersection_volume(a, a, np.zeros((0, 4, 4)))
    assert out.shape == (0,)


# -- against manifold3d -----------------------------------------------------------------------


def test_random_rigid_poses_agree_with_the_manifold3d_boolean():
    a = primitives.cylinder(0.03, 0.05, segments=48)
    b = primitives.box((0.04, 0.02, 0.015))
    rng = np.random.default_rng(7)
    poses = np.tile(np.eye(4), (40, 1, 1))
    poses[:, :3, :3] = Rotation.random(40, random_state=rng).as_matrix()
    poses[:, :3, 3] = rng.uniform(-0.05, 0.05, size=(40, 3))
    volumes, bounds = astuple(intersection(a, b, poses))
    reference = np.array([boolean_volume(a, b, p) for p in poses])
    assert (reference > 0).sum() >= 20 and (reference == 0).sum() >= 1
    assert np.all(volumes >= 0)
    # "To 1e-9 relative", volumes under a millionth of the smaller solid's relative to that.
    floor = 1e-6 * min(as_solid(a).volume, as_solid(b).volume)
    assert np.all(np.abs(volumes - reference) <= 1e-9 * np.maximum(reference, floor))
    # The boolean's own rounding (1e-12 of the coordinates times both areas) plus the bound.
    slack = 4e-12 * 0.1 * (as_solid(a).area + as_solid(b).area)
    assert np.all(np.abs(volumes - reference) <= bounds + slack)


def test_overlapping_shells_are_merged_into_one_solid():
    """A mesh of two overlapping cubes is the solid they bound: their union."""
    V1, F1 = box_arrays([0, 0, 0], [0.02, 0.02, 0.02])
    V2, F2 = box_arrays([0.01, 0.005, 0.005], [0.03, 0.025, 0.025])
    two = (np.vstack([V1, V2]), np.vstack([F1, F2 + 8]))
    big = box_arrays([-1, -1, -1], [1, 1, 1])
    with pytest.warns(UserWarning, match="shells"):
        volume = intersection_volume(big, two)
    union = 0.02**3 * 2 - 0.01 * 0.015 * 0.015
    assert volume == pytest.approx(union, rel=1e-12)


# -- input forms ------------------------------------------------------------------------------


def test_every_input_form_gives_the_same_volume(tmp_path):
    box = trimesh.creation.box(extents=(0.1, 0.06, 0.04))
    cyl = trimesh.creation.cylinder(radius=0.02, height=0.1, sections=40)
    pose = translation(0.03, 0.01, 0.0) @ np.diag([1.0, 1.0, 1.0, 1.0])
    pose[:3, :3] = Rotation.from_euler("xyz", [0.3, 0.2, 0.1]).as_matrix()
    box.export(tmp_path / "box.stl")
    cyl.export(tmp_path / "cyl.obj")
    reference = intersection_volume(box, cyl, pose)
    assert reference > 0
    forms = [
        ((box.vertices, box.faces), [cyl.vertices.tolist(), cyl.faces.tolist()]),
        (eg.Solid.from_trimesh(box), cyl),
    ]
    for a, b in forms:
        assert eg.intersection_volume(a, b, pose) == pytest.approx(reference, rel=1e-12)
    # Files: STL stores float32 coordinates, so compare with the meshes as read back.
    read = [trimesh.load(tmp_path / name, force="mesh") for name in ("box.stl", "cyl.obj")]
    from_files = intersection_volume(tmp_path / "box.stl", str(tmp_path / "cyl.obj"), pose)
    assert from_files == pytest.approx(intersection_volume(*read, pose), rel=1e-12)
    assert from_files == pytest.approx(reference, rel=1e-5)
    solid = eg.Solid.from_file(tmp_path / "cyl.obj")
    assert intersection_volume(read[0], solid, pose) == pytest.approx(from_files, rel=1e-12)


def test_units_of_files_in_millimetres(tmp_path):
    a = trimesh.creation.box(extents=(0.1, 0.06, 0.04))
    b = trimesh.creation.icosphere(subdivisions=2, radius=0.03)
    pose = translation(0.05, 0.01, -0.01)
    in_metres = intersection_volume(a, b, pose)
    a.apply_scale(1000.0)
    b.apply_scale(1000.0)
    a.export(tmp_path / "a_mm.stl")
    b.export(tmp_path / "b_mm.stl")
    a_mm, b_mm = tmp_path / "a_mm.stl", tmp_path / "b_mm.stl"
    assert intersection_volume(a_mm, b_mm, pose, units="mm") == pytest.approx(in_metres, rel=1e-12)
    b.apply_scale(0.001)
    mixed = intersection_volume(a_mm, b, pose, units=("mm", "m"))
    assert mixed == pytest.approx(in_metres, rel=1e-12)
    with pytest.raises(MeshError, match="long in units='m'"):
        intersection_volume(a_mm, b, pose)


def test_units_are_not_applied_to_a_solid():
    """A Solid is already in metres: units= converts the other inputs only."""
    a_mm = box_arrays([0, 0, 0], [100, 100, 100])  # a 0.1 m cube written in millimetres
    b = eg.Solid(*box_arrays([0, 0, 0], [0.05, 0.05, 0.05]))
    pose = translation(0.07, 0.07, 0.07)
    assert intersection_volume(a_mm, b, pose, units="mm") == pytest.approx(0.03**3, rel=1e-12)
    assert intersection_volume(a_mm, b, pose, units=("mm", "mm")) == pytest.approx(
        0.03**3, rel=1e-12
    )


def test_repair_closes_an_open_mesh():
    V, F = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    b = box_arrays([0.05, 0.05, 0.05], [0.2, 0.2, 0.2])
    with pytest.raises(MeshError, match="pass repair=True"):
        intersection_volume((V, F[1:]), b)
    volume = intersection_volume((V, F[1:]), b, repair=True)
    assert volume == pytest.approx(0.05**3, rel=1e-12)


# -- refusals ---------------------------------------------------------------------------------


def test_a_non_rigid_pose_is_refused_naming_poses_and_its_index():
    a = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    poses = np.stack([np.eye(4), np.diag([1.0, 1.0, 1.0, 1.0]), np.eye(4)])
    poses[1, :3, :3] *= 1.1
    with pytest.raises(BackendError, match=r"poses\[1\] is not a rigid motion.*scale"):
        intersection_volume(a, a, poses)
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    with pytest.raises(BackendError, match=r"^poses is not a rigid motion.*reflection"):
        intersection_volume(a, a, mirror)
    with pytest.raises(BackendError, match=r"poses must have shape"):
        intersection_volume(a, a, np.eye(3))


def test_an_open_mesh_is_refused_naming_the_argument(tmp_path):
    V, F = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    closed = (V, F)
    with pytest.raises(MeshError, match=r"^b: not a closed surface"):
        intersection_volume(closed, (V, F[1:]))
    trimesh.Trimesh(V, F[2:]).export(tmp_path / "open.stl")
    with pytest.raises(MeshError, match=r"^a: .*open\.stl: not a closed surface"):
        intersection_volume(tmp_path / "open.stl", closed)
    with pytest.raises(MeshError, match=r"^a: .*missing\.stl: no such file"):
        intersection_volume(tmp_path / "missing.stl", closed)


def test_wrong_input_types_name_the_argument_and_the_accepted_forms():
    closed = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    for bad in (42, {"vertices": 1}, (1, 2, 3)):
        with pytest.raises(MeshError, match=r"^b: got .*trimesh\.Trimesh.*Solid.*path"):
            intersection_volume(closed, bad)
    with pytest.raises(MeshError, match=r"^b: missing; pass the mesh that moves .*Trimesh.*path"):
        intersection_volume(closed, None)
    with pytest.raises(MeshError, match=r"^a: a \(vertices, faces\) pair must hold numeric"):
        intersection_volume((["x", "y"], [[0, 1, 2]]), closed)
    with pytest.raises(MeshError, match=r"^a: got a trimesh\.Scene"):
        intersection_volume(trimesh.Scene([trimesh.creation.box()]), closed)


def test_bad_options_are_refused_by_name():
    closed = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    with pytest.raises(BackendError, match=r"backend='voxel' is not offered"):
        intersection_volume(closed, closed, backend="voxel")
    with pytest.raises(BackendError, match=r"backend='fast'"):
        intersection_volume(closed, closed, backend="fast")
    with pytest.raises(MeshError, match=r"units='km'"):
        intersection_volume(closed, closed, units="km")
    with pytest.raises(MeshError, match=r"units=\('m',\)"):
        intersection_volume(closed, closed, units=("m",))
    with pytest.raises(BackendError, match=r"backend='voxel' is not offered"):
        intersection_volume(closed, closed, backend=VoxelBackend())
    with pytest.raises(TypeError, match="broadphase"):  # set on the backend: ExactBackend(...)
        intersection_volume(closed, closed, broadphase="coal")
    with pytest.raises(MeshError, match=r"repair must be True or False"):
        intersection_volume(closed, closed, repair="yes")


@pytest.mark.parametrize(
    "options", [{"broadphase": "coal"}, {"broadphase": "fcl"}, {"n_jobs": 2}, None], ids=str
)
def test_broadphase_and_threads_do_not_change_the_volumes(options):
    """Bit for bit; None is the name ``"exact"``: the library defaults (coal, every core)."""
    pytest.importorskip((options or {}).get("broadphase", "coal"))
    a = primitives.sphere(0.04, segments=24)
    b = primitives.box((0.03, 0.03, 0.03))
    poses = np.stack([translation(x, 0.01, 0) for x in np.linspace(-0.12, 0.12, 300)])
    reference = intersection_volume(a, b, poses, backend=ExactBackend(broadphase=None, n_jobs=1))
    assert reference[0] == 0.0 and reference[150] > 0
    backend = "exact" if options is None else ExactBackend(**options)
    assert np.array_equal(intersection_volume(a, b, poses, backend=backend), reference)


# -- real data ------------------------------------------------------------------------------


def test_a_real_penetrating_grasp_matches_its_recorded_boolean(shared_data):
    """The spray-bottle study record: hand (9 overlapping links as one mesh) ∩ bottle (mm)."""
    record = shared_data / "barrett-grasps" / "noise" / "spray_bottle_study_record.json"
    grasp = eg.Grasp.from_file(record)
    hand = trimesh.util.concatenate(grasp.hand.link_meshes())
    data = json.loads(record.read_text())
    bottle = (record.parent / data["object"]).resolve()
    with pytest.warns(UserWarning, match="merged shells"):
        pose = np.array(data["object_pose_in_hand"])
        result = intersection(hand, bottle, pose, units=("m", "mm"))
    volume, bound = result.volumes, result.bounds
    # Recorded from the links unioned another way, which moves it by a few 1e-9 relative.
    recorded = data["checks"]["hand_object_intersection_m3"]
    assert abs(volume - recorded) <= 1e-8 * recorded
    assert bound < 1e-6 * volume


# -- posed hands and grasps -------------------------------------------------------------------


def two_link_hand():
    """A hand of two overlapping box links (the overlap 0.02 x 0.1 x 0.02 m, hand once)."""
    links = [box_arrays([-0.06, -0.05, 0], [0.01, 0.05, 0.02]),
             box_arrays([-0.01, -0.05, 0], [0.06, 0.05, 0.02])]  # fmt: skip
    frame = eg.HandFrame.from_palm([0, 0, 0.02], [0, 0, 1], [0, 1, 0], 0.08)
    return eg.Hand.from_meshes(links, frame=frame)


def test_a_hand_is_the_union_of_its_posed_links():
    hand = two_link_hand()
    cube = box_arrays([0, 0, 0], [0.04, 0.04, 0.04])
    # The cube spans the links' overlap, 1 cm deep: each link alone holds 3 or 2 cm of its
    # width, their sum 5 cm counts the overlap twice; the union holds 4 cm.
    volume, bound = astuple(intersection(hand, cube, translation(-0.02, -0.02, 0.01)))
    expected = 0.04 * 0.04 * 0.01
    assert abs(volume - expected) <= bound + 1e-15 * expected
    # The hand moves as well as it stays: the same pair swapped, the pose inverted.
    swapped = intersection_volume(cube, hand, translation(0.02, 0.02, -0.01))
    assert swapped == pytest.approx(expected, rel=1e-12)


def test_a_grasp_is_its_hand_and_its_object_at_the_grasp_pose():
    hand = two_link_hand()
    grasp = eg.Grasp(hand, eg.Solid(*box_arrays([0, 0, 0], [0.04, 0.04, 0.04])),
                     translation(-0.02, -0.02, 0.01))  # fmt: skip
    assert intersection_volume(grasp) == pytest.approx(0.04 * 0.04 * 0.01, rel=1e-12)
    # Poses move the object from where the grasp holds it, in the hand's coordinates.
    lifted = intersection_volume(grasp, poses=np.stack([translation(z=0.005), translation(z=1)]))
    assert lifted == pytest.approx([0.04 * 0.04 * 0.005, 0.0], rel=1e-12, abs=0)
    # Lifting the object sheds volume at the area of its face inside the hand, 0.04 x 0.04.
    g = eg.intersection_gradient(grasp)
    assert g.shape == (6,)
    assert g[:3] == pytest.approx([0, 0, -0.04 * 0.04], abs=1e-15)


def test_hand_and_grasp_arguments_are_refused_when_they_cannot_mean_anything():
    hand = two_link_hand()
    cube = box_arrays([0, 0, 0], [0.04, 0.04, 0.04])
    grasp = eg.Grasp(hand, eg.Solid(*cube))
    with pytest.raises(MeshError, match=r"^b: got tuple beside a Grasp, .* pass the grasp alone"):
        intersection_volume(grasp, cube)
    with pytest.raises(
        MeshError, match=r"^b: got a Grasp, which holds both meshes; pass it alone"
    ):
        intersection_volume(cube, grasp)
    with pytest.raises(
        MeshError, match=r"^b: missing; pass the mesh that moves .*exactgrasp\.Hand"
    ):
        intersection_volume(hand)
    with pytest.raises(MeshError, match=r"^a: got int; pass .* or an exactgrasp.Hand"):
        intersection_volume(3, hand)


def test_a_hand_gives_the_exact_backends_volume_of_its_grasp(shared_data):
    """The spray-bottle study record: the hand's nine posed links against the bottle, as the
    exact backend computes the grasp at the identity path pose (in canonical units)."""
    record = shared_data / "barrett-grasps" / "noise" / "spray_bottle_study_record.json"
    grasp = eg.Grasp.from_file(record)
    backend = ExactBackend(n_jobs=1)
    scale = grasp.frame.scale
    reference = float(backend.volumes(grasp, np.eye(4))) / scale**3
    volume = intersection_volume(grasp.hand, grasp.object, grasp.object_pose, backend=backend)
    # Not bit-identical: the backend works in the canonical frame (scaled by 2 / depth), this
    # call in metres; the roundings differ by a few 1e-15 relative.
    assert abs(volume - reference) <= 1e-12 * reference
    assert abs(intersection_volume(grasp, backend=backend) - reference) <= 1e-12 * reference
    # A path pose in the canonical frame is, in the hand's metres, M^-1 P M.
    lift = translation(0.0, 0.0, 0.1)
    M = grasp.frame.matrix
    in_hand = np.linalg.solve(M, lift @ M)
    moved = float(backend.volumes(grasp, lift)) / scale**3
    assert 0 < moved < reference
    assert abs(intersection_volume(grasp, poses=in_hand, backend=backend) - moved) <= 1e-12 * moved


# -- command line ---------------------------------------------------------------------------


@pytest.fixture
def mesh_files(tmp_path):
    # Sides that float32 (STL) stores exactly.
    trimesh.creation.box(extents=(0.125, 0.125, 0.125)).export(tmp_path / "a.stl")
    trimesh.creation.box(extents=(62.5, 62.5, 62.5)).export(tmp_path / "b.obj")  # millimetres
    return tmp_path / "a.stl", tmp_path / "b.obj"


def test_overlap_command(mesh_files, tmp_path, capsys):
    a, b = mesh_files
    np.save(tmp_path / "pose.npy", translation(0.0625, 0.0625, 0.0625))
    args = ["overlap", str(a), str(b), "--units", "m,mm"]
    assert main([*args, "--pose", str(tmp_path / "pose.npy")]) == 0
    out = capsys.readouterr().out
    assert out.startswith("volume ") and "m^3 (bound " in out
    assert float(out.split()[1]) == pytest.approx(0.03125**3, rel=1e-12)
    stack = [translation(x).tolist() for x in (0.0, 0.2)]
    (tmp_path / "poses.json").write_text(json.dumps({"poses": stack}))
    assert main([*args, "--pose", str(tmp_path / "poses.json")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == ["pose[0]", "pose[1]"]
    assert float(lines[0].split()[2]) == pytest.approx(0.0625**3, rel=1e-12)
    assert float(lines[1].split()[2]) == 0.0
    assert main([*args, "--pose", json.dumps(translation(0.1).tolist())]) == 0
    assert float(capsys.readouterr().out.split()[1]) == 0.0
    assert main(["overlap", str(a), str(a), "--repair"]) == 0
    assert float(capsys.readouterr().out.split()[1]) == pytest.approx(0.125**3, rel=1e-12)


def test_overlap_command_errors_name_the_flag(mesh_files, tmp_path, capsys):
    a, b = mesh_files
    cases = [
        (["--pose", str(tmp_path / "nope.npy")], "--pose"),
        (["--pose", "[[1, 0], [0, 1]]"], "--pose must have shape"),
        (["--pose", json.dumps(np.diag([2.0, 1, 1, 1]).tolist())], "--pose is not a rigid"),
        (["--units", "km"], "--units 'km'"),
    ]
    for extra, message in cases:
        units = [] if "--units" in extra else ["--units", "m,mm"]
        assert main(["overlap", str(a), str(b), *units, *extra]) == 2
        err = capsys.readouterr().err
        assert err.startswith("exactgrasp overlap: error: ") and message in err, err
    V, F = box_arrays([0, 0, 0], [1, 1, 1])
    trimesh.Trimesh(V, F[1:]).export(tmp_path / "open.stl")
    assert main(["overlap", str(a), str(tmp_path / "open.stl")]) == 2
    assert "B: " in capsys.readouterr().err
    assert main(["overlap", str(a), str(b)]) == 2  # b is in millimetres, read as metres
    assert "pass --units mm" in capsys.readouterr().err
