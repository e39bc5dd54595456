"""Meshes of several closed shells: what is kept, merged, flipped or refused."""

from __future__ import annotations

import json
import warnings

import manifold3d as m3
import numpy as np
import pytest
import trimesh

import exactgrasp as eg
from exactgrasp import MeshError, MeshWarning, Solid
from exactgrasp.errors import WARNED
from exactgrasp.geometry.shells import find_crossings, resolve_shells, split_shells
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.hand import Hand
from tests.conftest import box_arrays
from tests.exact_reference import cgal_volume

# Two overlapping boxes: 0.5^3 + 0.5 * 0.35 * 0.4 - 0.25 * 0.35 * 0.3.
A_LO, A_HI = (0.0, 0.0, 0.0), (0.5, 0.5, 0.5)
B_LO, B_HI = (0.25, 0.1, 0.2), (0.75, 0.45, 0.6)
UNION = 0.125 + 0.07 - 0.02625


def two_shells(*boxes):
    vs, fs, offset = [], [], 0
    for v, f in boxes:
        vs.append(v)
        fs.append(f + offset)
        offset += len(v)
    return np.concatenate(vs), np.concatenate(fs)


def overlapping_boxes():
    return two_shells(box_arrays(A_LO, A_HI), box_arrays(B_LO, B_HI))


def box_manifold(lo, hi):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return m3.Manifold.cube(tuple(hi - lo)).translate(tuple(lo))


def recorded(fn):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fn()
    return result, [str(w.message) for w in caught]


def test_overlapping_boxes_in_one_object_are_merged():
    v, f = overlapping_boxes()
    raw = trimesh.Trimesh(v, f, process=False).volume
    assert raw == pytest.approx(0.195, abs=1e-15)
    solid, messages = recorded(lambda: Solid(v, f, name="two boxes"))
    assert solid.volume == pytest.approx(UNION, abs=1e-12)
    assert len(messages) == 1
    text = messages[0]
    assert text.startswith("two boxes: 2 shells; merged shells 0 (8 vertices), 1 (8 vertices)")
    assert "Volume 0.195 -> 0.16875 m^3" in text
    report = solid.shell_report
    assert report["n_shells"] == 2 and report["crossing_pairs"] > 0
    assert report["volume_before"] == pytest.approx(0.195, abs=1e-15)
    assert report["volume_after"] == pytest.approx(UNION, abs=1e-12)
    assert [s["role"] for s in report["shells"]] == ["merged", "merged"]
    # What every consumer sees is one closed shell of the union.
    n_shells, _ = split_shells(solid.faces, len(solid.vertices))
    assert n_shells == 1
    reference = box_manifold(A_LO, A_HI) + box_manifold(B_LO, B_HI)
    assert solid.area == pytest.approx(reference.surface_area(), abs=1e-12)
    assert solid.centroid == pytest.approx(
        trimesh.Trimesh(*_arrays(reference), process=False).center_mass, abs=1e-12
    )


def _arrays(solid):
    mesh = solid.to_mesh64()
    return np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts, dtype=np.int64)


def mesh_warnings(fn) -> list[str]:
    """The `MeshWarning` s that ``fn`` gives, under a filter that shows every warning."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fn()
    return [str(w.message) for w in caught if issubclass(w.category, MeshWarning)]


def test_a_mesh_is_warned_about_once_per_process():
    v, f = overlapping_boxes()

    def load_and_call():
        for _ in range(3):
            eg.intersection_volume(Solid(v, f, name="twice"), (v, f))  # b: the same mesh again
        Solid(v, f, name="twice")  # from another line

    messages = mesh_warnings(load_and_call)
    assert [m.split(";")[0] for m in messages] == ["twice: 2 shells", "b: 2 shells"]
    assert mesh_warnings(load_and_call) == []
    # Another mesh is another problem; forgetting what was said says it again.
    assert len(mesh_warnings(lambda: Solid(v, f, name="another"))) == 1
    WARNED.clear()
    assert len(mesh_warnings(lambda: Solid(v, f, name="twice"))) == 1


def test_a_grasp_files_object_is_warned_about_once_per_process(tmp_path):
    v, f = overlapping_boxes()
    trimesh.Trimesh(v * 0.1, f, process=False).export(tmp_path / "two-boxes.stl")
    data = {"object": "two-boxes.stl", "object_pose_in_hand": np.eye(4).tolist(),
            "hand": {"type": "builtin", "name": "parallel_gripper"}}  # fmt: skip
    (tmp_path / "g.json").write_text(json.dumps(data))
    messages = mesh_warnings(lambda: [eg.Grasp.from_file(tmp_path / "g.json") for _ in range(3)])
    assert len(messages) == 1 and "two-boxes.stl: 2 shells; merged shells 0" in messages[0]


def test_hand_link_of_two_overlapping_shells():
    v, f = overlapping_boxes()
    far_v, far_f = box_arrays([2, 0, 0], [2.1, 0.1, 0.1])
    hand, messages = recorded(
        lambda: Hand.from_meshes([(v, f), (far_v, far_f)], frame=HandFrame.identity())
    )
    assert hand.volume == pytest.approx(UNION + 0.001, abs=1e-12)
    assert len(messages) == 1 and messages[0].startswith("link0: 2 shells; merged shells 0")


def test_mjcf_mesh_geom_of_two_overlapping_shells(tmp_path):
    pytest.importorskip("mujoco")
    v, f = overlapping_boxes()
    trimesh.Trimesh(v * 0.1, f, process=False).export(tmp_path / "link.stl")
    (tmp_path / "hand.xml").write_text(
        '<mujoco model="two_shells"><asset><mesh name="link" file="link.stl"/></asset>'
        '<worldbody><body name="palm"><geom type="mesh" mesh="link"/></body></worldbody>'
        "</mujoco>"
    )
    hand, messages = recorded(
        lambda: Hand.from_mjcf(tmp_path / "hand.xml", frame=HandFrame.identity())
    )
    # MuJoCo stores vertices in float32: compare to rounding of the coordinates.
    assert hand.volume == pytest.approx(UNION * 1e-3, rel=1e-6)
    assert any("2 shells; merged shells 0 (8 vertices), 1 (8 vertices)" in m for m in messages)


def test_disjoint_cubes_unchanged():
    v, f = two_shells(box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([2, 0, 0], [2.5, 0.5, 0.5]))
    solid, messages = recorded(lambda: Solid(v, f))
    assert messages == []
    assert solid.volume == pytest.approx(1.125, abs=1e-14)
    np.testing.assert_array_equal(solid.faces, f)
    assert [s["role"] for s in solid.shell_report["shells"]] == ["outer", "outer"]
    assert solid.shell_report["actions"] == []


def test_touching_boxes_give_the_sum():
    # A face of one box against part of a face of the other (no shared corner, which
    # `Solid` would weld into a non-manifold edge): contact only, merged, volume the sum.
    v, f = two_shells(box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([1, 0.2, 0.1], [2, 0.8, 0.7]))
    solid, messages = recorded(lambda: Solid(v, f, name="touching"))
    assert solid.volume == pytest.approx(1.36, abs=1e-12)
    assert solid.shell_report["touching_pairs"] > 0
    assert solid.shell_report["crossing_pairs"] == 0
    assert "Volume 1.36 -> 1.36 m^3" in messages[0]
    # Whole faces against each other, corners coincident but not welded.
    v, f = two_shells(box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([1, 0, 0], [2, 1, 1]))
    out_v, out_f, report = resolve_shells(v, f.astype(np.int64), "face to face", warn=print)
    assert trimesh.Trimesh(out_v, out_f, process=False).volume == pytest.approx(2.0, abs=1e-12)
    assert report["touching_pairs"] > 0 and report["crossing_pairs"] == 0


def test_hollow_sphere_is_a_cavity():
    outer = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    inner = trimesh.creation.icosphere(subdivisions=3, radius=0.6)
    v, f = two_shells((outer.vertices, outer.faces), (inner.vertices, inner.faces[:, ::-1]))
    solid, messages = recorded(lambda: Solid(v, f))
    assert messages == []
    expected = outer.volume - inner.volume  # the tessellated shells, not the spheres
    assert solid.volume == pytest.approx(expected, abs=1e-12)
    assert expected == pytest.approx(4 / 3 * np.pi * (1 - 0.6**3), rel=2e-2)
    reference = m3.Manifold(m3.Mesh64(vert_properties=v, tri_verts=f.astype(np.uint64))).volume()
    assert solid.volume == pytest.approx(reference, abs=1e-12)
    assert [s["role"] for s in solid.shell_report["shells"]] == ["outer", "cavity"]


def test_same_orientation_nested_shell_is_dropped():
    v, f = two_shells(
        box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([0.2, 0.2, 0.2], [0.6, 0.6, 0.6])
    )
    solid, messages = recorded(lambda: Solid(v, f, name="double wall"))
    assert solid.volume == pytest.approx(1.0, abs=1e-14)
    assert len(solid.faces) == 12
    assert len(messages) == 1
    assert "dropped shell 1 (8 vertices): it lies inside shell(s) 0 (8 vertices)" in messages[0]
    assert "winding number 2" in messages[0]
    assert "Volume 1.064 -> 1 m^3" in messages[0]
    assert [s["role"] for s in solid.shell_report["shells"]] == ["outer", "redundant"]


def folded_box():
    """A unit box whose corner (1, 1, 1) is pushed through the face x = 0, its edges meeting
    that face exactly on the face's diagonal."""
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    v[7] = [-0.5, 0.5, 0.5]
    return v, f


def test_crossing_exactly_on_an_edge_is_cut_exactly():
    v, f = folded_box()
    solid, messages = recorded(lambda: Solid(v, f, name="folded.stl"))
    assert solid.volume == pytest.approx(cgal_volume(v, f), rel=1e-12)
    assert solid.volume == pytest.approx(7 / 27, rel=1e-12)
    assert len(messages) == 1
    text = messages[0]
    assert text.startswith(
        "folded.stl: cut the surface (8 vertices, 12 triangles), which crosses itself in 4 "
        "triangle pairs and touches itself exactly at edges, corners or in a plane in 2 more "
        "(e.g. near ("
    )
    assert "along every contact in exact arithmetic (6 triangles split)" in text
    # With a clean shell beside it, the message names the shell that was cut.
    v2, f2 = two_shells(box_arrays([3, 0, 0], [4, 1, 1]), folded_box())
    solid, messages = recorded(lambda: Solid(v2, f2))
    assert "cut shell 1 of 2 (8 vertices, 12 triangles)" in messages[0]
    assert solid.volume == pytest.approx(1 + 7 / 27, rel=1e-12)


def test_self_intersection_pairs_and_point():
    v, f = folded_box()
    _, label = split_shells(f, len(v))
    t, _, code, point = find_crossings(v, f, label)
    assert len(t) > 0 and np.all(code == 1)
    # Every crossing lies on the face x = 0 that the pushed corner goes through.
    assert np.all(np.abs(point[:, 0]) < 1e-12)


def test_clean_shells_have_no_crossings():
    sphere = trimesh.creation.icosphere(subdivisions=4)
    _, label = split_shells(sphere.faces, len(sphere.vertices))
    t, *_ = find_crossings(sphere.vertices, sphere.faces, label)
    assert len(t) == 0


def test_inverted_lone_shell_flipped_or_refused():
    v, f = two_shells(box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([2, 0, 0], [2.5, 0.5, 0.5]))
    f[12:] = f[12:, ::-1]
    solid, messages = recorded(lambda: Solid(v, f, name="half inverted"))
    assert solid.volume == pytest.approx(1.125, abs=1e-14)
    assert len(messages) == 1
    assert "flipped inside-out shell(s) 1 (8 vertices)" in messages[0]
    assert "Volume 0.875 -> 1.125 m^3" in messages[0]
    with pytest.raises(
        MeshError,
        match=r"half inverted: shell\(s\) 1 \(8 vertices\) are inside-out.*orientation='flip'",
    ):
        Solid(v, f, name="half inverted", orientation="refuse")


def test_inside_out_hollow_box_is_flipped_whole():
    v, f = two_shells(
        box_arrays([0, 0, 0], [1, 1, 1]), box_arrays([0.2, 0.2, 0.2], [0.6, 0.6, 0.6])
    )
    f[:12] = f[:12, ::-1]  # outer reversed, inner outward: the whole mesh is inside-out
    solid, messages = recorded(lambda: Solid(v, f))
    assert solid.volume == pytest.approx(1 - 0.064, abs=1e-14)
    assert [s["role"] for s in solid.shell_report["shells"]] == ["flipped", "flipped"]
    assert "flipped inside-out shell(s) 0 (8 vertices), 1 (8 vertices)" in messages[0]


def test_box_with_cavity_and_overlapping_box():
    # Outer box with a cavity, and a second box overlapping the outer one away from the
    # cavity: (outer + other) - cavity.
    v, f = two_shells(
        box_arrays([0, 0, 0], [1, 1, 1]),
        box_arrays([0.1, 0.1, 0.1], [0.3, 0.3, 0.3]),
        box_arrays([0.5, 0.5, 0.5], [1.5, 1.2, 1.1]),
    )
    f[12:24] = f[12:24, ::-1]
    solid, _ = recorded(lambda: Solid(v, f))
    assert solid.volume == pytest.approx(1 + 0.42 - 0.5 * 0.5 * 0.5 - 0.008, abs=1e-12)


def test_exact_backend_and_solid_agree_with_manifold():
    from exactgrasp.backends.exact import ExactIntersector

    v, f = overlapping_boxes()
    solid, _ = recorded(lambda: Solid(v, f))
    reference_object = box_manifold(A_LO, A_HI) + box_manifold(B_LO, B_HI)
    assert solid.volume == pytest.approx(reference_object.volume(), abs=1e-12)
    hand_v, hand_f = box_arrays([0.3, 0.05, 0.05], [0.9, 0.3, 0.45])
    hand = m3.Manifold(m3.Mesh64(vert_properties=hand_v, tri_verts=hand_f.astype(np.uint64)))
    poses = np.repeat(np.eye(4)[None], 3, axis=0)
    poses[1, :3, 3] = [0.07, -0.03, 0.02]
    angle = 0.3
    poses[2, :3, :3] = [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0],
                        [0, 0, 1]]  # fmt: skip
    got = ExactIntersector(
        [(hand_v, hand_f)], [(solid.vertices.copy(), solid.faces.copy())], broadphase=None
    ).volumes(poses)
    want = [(hand ^ reference_object.transform(pose[:3, :])).volume() for pose in poses]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert want[0] > 0.03


def test_resolve_shells_keeps_one_clean_shell_as_is():
    v, f = box_arrays([0, 0, 0], [1, 1, 1])
    f = f.astype(np.int64)
    out_v, out_f, report = resolve_shells(v, f, "box")
    assert out_v is v and out_f is f
    assert report["n_shells"] == 1 and report["actions"] == []


def reversed_box(lo, hi):
    v, f = box_arrays(lo, hi)
    return v, f[:, ::-1].copy()


def test_island_inside_a_cavity_is_kept_as_given():
    v, f = two_shells(
        box_arrays([0, 0, 0], [1, 1, 1]),
        reversed_box([0.2, 0.2, 0.2], [0.8, 0.8, 0.8]),
        box_arrays([0.4, 0.4, 0.4], [0.6, 0.6, 0.6]),
    )
    solid, messages = recorded(lambda: Solid(v, f, name="nested"))
    assert messages == []
    np.testing.assert_array_equal(solid.faces, f)
    assert solid.volume == pytest.approx(1 - 0.216 + 0.008, abs=1e-14)
    assert [s["role"] for s in solid.shell_report["shells"]] == ["outer", "cavity", "island"]


def test_overlapping_islands_inside_a_cavity_are_merged():
    v, f = two_shells(
        box_arrays([0, 0, 0], [1, 1, 1]),
        reversed_box([0.1, 0.1, 0.1], [0.9, 0.9, 0.9]),
        box_arrays([0.2, 0.2, 0.2], [0.5, 0.5, 0.5]),
        box_arrays([0.4, 0.4, 0.4], [0.7, 0.7, 0.7]),
    )
    solid, messages = recorded(lambda: Solid(v, f, name="islands"))
    assert solid.volume == pytest.approx(1 - 0.512 + 2 * 0.027 - 0.001, abs=1e-12)
    assert len(messages) == 1 and "merged shells 2 (8 vertices), 3 (8 vertices)" in messages[0]


@pytest.mark.parametrize(
    ("boxes", "volume"),
    [
        # Inside an outer box: an outward box crossed by a reversed one whose edges run
        # exactly through the diagonals of the outward box's faces: 27 less the half of the
        # reversed box that only the outer box holds (0.18).
        (
            [
                ((0, 0, 0), (3, 3, 3), 1),
                ((1, 1, 1), (2, 2, 2), 1),
                ((1.5, 1.2, 1.2), (2.5, 1.8, 1.8), -1),
            ],
            26.82,
        ),
        # Two overlapping outward boxes, and a reversed one crossing both.
        (
            [
                ((0, 0, 0), (1, 1, 1), 1),
                ((0.5, 0.1, 0.1), (1.5, 0.9, 0.9), 1),
                ((0.8, 0.3, 0.3), (1.7, 0.7, 0.7), -1),
            ],
            None,
        ),
    ],
    ids=["inside another shell", "overlapping outward shells"],
)
def test_combinations_with_exact_contacts_are_cut_exactly(boxes, volume):
    v, f = two_shells(
        *(box_arrays(lo, hi) if s > 0 else reversed_box(lo, hi) for lo, hi, s in boxes)
    )
    solid, messages = recorded(lambda: Solid(v, f, name="combo"))
    want = cgal_volume(v, f)
    assert solid.volume == pytest.approx(want, rel=1e-12)
    if volume is not None:
        assert want == pytest.approx(volume, rel=1e-12)
    assert len(messages) == 1 and "in exact arithmetic into the boundary" in messages[0]


def test_repair_does_not_touch_a_closed_shell_that_crosses_itself():
    v, f = folded_box()
    plain, _ = recorded(lambda: Solid(v, f, name="folded.stl"))
    repaired, _ = recorded(lambda: Solid(v, f, name="folded.stl", repair=True))
    assert repaired.repair_report is None
    np.testing.assert_array_equal(repaired.vertices, plain.vertices)
    np.testing.assert_array_equal(repaired.faces, plain.faces)


def test_a_mesh_warning_turned_into_an_error_is_raised_every_time():
    v, f = overlapping_boxes()
    for _ in range(2):
        with warnings.catch_warnings():
            warnings.simplefilter("error", MeshWarning)
            with pytest.raises(MeshWarning, match=r"^strict: 2 shells; merged shells"):
                Solid(v, f, name="strict")
