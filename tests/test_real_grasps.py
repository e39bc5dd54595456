"""The shared real Barrett grasps: loading, hand volume, JSON round trip, joint limits, the
noise set's intersection volume, and joint-noise statistics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

pytest.importorskip("mujoco", reason="the models extra (mujoco) is not installed")

import exactgrasp as eg
from exactgrasp.errors import NoiseError
from exactgrasp.geometry.manifold import to_manifold, union
from exactgrasp.grasp.noise import joint_noise
from tests.conftest import SHARED_DATA

GRASPS = SHARED_DATA / "barrett-grasps" / "grasps"
NOISE = SHARED_DATA / "barrett-grasps" / "noise"
CEREAL = sorted(p.name for p in GRASPS.glob("obj5_*.json"))
HAND_VOLUME = 6.2851e-4  # README: union of the 9 links, 6.28504e-4 .. 6.28509e-4 m^3


@pytest.fixture(scope="module")
def barrett_urdf(shared_data):
    return eg.Hand.from_urdf(shared_data / "barrett-grasps" / "hand" / "barrett.urdf")


@pytest.mark.parametrize("name", CEREAL or ["(no shared data)"])
def test_cereal_box_grasps_load_with_the_readme_hand_volume(shared_data, name):
    grasp = eg.Grasp.from_file(GRASPS / name)
    assert grasp.name == name.removesuffix(".json")
    assert len(grasp.hand.link_names) == 9
    assert grasp.object.volume == pytest.approx(2.86340e-3, rel=1e-5)
    assert grasp.hand.volume == pytest.approx(HAND_VOLUME, rel=1e-4)


def test_all_34_cereal_box_grasps_present(shared_data):
    assert len(CEREAL) == 34


def test_noise_grasps_load(shared_data):
    names = [f"noise_grasp{i}.json" for i in range(10)]
    grasps = [eg.Grasp.from_file(NOISE / n) for n in names]
    # The hand pose is bit-identical in all ten files; only the joints differ (a random walk
    # of 1e-4 rad steps, per-joint range 2e-4 .. 6.5e-4 rad over the set).
    for grasp in grasps[1:]:
        np.testing.assert_array_equal(grasp.object_pose, grasps[0].object_pose)
    values = np.array([list(g.hand.joints.values()) for g in grasps])
    spread = values.max(axis=0) - values.min(axis=0)
    assert np.all(spread > 1e-4) and np.all(spread < 1e-3)


def test_noise_grasp0_intersection_volume_matches_readme(shared_data):
    grasp = eg.Grasp.from_file(NOISE / "noise_grasp0.json")
    pose = grasp.object_pose
    placed = grasp.object.vertices @ pose[:3, :3].T + pose[:3, 3]
    hand = union(grasp.hand.link_arrays())
    volume = (hand ^ to_manifold(placed, grasp.object.faces)).volume()
    assert volume == pytest.approx(3.677e-10, rel=1e-3)  # README: 3.677e-10 m^3 (0.37 mm^3)


def test_real_grasp_json_round_trip(shared_data, tmp_path):
    grasp = eg.Grasp.from_file(GRASPS / "obj5_sub5_grasp5_optimal0_target.json")
    saved = grasp.save(tmp_path / "copy" / "grasp.json")
    again = eg.Grasp.from_file(saved)
    assert again.geometry_key == grasp.geometry_key
    assert again.hand.joints == grasp.hand.joints
    np.testing.assert_array_equal(again.object_pose, grasp.object_pose)
    assert again.name == grasp.name


def test_study_value_a_hair_above_the_rounded_limit_loads(shared_data):
    # Recorded distal value 0.837758 rad (48 degrees) against the URDF's rounded 0.837.
    path = SHARED_DATA / "barrett-grasps" / "study-records" / "CerealBox"
    grasp = eg.Grasp.from_file(path / "obj5_sub4_grasp1_optimal0.json")
    _, upper = grasp.hand.joint_limits["finger_1_dist_joint"]
    assert upper == 0.837
    assert grasp.hand.joints["finger_1_dist_joint"] == pytest.approx(0.8377580409569999, abs=0)
    with pytest.raises(eg.JointError, match=r"outside its limits \[0\.0, 0\.837\]"):
        grasp.hand.with_joints({"finger_1_dist_joint": 0.84})


# -- joint noise -------------------------------------------------------------------------------

FRACTION = 0.05
DRAWS = 2000


@pytest.fixture(scope="module")
def noise_draws():
    """The built-in hand mid-range, and one at its limits, each perturbed DRAWS times."""
    hand = eg.hands.barrett()
    mid = hand.with_joints({n: 0.5 * sum(hand.joint_limits[n]) for n in hand.joint_names})
    rng = np.random.default_rng(7)
    centred = np.array([list(joint_noise(mid, FRACTION, rng).values()) for _ in range(DRAWS)])
    at_lower = np.array([list(joint_noise(hand, FRACTION, rng).values()) for _ in range(DRAWS)])
    return hand, mid, centred, at_lower


def test_joint_noise_is_uniform_within_the_fraction_of_range(noise_draws):
    hand, mid, centred, _ = noise_draws
    span = np.array([np.subtract(*hand.joint_limits[n][::-1]) for n in hand.joint_names])
    start = np.array([mid.joints[n] for n in hand.joint_names])
    u = (centred - start) / (FRACTION * span)  # should be uniform on [-1, 1], per joint
    assert np.all(np.abs(u) <= 1.0)
    for column in u.T:
        assert abs(column.mean()) < 4 * np.sqrt(1 / 3 / DRAWS)  # 4 sigma of the mean
        assert column.std() == pytest.approx(np.sqrt(1 / 3), rel=0.06)
        assert stats.kstest(column, stats.uniform(-1, 2).cdf).pvalue > 1e-3
    # Joints move independently of each other.
    assert np.abs(np.corrcoef(u.T) - np.eye(len(span))).max() < 0.1


def test_joint_noise_is_clipped_at_the_limits(noise_draws):
    hand, _, _, at_lower = noise_draws
    for k, name in enumerate(hand.joint_names):
        lower, upper = hand.joint_limits[name]
        column = at_lower[:, k]
        assert column.min() == lower and column.max() <= lower + FRACTION * (upper - lower)
        assert np.mean(column == lower) == pytest.approx(0.5, abs=0.05)  # half clipped


def test_perturb_joints_is_seeded_and_returns_a_valid_hand(barrett_urdf):
    a = barrett_urdf.perturb_joints(0.03, rng=11)
    b = barrett_urdf.perturb_joints(0.03, rng=np.random.default_rng(11))
    c = barrett_urdf.perturb_joints(0.03, rng=12)
    assert a.joints == b.joints and a.joints != c.joints
    assert set(a.joints) == set(barrett_urdf.joint_names)
    for name, value in a.joints.items():
        lower, upper = barrett_urdf.joint_limits[name]
        assert lower <= value <= upper
        assert abs(value - barrett_urdf.joints[name]) <= 0.03 * (upper - lower)
    assert barrett_urdf.perturb_joints(0.0, rng=1).joints == barrett_urdf.joints


@pytest.mark.parametrize(
    ("fraction", "message"),
    [
        (-0.01, r"fraction must be a non-negative number, got -0\.01"),
        (float("nan"), r"fraction must be a non-negative number, got nan"),
    ],
)
def test_joint_noise_bad_fraction(fraction, message):
    with pytest.raises(NoiseError, match=message):
        eg.hands.barrett().perturb_joints(fraction, rng=0)


def test_joint_noise_needs_joints_with_a_range():
    rigid = eg.Hand.from_meshes([eg.objects.box()], frame=eg.HandFrame.identity())
    with pytest.raises(NoiseError, match=r"has no joints to perturb"):
        rigid.perturb_joints(0.01, rng=0)


def test_hand_model_compiled_once_per_file(shared_data, tmp_path):
    import shutil

    grasps = sorted((shared_data / "barrett-grasps" / "grasps").glob("obj5_*.json"))[:2]
    a, b = (eg.Grasp.from_file(p) for p in grasps)
    assert a.hand.model is b.hand.model  # one compile for many grasps of one hand
    # a changed file is compiled again
    hand_dir = tmp_path / "hand"
    shutil.copytree(shared_data / "barrett-grasps" / "hand", hand_dir)
    first = eg.Hand.from_urdf(hand_dir / "barrett.urdf")
    assert eg.Hand.from_urdf(hand_dir / "barrett.urdf").model is first.model
    urdf = hand_dir / "barrett.urdf"
    urdf.write_text(urdf.read_text() + "\n<!-- edited -->\n")
    assert eg.Hand.from_urdf(urdf).model is not first.model
