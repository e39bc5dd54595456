"""Articulated models through mujoco: FK against real exports, joints, bad input, Barrett."""

import gzip
import json
import re
import warnings

import numpy as np
import pytest
import trimesh

pytest.importorskip("mujoco", reason="the models extra (mujoco) is not installed")

from exactgrasp.datapath import data_dir
from exactgrasp.errors import JointError, ModelError
from exactgrasp.hands import PalmSpec, load_model

DATA = data_dir() / "barrett-grasps"
URDF = DATA / "hand" / "barrett.urdf"
needs_data = pytest.mark.skipif(
    not URDF.is_file(), reason=f"shared Barrett data not found at {DATA} (FK checks need it)"
)
LINK_ORDER = ["palm", "finger_1_prox", "finger_1_med", "finger_1_dist", "finger_2_prox",
              "finger_2_med", "finger_2_dist", "finger_3_med", "finger_3_dist"]  # fmt: skip
POSED = ["obj5_sub5_grasp5_optimal0_target", "obj5_sub6_grasp3_optimal0_target",
         "obj5_sub4_grasp4_extreme2_target"]  # fmt: skip


def _closed(V, F):
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    directed = {tuple(e) for e in edges.tolist()}
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    volume = np.einsum("ij,ij->", a, np.cross(b, c)) / 6
    return len(directed) == len(edges) and all((y, x) in directed for x, y in directed), volume


def _stl_triangles(path):
    raw = gzip.decompress(path.read_bytes())
    count = int(np.frombuffer(raw, np.uint32, 1, 80)[0])
    rec = np.frombuffer(raw, np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                        count, 84)  # fmt: skip
    return rec["v"].astype(np.float64)


@pytest.fixture(scope="module")
def urdf_model():
    if not URDF.is_file():
        pytest.skip(f"shared Barrett data not found at {DATA}")
    return load_model(URDF)


@needs_data
@pytest.mark.parametrize("name", POSED)
def test_fk_reproduces_posed_exports(urdf_model, name):
    grasp = json.loads((DATA / "grasps" / f"{name}.json").read_text())
    links = {n: (V, F) for n, V, F in urdf_model.link_meshes(grasp["joints"])}
    assert sorted(links) == sorted(LINK_ORDER)
    ours = np.concatenate([links[n][0][links[n][1]] for n in LINK_ORDER])
    ref = _stl_triangles(DATA / "grasps" / f"{name}_posed_hand.stl.gz")
    assert ours.shape == ref.shape
    assert np.abs(ours - ref).max() < 5e-5  # 0.05 mm; measured 1.5e-8 .. 1.7e-8 m


@needs_data
def test_urdf_links_are_welded_and_closed(urdf_model):
    total = 0.0
    for name, V, F in urdf_model.link_meshes(urdf_model.default_joints):
        closed, volume = _closed(V, F)
        assert closed and volume > 0, name
        total += volume
    assert total == pytest.approx(6.41254e-4, rel=1e-4)  # README: sum of the 9 link volumes


@needs_data
def test_urdf_names_limits_and_palm(urdf_model):
    assert urdf_model.joint_names[0] == "finger_1_prox_joint" and len(urdf_model.joint_names) == 8
    assert urdf_model.joint_limits["finger_1_dist_joint"] == (0.0, 0.837)
    assert urdf_model.palm == PalmSpec((0, 0, 0.08), (0, 0, 1), (0, 1, 0), 0.085)
    assert load_model(URDF, palm=False).palm is None


@needs_data
def test_urdf_visual_geometry(urdf_model):
    both = load_model(URDF, geometry="all", palm=False)
    assert len(both.link_names) == 18 and all("/" in n for n in both.link_names)
    visual = load_model(URDF, geometry="visual", palm=False)
    assert visual.link_names == urdf_model.link_names


@needs_data
def test_urdf_mimic_becomes_a_coupling(tmp_path):
    for stl in URDF.parent.glob("*.stl"):
        (tmp_path / stl.name).symlink_to(stl)
    limit = '<limit lower="0" upper="3.14159265" effort="5" velocity="2"/>'
    text = URDF.read_text()
    i = text.index("<axis", text.index('name="finger_2_prox_joint"'))
    text = text[:i] + text[i:].replace(
        limit, limit + '<mimic joint="finger_1_prox_joint" multiplier="1"/>', 1
    )
    model = load_model(_write(tmp_path, text, "mimic.urdf"), palm=False)
    assert "finger_2_prox_joint" not in model.joint_names
    assert model.couplings == {"finger_2_prox_joint": ("finger_1_prox_joint", 1.0, 0.0)}


@needs_data
def test_joint_limit_tolerance(urdf_model):
    q = urdf_model.check_joints({"finger_1_dist_joint": 0.837758})
    assert q["finger_1_dist_joint"] == 0.837758  # inside the 1e-3 slack, kept as recorded
    with pytest.raises(JointError, match=r"finger_1_dist_joint.*0\.9.*on_limit='clip'"):
        urdf_model.check_joints({"finger_1_dist_joint": 0.9})
    with pytest.warns(UserWarning, match="clipped"):
        q = urdf_model.check_joints({"finger_1_dist_joint": 0.9}, on_limit="clip")
    assert q["finger_1_dist_joint"] == 0.837
    with pytest.raises(JointError, match="on_limit"):
        urdf_model.check_joints({}, on_limit="ignore")


@needs_data
def test_unknown_and_bad_joint_values(urdf_model):
    with pytest.raises(JointError, match=r"thumb_joint.*finger_3_dist_joint"):
        urdf_model.check_joints({"thumb_joint": 0.1})
    with pytest.raises(JointError, match="not a number"):
        urdf_model.check_joints({"finger_1_med_joint": "open"})
    with pytest.raises(JointError, match="not finite"):
        urdf_model.check_joints({"finger_1_med_joint": float("nan")})


HAND = """
    <body name="hand" pos="0.1 0.2 0.5" euler="0 90 0">
      <freejoint/>
      <geom name="palm" type="box" size="0.04 0.04 0.01"/>
      <site name="face" pos="0 0 0.01"/>
      <body name="finger" pos="0 0.04 0.01">
        <joint name="{j1}" axis="1 0 0" range="0 90"/>
        <geom name="phalanx" type="capsule" fromto="0 0 0 0 0.04 0" size="0.008"/>
        <geom name="pad" type="sphere" pos="0 0.045 0" size="0.008"/>
        <body name="tip" pos="0 0.05 0">
          <joint name="{j2}" axis="1 0 0" range="0 90"/>
          <geom type="cylinder" fromto="0 0 0 0 0.03 0" size="0.007"/>
          <geom type="ellipsoid" pos="0 0.03 0" size="0.007 0.01 0.007" contype="0"
                conaffinity="0"/>
        </body>
      </body>
    </body>"""
SCENE = f"""<mujoco model="scene">
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="table" pos="0 0 0.2"><geom name="top" type="box" size="0.5 0.5 0.02"/></body>
    {HAND.format(j1="knuckle", j2="tip_joint")}
  </worldbody>
  <equality><joint joint1="tip_joint" joint2="knuckle" polycoef="0 0.5 0 0 0"/></equality>
</mujoco>"""


def _write(tmp_path, text, name="model.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_scene_root_body_drops_floor_and_table(tmp_path):
    path = _write(tmp_path, SCENE)
    palm = {"site": "face", "normal": "+z", "up": "+y", "depth": 0.06}
    with pytest.warns(
        UserWarning,
        match=r"outside root body 'hand': floor \(plane in world\), top \(box in table\)",
    ):
        model = load_model(path, root_body="hand", palm=palm)
    assert model.joint_names == ("knuckle",) and "tip_joint" in model.couplings
    assert model.joint_limits["knuckle"] == pytest.approx((0.0, np.pi / 2))
    assert model.link_names == ("hand", "finger/phalanx", "finger/pad", "tip")
    # Link meshes come out in the root body's frame, whatever the hand's pose in the scene.
    palm_v = model.link_meshes({})[0][1]
    assert np.allclose(palm_v.min(axis=0), (-0.04, -0.04, -0.01))
    assert np.allclose(model.palm.origin, (0, 0, 0.01)) and model.palm.depth == 0.06
    assert np.allclose([model.palm.normal, model.palm.up], [(0, 0, 1), (0, 1, 0)])
    bent = dict((n, v) for n, v, _ in model.link_meshes({"knuckle": np.pi / 2}))
    tip_axis = bent["tip"].mean(axis=0) - bent["finger/phalanx"][:, :].min(axis=0)
    assert bent["tip"][:, 2].max() > 0.08 and tip_axis[1] < 0.04  # closed and folded back
    # The same geoms left out again: said once per process.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        everything = load_model(path, root_body="hand", geometry="all", palm=palm)
    assert not caught
    assert everything.link_names[-1].startswith("tip/")


def test_explicit_couplings_and_dependent_joint_values(tmp_path):
    text = SCENE.replace("<equality>", "<!--").replace("</equality>", "-->")
    with pytest.warns(UserWarning):
        model = load_model(_write(tmp_path, text), root_body="hand",
                           couplings={"tip_joint": ("knuckle", 0.5)})  # fmt: skip
    assert model.all_joint_values({"knuckle": 1.0}) == {"knuckle": 1.0, "tip_joint": 0.5}
    assert model.check_joints({"knuckle": 1.0, "tip_joint": 0.5}) == {"knuckle": 1.0}
    with pytest.raises(JointError, match="contradicts its coupling"):
        model.check_joints({"knuckle": 1.0, "tip_joint": 0.9})
    with pytest.raises(ModelError, match="not a hinge/slide joint"):
        load_model(_write(tmp_path, text), root_body="hand", couplings={"x": ("knuckle", 1)})


def test_missing_mesh_file(tmp_path):
    text = """<mujoco><asset><mesh name="m" file="finger_missing.stl"/></asset>
      <worldbody><body name="b"><geom type="mesh" mesh="m"/></body></worldbody></mujoco>"""
    path = _write(tmp_path, text, "hand.xml")
    with pytest.raises(ModelError, match=r"hand\.xml.*finger_missing\.stl.*does not exist"):
        load_model(path)


@pytest.mark.filterwarnings("ignore:.*left out of the hand")
def test_no_geometry_and_bad_options(tmp_path):
    empty = _write(tmp_path, '<mujoco><worldbody><body name="b"><joint name="j"/><site name="s"/>'
                   '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body></worldbody>'
                   "</mujoco>")  # fmt: skip
    with pytest.raises(ModelError, match="no collision geometry"):
        load_model(empty)
    with pytest.raises(ModelError, match="does not exist"):
        load_model(tmp_path / "nowhere.xml")
    path = _write(tmp_path, SCENE)
    with pytest.raises(ModelError, match=r"root_body 'paw'.*hand"):
        load_model(path, root_body="paw")
    with pytest.raises(ModelError, match="geometry must be"):
        load_model(path, geometry="render")
    with pytest.raises(ModelError, match="perpendicular"):
        load_model(path, root_body="hand", palm={"normal": "+z", "up": "+z", "depth": 0.1})


def _mjcf(body: str, asset: str = "") -> str:
    """A model of one top-level body holding ``body``."""
    return f"<mujoco><asset>{asset}</asset><worldbody>{body}</worldbody></mujoco>"


BOX_GEOM = '<geom type="box" size="0.01 0.01 0.01"{}/>'


@pytest.mark.filterwarnings("ignore:.*left out of the hand")
def test_no_geometry_says_what_to_do(tmp_path):
    visual = BOX_GEOM.format(' contype="0" conaffinity="0"')
    path = _write(tmp_path, _mjcf(f'<body name="b">{visual}</body>'), "visual.xml")
    with pytest.raises(
        ModelError,
        match=r"visual\.xml: no collision geometry in the hand's subtree \(root 'world'\); 1 "
        r"geom\(s\) of the other kind exist: try geometry='all'$",
    ):
        load_model(path, palm=False)
    assert load_model(path, palm=False, geometry="all").link_names == ("b",)
    body = f'<body name="mount"><body name="hand"/>{BOX_GEOM.format("")}</body>'
    path = _write(tmp_path, _mjcf(body), "split.xml")
    with pytest.raises(
        ModelError,
        match=r"no collision geometry in the hand's subtree \(root 'hand'\); pass root_body= "
        r"naming the body whose subtree holds the hand's geoms$",
    ):
        load_model(path, root_body="hand", palm=False)
    path = _write(tmp_path, _mjcf('<body name="b"><site name="s"/></body>'), "empty.xml")
    with pytest.raises(
        ModelError,
        match=r"\(root 'world'\); the model has no solid geom \(box, sphere, capsule, cylinder, "
        r"ellipsoid or mesh\): add the hand's geoms to the model file$",
    ):
        load_model(path, palm=False)


def test_missing_model_file_names_it_and_where_relative_paths_start(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(
        ModelError,
        match=r"^hand model file 'hands/nowhere\.urdf' does not exist; check the path \(a "
        rf"relative path is resolved from {re.escape(str(tmp_path))}\)$",
    ):
        load_model("hands/nowhere.urdf")


def test_a_model_mujoco_cannot_compile_gives_mujocos_message(tmp_path):
    bad = _write(
        tmp_path, _mjcf('<body name="b"><geom type="box" size="-1 1 1"/></body>'), "bad.xml"
    )
    with pytest.raises(ModelError, match=r"bad\.xml: mujoco cannot compile the model: Error: "):
        load_model(bad, palm=False)
    torn = _write(tmp_path, '<mujoco><worldbody><body name="b">', "torn.xml")
    with pytest.raises(ModelError, match=r"torn\.xml: mujoco cannot compile the model: XML parse"):
        load_model(torn, palm=False)


def test_inside_out_mesh_geom_is_flipped_with_a_warning(tmp_path):
    box = trimesh.creation.box((0.02, 0.03, 0.04))
    trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False).export(tmp_path / "inv.stl")
    body = '<body name="b"><geom name="g" type="mesh" mesh="m"/></body>'
    path = _write(tmp_path, _mjcf(body, '<mesh name="m" file="inv.stl"/>'), "inv.xml")
    with pytest.warns(UserWarning, match=r"mesh geom 'g' of body 'b' is inside-out \(negative "
                      r"volume\); its faces were flipped"):  # fmt: skip
        model = load_model(path, palm=False)
    ((_, V, F),) = model.link_meshes({})
    assert trimesh.Trimesh(V, F, process=False).volume == pytest.approx(2.4e-5, rel=1e-6)


def test_slide_joint_limit_slack_is_1e_5_metres(tmp_path):
    finger = '<joint name="s" type="slide" axis="0 1 0" range="0 0.04"/>' + BOX_GEOM.format("")
    body = (
        f'<body name="b">{BOX_GEOM.format("")}<body name="f" pos="0 0.05 0">{finger}</body></body>'
    )
    model = load_model(_write(tmp_path, _mjcf(body), "slide.xml"), palm=False)
    assert model.check_joints({"s": 0.04 + 0.9e-5}) == {"s": 0.04 + 0.9e-5}  # kept as given
    with pytest.raises(JointError, match=r"'s' = 0\.040011 is outside its limits \[0\.0, 0\.04\] "
                       r"\(tolerance 1e-05\); pass on_limit='clip'"):  # fmt: skip
        model.check_joints({"s": 0.04 + 1.1e-5})


def test_open_mesh_is_refused(tmp_path):
    # A tetrahedron with one face missing: mujoco compiles it, it is not a closed solid.
    (tmp_path / "open.obj").write_text(
        "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0 0 0.01\nf 1 3 2\nf 1 2 4\nf 2 3 4\n"
    )
    text = """<mujoco><asset><mesh name="open" file="open.obj"/></asset><worldbody>
      <body name="b"><geom name="shell" type="mesh" mesh="open"/></body></worldbody></mujoco>"""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            load_model(_write(tmp_path, text))
    except ModelError as exc:
        text = str(exc)
        assert "'shell'" in text and "is not a closed surface" in text
        # The three rim edges of the missing face, with where one is.
        assert "(3 edges belong to an odd number of faces (holes), e.g. at (" in text
    else:  # pragma: no cover - mujoco would have to close the mesh itself
        pytest.fail("an open mesh was accepted")


# -- built-in Barrett -------------------------------------------------------------------------
def test_builtin_barrett_model():
    from exactgrasp.hands import barrett_model

    model = barrett_model()
    assert model.joint_names == (
        "finger_1_prox_joint", "finger_1_med_joint", "finger_1_dist_joint",
        "finger_2_med_joint", "finger_2_dist_joint", "finger_3_med_joint",
        "finger_3_dist_joint",
    )  # fmt: skip
    assert model.joint_limits["finger_1_prox_joint"] == pytest.approx((0, np.pi))
    assert model.joint_limits["finger_2_med_joint"] == (0.0, 2.44)
    assert model.joint_limits["finger_3_dist_joint"] == (0.0, 0.837)
    assert model.palm == PalmSpec((0, 0, 0.08), (0, 0, 1), (0, 1, 0), 0.085)
    rest = {n: V for n, V, _ in model.link_meshes({})}
    assert list(rest) == LINK_ORDER
    for name, V, F in model.link_meshes({}):
        closed, volume = _closed(V, F)
        assert closed and volume > 0, name
    assert rest["palm"][:, 2].max() == pytest.approx(0.08)

    closed = {n: V for n, V, _ in model.link_meshes({"finger_3_med_joint": 1.2})}
    assert closed["finger_3_dist"][:, 2].mean() > rest["finger_3_dist"][:, 2].mean() + 0.05
    assert np.array_equal(closed["finger_1_dist"], rest["finger_1_dist"])

    # One spread joint turns fingers 1 and 2 in opposite senses (mirror images in x).
    spread = {n: V for n, V, _ in model.link_meshes({"finger_1_prox_joint": 0.6})}
    c1, c2 = spread["finger_1_med"].mean(axis=0), spread["finger_2_med"].mean(axis=0)
    assert c1[0] < rest["finger_1_med"][:, 0].mean() - 0.02
    assert np.allclose(c1 * (-1, 1, 1), c2, atol=1e-9)
    assert model.check_joints({"finger_1_prox_joint": 0.6, "finger_2_prox_joint": 0.6})
    with pytest.raises(JointError, match="coupling"):
        model.check_joints({"finger_1_prox_joint": 0.6, "finger_2_prox_joint": 0.2})


def test_builtin_barrett_volumes():
    # A 90 x 90 x 80 mm palm box; the whole hand (union of its links) 856 cm^3.
    import exactgrasp.hands as hands

    hand = hands.barrett()
    palm_v, palm_f = hand.link_arrays()[hand.link_names.index("palm")]
    assert trimesh.Trimesh(palm_v, palm_f, process=False).volume == pytest.approx(648e-6, rel=1e-9)
    assert np.ptp(palm_v, axis=0) == pytest.approx((0.09, 0.09, 0.08))
    assert hand.volume == pytest.approx(856e-6, rel=5e-4)


def test_builtin_barrett_distal_coupling():
    from exactgrasp.hands import barrett_model
    from exactgrasp.hands.barrett import DISTAL_RATIO

    model = barrett_model(distal_coupling=True)
    assert len(model.joint_names) == 4
    full = model.all_joint_values(model.check_joints({"finger_2_med_joint": 2.44}))
    assert full["finger_2_dist_joint"] == pytest.approx(2.44 * DISTAL_RATIO)


def test_builtin_barrett_hand():
    import exactgrasp.hands as hands

    hand = hands.barrett(joints={"finger_1_med_joint": 1.0})
    assert hand.joints["finger_1_med_joint"] == 1.0
    assert len(hand.link_meshes()) == 9


# -- built-in parallel gripper, couplings with reference poses --------------------------------
def test_builtin_parallel_gripper_model():
    import exactgrasp.hands as hands
    from exactgrasp.hands.gripper import GRIPPER_STROKE

    model = hands.parallel_gripper_model()
    assert model.joint_names == ("finger_1_joint",)
    assert model.couplings == {"finger_2_joint": ("finger_1_joint", 1.0, 0.0)}
    assert model.joint_limits["finger_1_joint"] == (0.0, GRIPPER_STROKE / 2)
    assert model.default_joints == {"finger_1_joint": 0.04}  # open
    assert model.palm == PalmSpec((0, 0, 0), (0, 0, 1), (0, 1, 0), 0.05)
    for q in (0.0, 0.013, 0.04):
        links = {n: V for n, V, _ in model.link_meshes({"finger_1_joint": q})}
        assert links["finger_1"][:, 1].min() == pytest.approx(q, abs=1e-12)
        assert links["finger_2"][:, 1].max() == pytest.approx(-q, abs=1e-12)
    hand = hands.parallel_gripper()
    assert hand.source == {"type": "builtin", "name": "parallel_gripper", "options": {}}
    assert hands.get_builtin("parallel_gripper") is hands.parallel_gripper


def test_joint_equality_holds_between_displacements_from_the_reference(tmp_path):
    import mujoco

    text = """<mujoco><worldbody><body name="base"><geom type="box" size=".05 .05 .01"/>
      <body name="f1"><joint name="j1" type="slide" axis="0 1 0" range="0 0.04" ref="0.04"/>
        <geom type="box" size=".01 .01 .01" pos="0 .05 .02"/></body>
      <body name="f2"><joint name="j2" type="slide" axis="0 -1 0" range="0 0.08" ref="0.02"/>
        <geom type="box" size=".01 .01 .01" pos="0 -.05 .02"/></body>
    </body></worldbody>
    <equality><joint joint1="j2" joint2="j1" polycoef="0.001 2 0 0 0"/></equality></mujoco>"""
    model = load_model(_write(tmp_path, text), palm=False)
    # j2 - 0.02 = 0.001 + 2 (j1 - 0.04): j2 = 2 j1 - 0.059
    driver, ratio, offset = model.couplings["j2"]
    assert (driver, ratio) == ("j1", 2.0) and offset == pytest.approx(-0.059, abs=1e-15)
    m = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(m)
    data.qpos[:] = list(model.all_joint_values({"j1": 0.035}).values())
    mujoco.mj_forward(m, data)
    equality = data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert np.abs(data.efc_pos[: data.nefc][equality]).max() < 1e-12
