"""Palms of several shells that meet where floating-point signs cannot decide how (faces in one
plane that overlap, shells touching along edges or sharing corners, an edge exactly through an
edge or a corner, a piece folded through itself), resolved in exact arithmetic: volumes against
CGAL's exact arrangement (and exact rational volumes of box unions), winding numbers against the
input's at sample points, a 2-manifold by index that manifold3d reads with the same volume; the
exact machinery's parts; a fuzzed family drawn by hypothesis with a fixed seed."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import exactgrasp as eg
from exactgrasp import MeshError, Solid
from exactgrasp.geometry.crossings import find_contacts
from exactgrasp.geometry.exact_solid import solid_boundary
from exactgrasp.geometry.manifold import to_manifold
from exactgrasp.geometry.rational import Integers
from exactgrasp.geometry.topology import bounding_faces, edge_defects
from exactgrasp.geometry.triangulation import constrained_delaunay
from tests.degenerate_palms import (
    BOXES,
    PALMS,
    box,
    boxes,
    frames,
    reversed_mesh,
    union_of_boxes,
)
from tests.exact_reference import cgal_volume, mesh_volume, rational_volume
from tests.messy_meshes import DENTED_VOLUME, dented_box, joined

igl = pytest.importorskip("igl", reason="libigl (the dev extra) not installed")

FRAMES = list(frames())


def resolved(V, F, name="palm") -> tuple[Solid, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        solid = Solid(V, F, name=name, check_scale=False)
    return solid, [str(w.message) for w in caught]


def moved(mesh, frame):
    _, scale, rotation, shift, _ = frame
    return mesh[0] @ rotation.T * scale + shift, mesh[1]


def assert_same_solid(V, F, solid: Solid, rng: np.random.Generator, n: int = 600) -> None:
    """At points around the input, the result's winding number is 1 exactly where the
    input's is at least 1, and 0 elsewhere (points on either surface left out)."""
    lo, hi = V.min(0), V.max(0)
    pad = 0.05 * (hi - lo)
    points = lo - pad + rng.random((n, 3)) * (hi - lo + 2 * pad)
    w_in = igl.winding_number(np.asarray(V, float), np.asarray(F, np.int64), points)
    w_out = igl.winding_number(
        np.asarray(solid.vertices, float), np.asarray(solid.faces, np.int64), points
    )
    clear = (np.abs(w_in - np.rint(w_in)) < 1e-6) & (np.abs(w_out - np.rint(w_out)) < 1e-6)
    assert clear.mean() > 0.9
    inside = np.rint(w_in[clear]) >= 1
    np.testing.assert_array_equal(np.rint(w_out[clear]), inside.astype(float))
    assert 0 < inside.sum() < clear.sum()


def assert_clean(solid: Solid, name: str, rel: float) -> None:
    """A 2-manifold by index that manifold3d takes with the same volume."""
    defects = edge_defects(solid.vertices, solid.faces)
    assert defects.is_cycle and defects.nonmanifold == 0
    assert to_manifold(solid.vertices, solid.faces, name).volume() == pytest.approx(
        solid.volume, rel=rel
    )


# -- the palms, in four frames -----------------------------------------------------------------


@pytest.mark.parametrize("frame", FRAMES, ids=[f[0] for f in FRAMES])
@pytest.mark.parametrize("name", PALMS)
def test_palm_resolves_to_the_exact_solid(name, frame):
    V, F = moved(PALMS[name](), frame)
    solid, messages = resolved(V, F, name)
    tolerance = frame[4]
    assert solid.volume == pytest.approx(cgal_volume(V, F), rel=tolerance)
    assert_same_solid(V, F, solid, np.random.default_rng(1))
    assert_clean(solid, name, tolerance)
    # One warning, naming the mesh and the exact cut.
    assert len(messages) == 1 and messages[0].startswith(f"{name}: ")
    assert "in exact arithmetic" in messages[0] and "winding number >= 1" in messages[0]


@pytest.mark.parametrize("name", BOXES)
def test_box_palms_have_their_exact_rational_volumes(name):
    # Every cut of axis-aligned boxes with dyadic corners is dyadic: no rounding at all.
    want = union_of_boxes([(lo, hi) for lo, hi, _ in BOXES[name]])
    for weld in (False, True):
        solid, _ = resolved(*boxes(name, weld))
        assert rational_volume(solid.vertices, solid.faces) == want


def test_the_refused_palm_is_resolved():
    # Two shells crossing along coplanar patches, one of them folded through itself: what the
    # floating-point cut refused ("a patch of the cut surface lies on another part of it").
    V, F = PALMS["folded and plate"]()
    solid, messages = resolved(V, F, "r_palm_col")
    assert solid.volume == pytest.approx(cgal_volume(V, F), rel=1e-12)
    assert solid.volume == pytest.approx(1.0, rel=1e-12)
    assert "coincident faces, along every contact in exact arithmetic" in messages[0]


def test_what_the_floating_point_cut_cannot_decide_is_cut_exactly(monkeypatch):
    # A self-crossing shell whose crossings are all certain takes the floating-point cut; where
    # that cut cannot decide (here made to fail as it does on a patch lying on another), the
    # exact cut resolves the same solid.
    from exactgrasp.errors import UncertainCrossingError
    from exactgrasp.geometry import untangle

    def undecided(*args):
        raise UncertainCrossingError(
            "a patch of the cut surface lies on another part of it", np.zeros(3)
        )

    V, F = dented_box()
    float_solid, _ = resolved(V, F, "dented")
    monkeypatch.setattr(untangle, "winding_layers", undecided)
    solid, messages = resolved(V, F, "dented")
    assert "along every contact in exact arithmetic" in messages[0]
    assert solid.volume == pytest.approx(DENTED_VOLUME, rel=1e-12)
    assert solid.volume == pytest.approx(float_solid.volume, rel=1e-12)
    assert_clean(solid, "dented", 1e-12)


def palm_hand(folder, V, F, **options) -> eg.Hand:
    """A hand of one body whose mesh geom is (V, F) in metres, written as STL and MJCF in
    ``folder`` and loaded as a model is."""
    trimesh.Trimesh(V, F, process=False).export(folder / "palm.stl")
    (folder / "hand.xml").write_text(
        '<mujoco><asset><mesh name="palm" file="palm.stl"/></asset><worldbody>'
        '<body name="palm"><geom type="mesh" mesh="palm"/></body></worldbody></mujoco>'
    )
    return eg.Hand.from_mjcf(folder / "hand.xml", frame=eg.HandFrame.identity(), **options)


def test_a_hand_with_a_degenerate_palm_loads(tmp_path):
    pytest.importorskip("mujoco")
    V, F = PALMS["coplanar plates"]()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hand = palm_hand(tmp_path, V * 0.08, F)
    assert any("in exact arithmetic" in str(w.message) for w in caught)
    (link,) = hand.link_arrays()
    assert edge_defects(*link).nonmanifold == 0
    # MuJoCo keeps float32 vertices: the volume to their rounding.
    want = float(union_of_boxes([(lo, hi) for lo, hi, _ in BOXES["coplanar plates"]]))
    assert hand.volume == pytest.approx(want * 0.08**3, rel=1e-6)


@pytest.mark.parametrize("name", PALMS)
def test_rotated_palms_match_cgal_and_manifold3d_never_misreads_silently(name):
    # Rotated in floating point, faces built in one plane are within rounding of it: the cut
    # is still exact (as CGAL's), and where its slivers are thinner than manifold3d's
    # tolerance, manifold3d's reading is refused rather than trusted.
    q = np.linalg.qr(np.random.default_rng(5).normal(size=(3, 3)))[0]
    q *= np.sign(np.linalg.det(q))
    V, F = PALMS[name]()
    V = V @ q.T + [700.3, -650.7, 811.1]
    solid, _ = resolved(V, F, name)
    assert solid.volume == pytest.approx(cgal_volume(V, F), rel=1e-9)
    assert_same_solid(V, F, solid, np.random.default_rng(2))
    assert edge_defects(solid.vertices, solid.faces).nonmanifold == 0
    try:
        manifold = to_manifold(solid.vertices, solid.faces, name)
    except MeshError as exc:
        assert "manifold3d reads a volume of" in str(exc) and "near (" in str(exc)
    else:
        assert manifold.volume() == pytest.approx(solid.volume, rel=1e-8)


# -- what is kept or refused -------------------------------------------------------------------


def test_coincident_faces_of_closed_shells_are_kept_and_a_stray_copy_dropped():
    V, F = boxes("stacked plates", weld=True)
    G, repeated, cancelled, defects = bounding_faces(V, F)
    assert defects.is_cycle and repeated == 0 and len(G) == len(F) - cancelled
    W, H = box([0, 0, 0], [1, 1, 1])
    G, repeated, cancelled, defects = bounding_faces(W, np.concatenate([H, H[:1]]))
    assert (len(G), repeated, cancelled, defects.is_cycle) == (12, 1, 0, True)


def test_a_surface_with_no_solid_is_refused():
    V, F = joined(reversed_mesh(box([0, 0, 0], [1, 1, 1])), box([0, 0, 0], [1, 1, 1]))
    with pytest.raises(MeshError, match=r"^empty: .*bounds no solid"):
        Solid(V, F, name="empty")


def test_an_open_surface_is_still_refused():
    V, F = box([0, 0, 0], [1, 1, 1])
    with pytest.raises(MeshError, match=r"odd number of faces \(holes\), e\.g\. at \("):
        Solid(V, F[:-1], name="open")


# -- the parts ---------------------------------------------------------------------------------


def test_coordinates_become_integers_and_round_back_exactly():
    V = np.array([[0.1, -2.5, 3e-17], [1e3, 0.0, -7.25], [5e-310, 1.0, 2.0]])
    ints = Integers(V)
    for k, row in enumerate(V):
        p = ints.point(k)
        assert p[3] == 1 and ints.to_float(p) == list(row)


def test_overlapping_triangles_tile_their_overlap_alike():
    # A rectangle (four points on one circle) inside two different triangles: the constrained
    # Delaunay triangulation, ties broken by rank, tiles it the same way in both.
    rectangle = [(1, 1), (3, 1), (3, 2), (1, 2)]
    segments = [(3, 4), (4, 5), (5, 6), (6, 3)]
    inner = []
    for corners in ([(0, 0), (8, 0), (0, 8)], [(-1, -1), (9, 0), (2, 9)]):
        xy = corners + rectangle
        points = [(x, y, 0, 1) for x, y in xy]
        tiles = constrained_delaunay(
            points, [(float(x), float(y)) for x, y in xy], [9, 8, 7, 0, 1, 2, 3], segments, 0, 1
        )
        inner.append(sorted(tuple(sorted(t)) for t in tiles if min(t) >= 3))
    assert inner[0] == inner[1] and len(inner[0]) == 2


def test_neighbours_in_a_flat_region_are_not_contacts_but_a_fold_is():
    V, F = box([0, 0, 0], [1, 1, 1], 4)
    t, _ = find_contacts(V, F, np.arange(len(V)))
    assert len(t) == 0
    folded = V.copy()
    centre = np.flatnonzero(np.all(V == [0.5, 0.5, 1.0], axis=1))[0]
    folded[centre] = [0.5, 0.5, 0.0]  # pushed onto the bottom face
    t, _ = find_contacts(folded, F, np.arange(len(V)))
    assert len(t) > 0


def test_a_surface_that_is_its_solids_boundary_comes_back_as_it_is():
    V, F = joined(box([0, 0, 0], [1, 1, 1]), box([1, 1, 0], [2, 2, 1]), weld=False)
    W, G, report = solid_boundary(V, F)
    assert W is V and G is F and not report["changed"]


# -- fuzzed: boxes on a dyadic grid ------------------------------------------------------------


@st.composite
def box_palms(draw):
    """2 to 4 boxes on a grid of quarters (faces often in one plane, edges on edges), some
    split finer, maybe a pocket inside the first, and a frame."""
    parts, spans = [], []
    for _ in range(draw(st.integers(2, 4))):
        lo = np.array(draw(st.lists(st.integers(0, 5), min_size=3, max_size=3))) / 4
        size = np.array(draw(st.lists(st.integers(1, 4), min_size=3, max_size=3))) / 4
        parts.append(box(lo, lo + size, draw(st.integers(1, 2))))
        spans.append((lo, lo + size))
    pocket = draw(st.booleans())
    if pocket:
        lo0, hi0 = spans[0]
        lo = lo0 + np.array(draw(st.lists(st.integers(0, 1), min_size=3, max_size=3))) / 8
        hi = np.minimum(hi0, lo + 1 / 8)
        parts.append(reversed_mesh(box(lo, hi)))
    mesh = joined(*parts, weld=draw(st.booleans()))
    return mesh, FRAMES[draw(st.integers(0, len(FRAMES) - 1))], spans, pocket


@settings(
    max_examples=30,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(box_palms())
def test_fuzzed_box_palms_match_cgal(case):
    mesh, frame, spans, pocket = case
    V, F = moved(mesh, frame)
    solid, _ = resolved(V, F)
    assert solid.volume == pytest.approx(cgal_volume(V, F), rel=frame[4])
    if frame[0] == "as built" and not pocket:
        assert rational_volume(solid.vertices, solid.faces) == union_of_boxes(spans)
    assert_same_solid(V, F, solid, np.random.default_rng(3), n=300)
    assert_clean(solid, "fuzzed palm", frame[4])


def test_a_hand_whose_palm_crosses_itself_along_coplanar_patches_loads_with_repair(tmp_path):
    # Two shells crossing along coplanar patches, one folded through itself, as a hand's palm
    # geom with repair=True (a closed surface is never repaired: it is resolved). MuJoCo keeps
    # the vertices in float32 about the mesh's centre, so the volume is the exact solid's to
    # that rounding; the same solid against CGAL to 1e-12 is the test above.
    pytest.importorskip("mujoco")
    V, F = PALMS["folded and plate"]()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hand = palm_hand(tmp_path, V * 0.08, F, repair=True)
    assert any("in exact arithmetic" in str(w.message) for w in caught)
    (link,) = hand.link_arrays()
    assert edge_defects(*link).nonmanifold == 0
    assert mesh_volume(*link) == pytest.approx(0.08**3, rel=1e-6)  # the solid: 1.0 unscaled
    assert hand.volume == pytest.approx(mesh_volume(*link), rel=1e-9)
