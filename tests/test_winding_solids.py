"""Closed surfaces that are not 2-manifolds, or cross themselves, read as the solids they bound
(the points of winding number >= 1): volumes against analytic values and libigl's CGAL
arrangement (exact arithmetic), one warning each, messages that name the defect, hands built
from such links, and exact descriptors against the plain boolean of the resolved links."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import exactgrasp as eg
from exactgrasp import MeshError, ModelError, Solid
from exactgrasp.backends.exact import ExactIntersector
from exactgrasp.backends.exact.reference import agrees, plain_volumes
from exactgrasp.geometry.manifold import to_manifold
from exactgrasp.geometry.topology import drop_repeated_faces, edge_defects, split_nonmanifold
from tests.conftest import box_arrays
from tests.messy_meshes import (
    DENTED_VOLUME,
    FIGURE_EIGHT_VOLUME_CGAL,
    FOLDED_VOLUME_CGAL,
    cubes_sharing_an_edge,
    dented_box,
    figure_eight_tube,
    folded_box,
    joined,
    tetrahedra_sharing_a_vertex,
)

CASES = {
    "cubes sharing an edge": (cubes_sharing_an_edge, 2.0, "1 edges shared by more than two"),
    "tetrahedra sharing a vertex": (tetrahedra_sharing_a_vertex, 1 / 3, "merged shells 0"),
    "box dented through its floor": (
        dented_box,
        DENTED_VOLUME,
        "crosses itself in 10 triangle pairs",
    ),
    "box folded through a face": (
        folded_box,
        FOLDED_VOLUME_CGAL,
        "crosses itself in 5 triangle pairs",
    ),
    "figure-eight tube": (figure_eight_tube, FIGURE_EIGHT_VOLUME_CGAL, "(116 triangles split)"),
}


def solid_and_warnings(V, F, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        solid = Solid(V, F, **kwargs)
    return solid, [str(w.message) for w in caught]


def cgal_volume(V, F) -> float:
    cgal = pytest.importorskip("igl.copyleft.cgal", reason="libigl (the dev extra) not installed")
    empty_v, empty_f = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    VC, FC, _ = cgal.mesh_boolean(np.asarray(V, float), np.asarray(F), empty_v, empty_f, "union")
    return float(trimesh.Trimesh(VC, FC, process=False).volume)


@pytest.mark.parametrize("case", CASES)
def test_solid_of_winding_number_at_least_one(case):
    build, volume, action = CASES[case]
    solid, messages = solid_and_warnings(*build(), name=case)
    assert solid.volume == pytest.approx(volume, rel=1e-12)
    # One warning, naming the mesh, what was done and the volume after.
    assert len(messages) == 1 and messages[0].startswith(f"{case}: ")
    assert action in messages[0] and "winding number >= 1" in messages[0]
    assert solid.shell_report["volume_after"] == pytest.approx(volume, rel=1e-12)
    # The result is a solid manifold3d accepts, of the same volume.
    manifold = to_manifold(solid.vertices, solid.faces, case)
    assert manifold.volume() == pytest.approx(volume, rel=1e-12)


@pytest.mark.parametrize("case", CASES)
def test_matches_cgal_arrangement_under_rigid_motions_and_scales(case):
    V, F = CASES[case][0]()
    rng = np.random.default_rng(11)
    for scale, shift in ((1.0, 0.0), (1e-3, 0.5), (1e3, -3e3), (1e-6, 1e-4)):
        R = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
        moved = (V @ R.T) * scale + shift
        solid, _ = solid_and_warnings(moved, F, check_scale=False)
        want = cgal_volume(moved, F)
        assert solid.volume == pytest.approx(want, rel=1e-9), (scale, shift)
        assert want == pytest.approx(CASES[case][1] * scale**3, rel=1e-9)


def test_crumpled_spheres_match_cgal():
    # Spheres with every vertex pushed at random: surfaces folded through themselves many
    # times over, with regions wrapped twice and regions turned inside out.
    rng = np.random.default_rng(0)
    for _ in range(12):
        sphere = trimesh.creation.icosphere(subdivisions=int(rng.integers(1, 3)))
        scale = 1 + rng.normal(scale=rng.uniform(0.2, 0.8), size=(len(sphere.vertices), 1))
        V = sphere.vertices * scale + rng.normal(scale=0.15, size=sphere.vertices.shape)
        solid, _ = solid_and_warnings(V, sphere.faces, check_scale=False)
        assert solid.volume == pytest.approx(cgal_volume(V, sphere.faces), rel=1e-9)


def test_repeated_faces_count_once_and_a_face_and_its_reverse_cancel():
    V, F = box_arrays([0, 0, 0], [1, 1, 1])
    solid, messages = solid_and_warnings(V, np.concatenate([F, F[3:4]]), name="repeated")
    assert solid.volume == pytest.approx(1.0, rel=1e-15)
    assert "dropped 1 repeated and 0 mutually cancelling" in messages[0]
    fin = np.concatenate([F, F[3:4], F[3:4, ::-1]])
    solid, messages = solid_and_warnings(V, fin, name="fin")
    assert solid.volume == pytest.approx(1.0, rel=1e-15)
    assert "dropped 0 repeated and 2 mutually cancelling" in messages[0]
    kept, repeated, cancelled = drop_repeated_faces(np.concatenate([F, F[:2], F[:2]]))
    assert (len(kept), repeated, cancelled) == (12, 4, 0)


def test_inverted_inner_shell_is_a_cavity():
    outer = box_arrays([0, 0, 0], [1, 1, 1])
    inner_v, inner_f = box_arrays([0.25, 0.25, 0.25], [0.75, 0.75, 0.75])
    solid, messages = solid_and_warnings(*joined(outer, (inner_v, inner_f[:, ::-1])))
    assert solid.volume == pytest.approx(1 - 0.125, rel=1e-15)
    assert messages == []  # a cavity is a boundary of the solid as it is


def test_non_manifold_edges_paired_by_solid_wedge():
    V, F = cubes_sharing_an_edge()
    defects = edge_defects(V, F)
    assert (defects.open, defects.misoriented, defects.nonmanifold) == (0, 0, 1)
    np.testing.assert_allclose(defects.nonmanifold_at, [1, 1, 0.5])
    W, G, n_edges, n_split = split_nonmanifold(V, F)
    # Each cube keeps its own copy of the shared edge: two closed manifold shells.
    assert (n_edges, n_split, len(W), len(V)) == (1, 2, 16, 14)
    pieces = trimesh.Trimesh(W, G, process=False).split(only_watertight=True)
    assert sorted(p.volume for p in pieces) == pytest.approx([1.0, 1.0])


def test_open_and_misoriented_edges_are_counted_and_located():
    V, F = box_arrays([0, 0, 0], [1, 1, 1])
    with pytest.raises(MeshError) as info:
        Solid(V, F[:-1], name="open.stl")
    text = str(info.value)
    assert "(3 edges belong to an odd number of faces (holes), e.g. at (" in text
    assert "repair=True" in text and "0 edges" not in text
    flipped = F.copy()
    flipped[0] = flipped[0, ::-1]
    with pytest.raises(MeshError) as info:
        Solid(V, flipped, name="flip.stl")
    text = str(info.value)
    assert "not consistently oriented (3 edges are used twice in the same direction" in text
    assert "e.g. at (" in text and "repair=True to fix the winding" in text


def test_crossing_through_vertices_exactly_is_cut_exactly():
    # A symmetric sphere whose top is pushed straight down through its bottom: its edges pass
    # exactly through the bottom's vertices, so no crossing is certain in floating point; the
    # cut is decided in exact arithmetic.
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    V = np.array(sphere.vertices)
    V[V[:, 2] > 0.031, 2] -= 0.095
    solid, messages = solid_and_warnings(V, sphere.faces, name="pushed")
    assert solid.volume == pytest.approx(cgal_volume(V, sphere.faces), rel=1e-12)
    assert len(messages) == 1 and "in exact arithmetic" in messages[0]
    assert edge_defects(solid.vertices, solid.faces).nonmanifold == 0
    assert to_manifold(solid.vertices, solid.faces).volume() == pytest.approx(
        solid.volume, rel=1e-12
    )


def test_real_objects_are_unchanged(shared_data):
    # Objects whose triangles touch in flat regions (CAD exports) keep their volume and
    # raise nothing new.
    for name in ("SoapDispenser", "SprayBottle", "Chunk_of_foam"):
        path = shared_data / "osu-objects" / f"{name}.STL"
        solid, messages = solid_and_warnings(*_raw(path), units="mm")
        assert messages == []
        raw = trimesh.load(path)
        assert solid.volume == pytest.approx(raw.volume * 1e-9, rel=1e-12)


def _raw(path):
    mesh = trimesh.load(path)
    mesh.merge_vertices()
    return mesh.vertices, mesh.faces


def test_intersection_volume_accepts_messy_objects():
    V, F = figure_eight_tube()
    box = box_arrays([-0.2, -0.3, -0.3], [0.2, 0.3, 0.3])
    with pytest.warns(UserWarning, match="crosses itself"):
        got = eg.intersection_volume(box, (V, F), check_scale=False)
    resolved = Solid(V, F)
    want = plain_volumes([box], [(resolved.vertices, resolved.faces)], np.eye(4)[None])[0]
    assert got == pytest.approx(want, rel=1e-9) and got > 0.01


# -- a hand of messy links ---------------------------------------------------------------------

MJCF = """<mujoco><asset>
  <mesh name="palm" file="palm.stl"/><mesh name="finger" file="finger.stl"/>
  <mesh name="tip" file="tip.stl"/></asset>
  <worldbody><body name="palm"><geom type="mesh" mesh="palm"/>
    <body name="finger" pos="0.02 0 0.09"><joint name="bend" axis="0 1 0" range="-1 1"/>
      <geom type="mesh" mesh="finger"/>
      <body name="tip" pos="0 0 0.03"><geom type="mesh" mesh="tip"/></body></body>
  </body></worldbody></mujoco>"""

# Link meshes in metres: the dented box 8 cm, two 2 cm cubes sharing an edge, the
# figure-eight tube 2 cm long.
LINK_SCALES = {"palm": 0.08, "finger": 0.02, "tip": 0.01}
LINK_VOLUMES = {
    "palm": DENTED_VOLUME * 0.08**3,
    "finger": 2.0 * 0.02**3,
    "tip": FIGURE_EIGHT_VOLUME_CGAL * 0.01**3,
}


@pytest.fixture
def messy_hand_file(tmp_path):
    for name, build in (
        ("palm", dented_box),
        ("finger", cubes_sharing_an_edge),
        ("tip", figure_eight_tube),
    ):
        V, F = build()
        trimesh.Trimesh(V * LINK_SCALES[name], F, process=False).export(tmp_path / f"{name}.stl")
    path = tmp_path / "hand.xml"
    path.write_text(MJCF)
    return path


def test_hand_of_messy_links_loads_with_one_warning(messy_hand_file):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hand = eg.Hand.from_mjcf(messy_hand_file, frame=eg.HandFrame.identity())
    messages = [str(w.message) for w in caught if "resolved" in str(w.message)]
    assert len(messages) == 1, [str(w.message) for w in caught]
    assert "resolved mesh geoms into the solids they bound: " in messages[0]
    for what in ("shared by more than two faces", "crosses itself in 10 triangle pairs"):
        assert what in messages[0]
    assert messages[0].count("into the boundary of the points of winding number >= 1") == 2
    links = dict(zip(hand.link_names, hand.link_arrays(), strict=True))
    for name, volume in LINK_VOLUMES.items():
        V, F = links[name]
        got = float(trimesh.Trimesh(V, F, process=False).volume)
        # float32 mesh storage in MuJoCo moves the vertices by about 1e-7 relative.
        assert got == pytest.approx(volume, rel=1e-6), name
    # The hand's volume is the union of the resolved links.
    union = to_manifold(*links["palm"], "palm")
    for name in ("finger", "tip"):
        union = union + to_manifold(*links[name], name)
    assert hand.volume == pytest.approx(union.volume(), rel=1e-12)


def test_exact_volumes_of_messy_hand_match_plain_boolean(messy_hand_file):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hand = eg.Hand.from_mjcf(messy_hand_file, frame=eg.HandFrame.identity())
    links = list(hand.link_arrays())
    obj = box_arrays([-0.015, -0.02, -0.01], [0.015, 0.02, 0.01])
    rng = np.random.default_rng(23)
    poses = np.repeat(np.eye(4)[None], 12, axis=0)
    poses[:, :3, :3] = Rotation.from_rotvec(rng.normal(scale=0.5, size=(12, 3))).as_matrix()
    poses[:, :3, 3] = rng.uniform([-0.04, -0.04, 0.0], [0.06, 0.04, 0.12], size=(12, 3))
    ex = ExactIntersector(links, [obj], broadphase=None)
    got = ex.volumes(poses)
    want = plain_volumes(links, [obj], poses)
    assert (got > 0).sum() >= 6
    assert agrees(got, want, ex.hand_volume, rtol=1e-9).all()
    # Both backends see the resolved solids: the voxel estimate is near the exact volume.
    grasp = eg.Grasp(hand, eg.Solid(*obj), poses[int(np.argmax(got))])
    sampler = eg.PathSampler(3, 2, 2, n_steps=3)
    exact = eg.compute_descriptor(grasp, sampler, backend="exact").values
    voxel = eg.compute_descriptor(grasp, sampler, backend="voxel").values
    assert exact.max() > 0.01
    # Measured: at most 8e-4 of the hand's volume apart.
    assert np.abs(voxel - exact).max() < 5e-3


def test_model_error_names_open_link(tmp_path):
    V, F = box_arrays([0, 0, 0], [0.02, 0.02, 0.02])
    trimesh.Trimesh(V, F[:-2], process=False).export(tmp_path / "palm.stl")
    (tmp_path / "hand.xml").write_text(
        '<mujoco><asset><mesh name="palm" file="palm.stl"/></asset><worldbody>'
        '<body name="palm"><geom type="mesh" mesh="palm"/></body></worldbody></mujoco>'
    )
    with pytest.raises(ModelError) as info:
        eg.Hand.from_mjcf(tmp_path / "hand.xml", frame=eg.HandFrame.identity())
    text = str(info.value)
    assert "is not a closed surface, even after merging duplicate vertices" in text
    assert "edges belong to an odd number of faces (holes), e.g. at (" in text
    assert "(0 edges" not in text


def test_resolved_links_are_read_back_from_the_disk_cache(messy_hand_file, monkeypatch, tmp_path):
    from exactgrasp.errors import WARNED
    from exactgrasp.hands import geoms, loading

    monkeypatch.setenv("EXACTGRASP_CACHE", str(tmp_path / "cache"))
    calls = []
    real = geoms._weld
    monkeypatch.setattr(geoms, "_weld", lambda *a: calls.append(a[2]) or real(*a))
    loaded = []
    for _ in range(2):
        loading._MODELS.clear()  # the in-memory model cache would hide the disk cache
        WARNED.clear()  # and, as in a new process, nothing said yet
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            hand = eg.Hand.from_mjcf(messy_hand_file, frame=eg.HandFrame.identity())
        loaded.append((hand.link_arrays(), [str(w.message) for w in caught]))
    # Three mesh geoms welded and resolved once; the second load reads them back, with the
    # same warning and bit-identical arrays.
    assert len(calls) == 3
    assert len(list((tmp_path / "cache" / "solids").glob("*.npz"))) == 3
    (first, first_warnings), (second, second_warnings) = loaded
    assert first_warnings == second_warnings and len(first_warnings) >= 1
    for (v1, f1), (v2, f2) in zip(first, second, strict=True):
        assert np.array_equal(v1, v2) and np.array_equal(f1, f2)


def _reversed_box(lo, hi):
    v, f = box_arrays(lo, hi)
    return v, f[:, ::-1]


@pytest.mark.parametrize(
    ("boxes", "volume"),
    [
        # Inside a 3 m box (winding number 1 around): an outward box (2 inside it) crossed by a
        # reversed one (0 where it is alone, 1 where both are): 27 - 0.24 + 0.12.
        (
            [
                ((0, 0, 0), (3, 3, 3), 1),
                ((1, 1, 1), (2, 2, 2), 1),
                ((1.5, 1.2, 1.3), (2.5, 1.8, 1.7), -1),
            ],
            26.88,
        ),
        # Two overlapping outward boxes and a reversed one crossing both: the union (1.28)
        # less the reversed box where exactly one outward box holds it (0.024 + 0.084 - 0.048).
        (
            [
                ((0, 0, 0), (1, 1, 1), 1),
                ((0.5, 0.1, 0.15), (1.5, 0.9, 0.85), 1),
                ((0.8, 0.3, 0.35), (1.7, 0.7, 0.65), -1),
            ],
            1.22,
        ),
    ],
    ids=["inside another shell", "overlapping outward shells"],
)
def test_crossing_outward_and_reversed_shells_are_cut(boxes, volume):
    V, F = joined(
        *((box_arrays(lo, hi) if s > 0 else _reversed_box(lo, hi)) for lo, hi, s in boxes),
        weld=False,
    )
    solid, messages = solid_and_warnings(V, F, name="combo")
    assert solid.volume == pytest.approx(volume, rel=1e-12)
    assert len(messages) == 1 and "along their crossings into the boundary" in messages[0]
    assert cgal_volume(V, F) == pytest.approx(volume, rel=1e-12)
