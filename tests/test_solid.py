import warnings

import numpy as np
import pytest
import trimesh

from exactgrasp import MeshError, Solid
from tests.conftest import box_arrays


def test_box_volume_and_units():
    v, f = box_arrays([0, 0, 0], [10, 20, 30])
    solid = Solid(v, f, units="mm")
    assert solid.volume == pytest.approx(6000e-9, rel=1e-12)
    assert solid.extent == pytest.approx(0.03)
    assert Solid(v, f, units="cm").volume == pytest.approx(6e-3, rel=1e-12)
    assert Solid(v, f, units="inch").volume == pytest.approx(6000 * 0.0254**3, rel=1e-12)


def test_unknown_units():
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    with pytest.raises(MeshError, match="units='furlong' is not known"):
        Solid(v, f, units="furlong")


def test_missing_file(tmp_path):
    with pytest.raises(MeshError, match=r"nothere\.stl: no such file"):
        Solid.from_file(tmp_path / "nothere.stl")


def test_nan_coordinates():
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    v[3, 1] = np.nan
    with pytest.raises(MeshError, match="1 vertices have NaN or infinite coordinates"):
        Solid(v, f, name="nanbox")


def test_nan_in_file(tmp_path):
    v, f = box_arrays([0, 0, 0], [0.1, 0.1, 0.1])
    v[0, 0] = np.inf
    path = tmp_path / "inf.stl"
    trimesh.Trimesh(v, f, process=False).export(path)
    with pytest.raises(MeshError, match=r"inf\.stl: .* NaN or infinite"):
        Solid.from_file(path)


def test_empty_mesh():
    with pytest.raises(MeshError, match="the mesh is empty"):
        Solid(np.zeros((0, 3)), np.zeros((0, 3), int), name="empty")


def test_points_only_file(tmp_path):
    path = tmp_path / "cloud.ply"
    trimesh.PointCloud(np.random.default_rng(0).random((10, 3))).export(path)
    with pytest.raises(
        MeshError,
        match=r"cloud\.ply: holds a point cloud of 10 points and no faces; .*"
        r"`surface_samples` \(the grasp file's \"object_surface_samples\"\)",
    ):
        Solid.from_file(path)


@pytest.mark.parametrize(
    ("name", "content", "size"),
    [("empty.stl", b"", 0), ("empty.ply", b"", 0), ("none.stl", bytes(84), 84)],
)
def test_empty_mesh_file_is_called_empty_not_a_point_cloud(tmp_path, name, content, size):
    """A file of no bytes, or a binary STL header with 0 triangles: no word of surface samples."""
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(MeshError) as caught:
        Solid.from_file(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: holds no triangles and no points ({size} bytes)")
    assert "Export the mesh again" in message and "surface_samples" not in message


def test_open_mesh_refused_with_repair_hint():
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    with pytest.raises(MeshError, match=r"open box: not a closed surface .*repair=True"):
        Solid(v, f[:-1], name="open box")


def test_inconsistent_winding_refused():
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    f = f.copy()
    f[0] = f[0][::-1]
    with pytest.raises(MeshError, match="not consistently oriented.*repair=True"):
        Solid(v, f)


def test_inside_out_flipped_with_warning_or_refused():
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    with pytest.warns(UserWarning, match="inside-out .* flipped"):
        solid = Solid(v, f[:, ::-1], name="inverted")
    assert solid.volume == pytest.approx(1.0)
    with pytest.raises(MeshError, match=r"signed volume is -1 .*inside-out.*orientation='flip'"):
        Solid(v, f[:, ::-1], orientation="refuse")


def test_bad_face_indices():
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    with pytest.raises(MeshError, match="faces index vertices outside 0..7"):
        Solid(v, f + 1)


def test_millimetres_read_as_metres():
    v, f = box_arrays([0, 0, 0], [300, 50, 200])
    with pytest.raises(MeshError, match="too large for a grasped object.*units='mm'"):
        Solid(v, f)
    assert Solid(v, f, check_scale=False).volume == pytest.approx(3e6)


def test_foodclip_is_open_and_repairs_to_two_halves(shared_data):
    path = shared_data / "osu-objects" / "FoodClip.STL"
    with pytest.raises(MeshError, match=r"FoodClip\.STL: not a closed surface.*repair=True"):
        Solid.from_file(path, units="mm")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        solid = Solid.from_file(path, units="mm", repair=True)
    # the shared data's own closing (4 planar caps, two halves): 99,902 mm^3
    assert solid.volume == pytest.approx(99_902e-9, rel=1e-3)
    report = solid.repair_report
    # The two halves touch face to face: merged into the solid they bound, same volume.
    assert report["volume_after"] == pytest.approx(solid.volume, rel=1e-12)
    assert solid.shell_report["n_shells"] == 2
    assert solid.shell_report["crossing_pairs"] == 0
    assert [s["role"] for s in solid.shell_report["shells"]] == ["merged", "merged"]
    assert report["volume_before"] == pytest.approx(1.0005e-4, rel=1e-3)
    assert any("volume" in str(w.message) and "->" in str(w.message) for w in caught)
    assert len(solid.to_trimesh().split()) == 2


def test_spray_bottle_reads_in_millimetres(shared_data):
    solid = Solid.from_file(shared_data / "osu-objects" / "SprayBottle.STL", units="mm")
    assert solid.volume == pytest.approx(1.22924e-3, rel=1e-5)  # shared data README
    assert len(solid.faces) == 11144


def test_surface_samples_units(shared_data):
    obj = shared_data / "osu-objects"
    solid = Solid.from_file(
        obj / "SprayBottle.STL", units="mm", surface_samples=obj / "SprayBottle_P.ply"
    )
    samples = solid.surface_samples
    assert samples.shape[1] == 3 and len(samples) > 1000
    lo, hi = solid.bounds
    assert np.all(samples >= lo - 1e-3) and np.all(samples <= hi + 1e-3)


def test_transformed_and_hash():
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    solid = Solid(v, f)
    moved = solid.transformed(np.diag([1.0, 1.0, 1.0, 1.0]) + np.eye(4) * 0)
    assert moved.hash == solid.hash
    shift = np.eye(4)
    shift[:3, 3] = [1, 2, 3]
    assert solid.transformed(shift).hash != solid.hash
    assert solid.transformed(shift).volume == pytest.approx(1.0)


def test_repair_of_an_open_box_is_reported(tmp_path):
    closed = trimesh.creation.box((0.1, 0.1, 0.1))
    path = tmp_path / "open.stl"
    trimesh.Trimesh(closed.vertices, closed.faces[1:], process=False).export(path)
    with pytest.raises(MeshError, match="repair=True"):
        Solid.from_file(path)
    with pytest.warns(UserWarning, match=r"repaired \(filled holes"):
        solid = Solid.from_file(path, repair=True)
    assert solid.volume == pytest.approx(1e-3, rel=1e-6)
    assert solid.repair_report["actions"] == ["filled holes (trimesh)"]
    assert solid.repair_report["volume_before"] == pytest.approx(0.75e-3, rel=1e-6)


def test_a_mesh_repair_cannot_close_is_refused_naming_it_and_the_fix():
    pytest.importorskip("pymeshfix", reason="repair needs the repair extra (pymeshfix)")
    triangle = np.array([[0.0, 0, 0], [0.01, 0, 0], [0, 0.01, 0]])
    # np.errstate: trimesh divides by the zero area of what pymeshfix leaves of the sheet.
    with pytest.raises(MeshError) as info, np.errstate(invalid="ignore", divide="ignore"):
        Solid(triangle, np.array([[0, 1, 2]]), name="sheet.stl", repair=True)
    message = str(info.value)
    assert message.startswith("sheet.stl: repair=True could not close the surface (after: ")
    assert "closed with pymeshfix" in message
    assert message.endswith(
        "fix the mesh in a modeller (e.g. MeshLab, Blender's 3D-print toolbox)."
    )


def test_the_plausible_size_is_5_metres():
    # The longest side decides: 4.99 m is taken as metres, 5.01 m is refused as millimetres.
    v, f = box_arrays([0, 0, 0], [4.99, 0.1, 0.1])
    assert Solid(v, f).extent == pytest.approx(4.99)
    v, f = box_arrays([0, 0, 0], [5.01, 0.1, 0.1])
    with pytest.raises(MeshError, match=r"^<array mesh>: 5\.01 m long in units='m', too large"):
        Solid(v, f)
    assert Solid(v, f, units="mm").extent == pytest.approx(5.01e-3)
