"""Derivatives of the exact volume: `intersection_gradient` and
`ExactBackend.volume_gradients` against closed forms and central differences."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

import exactgrasp as eg
from exactgrasp.backends.exact import ExactBackend
from exactgrasp.geometry.se3 import exp_se3
from tests.conftest import box_arrays

ROOT = Path(__file__).resolve().parents[1]


def translation(x=0.0, y=0.0, z=0.0) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = (x, y, z)
    return pose


def moved(pose: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """``exp(ξ̂) · pose``: the twist (v, ω) applied on the left."""
    return exp_se3(xi[3:], xi[:3]) @ pose


def box_gradient(a_lo, a_hi, b_lo, b_hi) -> np.ndarray:
    """The twist gradient of box A ∩ box B (axis-aligned, B already placed) in closed form:
    ``Σ area · (n, c × n)`` over the faces of B strictly inside A's slab, each restricted to
    the overlap's rectangle (``c`` its centre, ``n`` B's outward normal)."""
    a_lo, a_hi, b_lo, b_hi = (np.asarray(x, float) for x in (a_lo, a_hi, b_lo, b_hi))
    lo, hi = np.maximum(a_lo, b_lo), np.minimum(a_hi, b_hi)
    grad = np.zeros(6)
    if np.any(hi <= lo):
        return grad
    for k in range(3):
        others = [i for i in range(3) if i != k]
        area = np.prod(hi[others] - lo[others])
        for plane, sign in ((b_lo[k], -1.0), (b_hi[k], 1.0)):
            if not a_lo[k] < plane < a_hi[k]:
                continue
            n = np.zeros(3)
            n[k] = sign
            centre = 0.5 * (lo + hi)
            centre[k] = plane
            grad += area * np.concatenate([n, np.cross(centre, n)])
    return grad


# -- closed forms -----------------------------------------------------------------------------

BOX_CASES = [
    ([0.0, 0.0, 0.0], [0.07, 0.05, 0.03]),
    ([-0.07, 0.01, 0.015], [0.03, 0.03, 0.03]),
    ([0.081, -0.013, -0.02], [0.02, 0.05, 0.11]),
    ([0.031, 0.022, 0.047], [0.09, 0.1, 0.04]),
]


@pytest.mark.parametrize(("offset", "size"), BOX_CASES)
def test_box_gradient_is_the_closed_form_face_integral(offset, size):
    a_lo, a_hi = np.array([-0.05, -0.04, -0.03]), np.array([0.1, 0.08, 0.06])
    b = box_arrays([0, 0, 0], size)
    pose = translation(*offset)
    grad = eg.intersection_gradient(box_arrays(a_lo, a_hi), b, pose)
    expected = box_gradient(a_lo, a_hi, np.array(offset), np.array(offset) + size)
    assert grad.shape == (6,)
    # Relative to the moments of B's whole surface (a box wholly inside has gradient 0).
    scale = 2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2])
    np.testing.assert_allclose(grad, expected, rtol=0, atol=1e-12 * scale)
    assert (np.abs(expected).max() > 1e-4) == (offset != [0.0, 0.0, 0.0])


def test_box_translation_gradient_is_the_derivative_of_the_overlap_product():
    # V = Π_k overlap_k; moving B along +x shrinks the x overlap (B sticks out at +x).
    a = box_arrays([0, 0, 0], [0.1, 0.08, 0.06])
    b = box_arrays([0, 0, 0], [0.05, 0.05, 0.05])
    pose = translation(0.07, 0.05, 0.03)  # overlaps 0.03 along each axis
    grad = eg.intersection_gradient(a, b, pose)
    expected = -np.array([0.03 * 0.03, 0.03 * 0.03, 0.03 * 0.03])
    np.testing.assert_allclose(grad[:3], expected, rtol=1e-12)
    # Pushed in along -x (B's low x face moves down into A), the volume grows.
    pose = translation(-0.02, 0.01, 0.005)  # x overlap 0.03, B's high faces inside A
    grad = eg.intersection_gradient(a, b, pose)
    np.testing.assert_allclose(grad[:3], [0.05 * 0.05, 0.0, 0.0], atol=1e-12 * 0.0025)


def section_polygon(mesh: trimesh.Trimesh, height: float) -> tuple[float, np.ndarray]:
    """Area and centroid of the convex section of a convex mesh by the plane z = height,
    from the crossing points of its edges (angle-sorted, shoelace formula)."""
    V = mesh.vertices
    E = mesh.edges_unique
    z0, z1 = V[E[:, 0], 2] - height, V[E[:, 1], 2] - height
    cut = z0 * z1 < 0
    lam = z0[cut] / (z0[cut] - z1[cut])
    P = V[E[cut, 0]] + lam[:, None] * (V[E[cut, 1]] - V[E[cut, 0]])
    mid = P.mean(0)
    P = P[np.argsort(np.arctan2(P[:, 1] - mid[1], P[:, 0] - mid[0]))]
    x, y = P[:, 0] - mid[0], P[:, 1] - mid[1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = 0.5 * cross.sum()
    cx = ((x + xn) * cross).sum() / (6 * area) + mid[0]
    cy = ((y + yn) * cross).sum() / (6 * area) + mid[1]
    return area, np.array([cx, cy, height])


def test_sphere_in_a_half_space_sheds_volume_at_the_rate_of_its_section():
    # The object's surface inside the half-space z < h and the flat section close a solid:
    # ∫ n dA = -area ẑ and ∫ x × n dA = -(centroid × ẑ) area over that surface.
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
    half_space = box_arrays([-0.2, -0.2, -0.2], [0.2, 0.2, 0.0123])
    pose = translation(0.011, -0.007, 0.004)
    grad = eg.intersection_gradient(half_space, sphere, pose)
    placed = sphere.copy()
    placed.apply_transform(pose)
    area, centroid = section_polygon(placed, 0.0123)
    up = np.array([0.0, 0.0, 1.0])
    expected = -area * np.concatenate([up, np.cross(centroid, up)])
    np.testing.assert_allclose(grad, expected, rtol=0, atol=1e-12 * area)


def test_shapes_follow_the_poses():
    a = box_arrays([0, 0, 0], [0.1, 0.08, 0.06])
    b = box_arrays([0, 0, 0], [0.05, 0.05, 0.05])
    poses = np.stack([translation(0.07, 0.05, 0.03), translation(1.0)]).reshape(2, 1, 4, 4)
    grad = eg.intersection_gradient(a, b, poses)
    assert grad.shape == (2, 1, 6)
    assert eg.intersection_gradient(a, b).shape == (6,)
    assert eg.intersection_gradient(a, b, np.zeros((0, 4, 4))).shape == (0, 6)


def test_options_are_intersections_and_others_are_refused_by_name():
    a = box_arrays([0, 0, 0], [100.0, 80.0, 60.0])
    b = box_arrays([0, 0, 0], [50.0, 50.0, 50.0])
    # The same boxes in millimetres (poses are in metres either way): the same gradient.
    grad = eg.intersection_gradient(a, b, translation(0.07, 0.05, 0.03), units="mm")
    metres = eg.intersection_gradient(
        box_arrays([0, 0, 0], [0.1, 0.08, 0.06]),
        box_arrays([0, 0, 0], [0.05, 0.05, 0.05]),
        translation(0.07, 0.05, 0.03),
    )
    np.testing.assert_allclose(grad, metres, rtol=1e-12, atol=1e-18)
    with pytest.raises(TypeError, match=r"\['n_jobs'\].*check_scale, repair, units"):
        eg.intersection_gradient(a, b, n_jobs=1)


def test_apart_and_touching_poses_have_zero_gradient():
    a = box_arrays([0, 0, 0], [0.1, 0.08, 0.06])
    b = box_arrays([0, 0, 0], [0.05, 0.05, 0.05])
    poses = np.stack([translation(0.3), translation(0.1), translation(0.0, 0.0, -0.05)])
    assert np.all(eg.intersection_volume(a, b, poses) == 0)
    assert np.all(eg.intersection_gradient(a, b, poses) == 0)


def test_the_docs_example_runs(capsys):
    # The example of docs/penetration-volume.md ("Derivatives"), run as it is written there.
    text = (ROOT / "docs" / "penetration-volume.md").read_text()
    block = text.split("<!-- gradient-example -->\n```python\n", 1)[1].split("```", 1)[0]
    scope: dict = {}
    exec(compile(block, "penetration-volume.md", "exec"), scope)
    pose, steps = scope["pose"], scope["steps"]
    assert 1 <= steps <= 10
    assert pose[0, 3] >= 0.05 + 0.0199  # pushed out along +x, the nearest way out
    assert abs(pose[1, 3] - 0.01) < 1e-9 and abs(pose[2, 3]) < 1e-9
    assert str(steps) in capsys.readouterr().out


def test_the_units_example_runs(capsys):
    # The example of docs/exact-backend.md ("Units: the canonical frame"), run as written.
    text = (ROOT / "docs" / "exact-backend.md").read_text()
    block = text.split("<!-- gradient-units-example -->\n```python\n", 1)[1].split("```", 1)[0]
    scope: dict = {}
    exec(compile(block, "exact-backend.md", "exec"), scope)
    grasp, volume, twist = scope["grasp"], scope["volume"], scope["twist"]
    assert scope["s"] == 25.0
    # A cap of the ball 5 mm deep, its base a disc of radius sqrt(0.02² - 0.015²) in z = 0.01.
    assert 0 < volume < np.pi * 0.005**2 * (3 * 0.02 - 0.005) / 3
    assert volume == pytest.approx(eg.intersection_volume(grasp), rel=1e-12)
    direct = eg.intersection_gradient(grasp)
    assert np.allclose(twist, direct, rtol=1e-9, atol=1e-12 * np.abs(direct).max())
    # Lifting the ball sheds volume at about the cap's base area (a disc of the icosphere).
    assert -twist[2] == pytest.approx(np.pi * (0.02**2 - 0.015**2), rel=0.1)
    assert str(volume) in capsys.readouterr().out


# -- central differences on real grasps ---------------------------------------------------------

STEPS = (1e-3, 1e-4, 1e-5)


def relative_errors(fd: np.ndarray, grad: np.ndarray) -> np.ndarray:
    """|fd - grad| / max(|grad|, 1e-3 max |grad|), component by component."""
    floor = 1e-3 * np.abs(grad).max()
    return np.abs(fd - grad) / np.maximum(np.abs(grad), floor)


@pytest.fixture(scope="module")
def raw_record(shared_data):
    path = shared_data / "barrett-grasps/study-records/CerealBox/obj5_sub4_grasp1_optimal0.json"
    return eg.Grasp.from_file(path)


def test_twist_gradient_matches_central_differences_on_a_real_grasp(raw_record):
    backend = ExactBackend(n_jobs=1)
    rng = np.random.default_rng(7)
    poses = [np.eye(4)] + [
        exp_se3(rng.normal(0, 0.05, 3), rng.normal(0, 0.05, 3)) for _ in range(3)
    ]
    result = backend.volume_gradients(raw_record, np.stack(poses))
    assert np.all(result.volumes > 0)
    errors = []
    for h in STEPS:
        for i, pose in enumerate(poses):
            fd = np.zeros(6)
            for k in range(6):
                xi = np.zeros(6)
                xi[k] = h
                plus, minus = backend.volumes(
                    raw_record, np.stack([moved(pose, xi), moved(pose, -xi)])
                )
                fd[k] = (plus - minus) / (2 * h)
            errors.append(relative_errors(fd, result.twist[i]))
    assert np.median(np.concatenate(errors)) <= 1e-3
    # The translation along -grad sheds volume (a sign check a wrong factor would pass too).
    g = result.twist[0, :3]
    step = moved(np.eye(4), np.concatenate([-1e-3 * g / np.linalg.norm(g), np.zeros(3)]))
    assert backend.volumes(raw_record, step[None])[0] < result.volumes[0]


def joint_differences(grasp, backend, names, h):
    out = []
    for name in names:
        q = grasp.hand.joints[name]
        vols = []
        for sign in (1, -1):
            hand = grasp.hand.with_joints({name: q + sign * h}, on_limit="clip")
            vols.append(
                backend.volumes(eg.Grasp(hand, grasp.object, grasp.object_pose), np.eye(4)[None])[
                    0
                ]
            )
        out.append((vols[0] - vols[1]) / (2 * h))
    return np.array(out)


def test_joint_gradient_matches_central_differences_on_a_real_grasp(raw_record):
    backend = ExactBackend(n_jobs=1)
    result = backend.volume_gradients(raw_record, np.eye(4))
    assert result.joint_names == raw_record.hand.joint_names and len(result.joint_names) == 8
    assert result.joints.shape == (1, 8)
    errors = [
        relative_errors(
            joint_differences(raw_record, backend, result.joint_names, h), result.joints[0]
        )
        for h in (1e-4, 1e-5)
    ]
    assert np.median(np.concatenate(errors)) <= 1e-3
    # Closing a medial joint pushes that finger deeper into the box.
    assert result.joints[0, result.joint_names.index("finger_1_med_joint")] > 0


def coupled_grasp():
    """The built-in Barrett hand (finger 2's spread follows finger 1's), spread open, with a
    box through both spreading knuckles and the palm."""
    hand = eg.hands.barrett().with_joints({"finger_1_prox_joint": 0.4, "finger_1_med_joint": 0.3})
    box = eg.Solid(*box_arrays([-0.045, -0.05, 0.07], [0.045, 0.005, 0.095]))
    return eg.Grasp(hand, box, name="coupled")


def test_coupled_joints_move_their_dependents():
    grasp = coupled_grasp()
    backend = ExactBackend(n_jobs=1)
    result = backend.volume_gradients(grasp, np.eye(4))
    assert "finger_2_prox_joint" not in result.joint_names
    assert "finger_2_prox_joint" in grasp.hand.model.couplings
    spread = result.joint_names.index("finger_1_prox_joint")
    errors = [
        relative_errors(joint_differences(grasp, backend, result.joint_names, h), result.joints[0])
        for h in (1e-4, 1e-5)
    ]
    assert np.median(np.concatenate(errors)) <= 1e-3
    for h in (1e-4, 1e-5):
        fd = joint_differences(grasp, backend, ["finger_1_prox_joint"], h)[0]
        assert abs(fd - result.joints[0, spread]) <= 1e-3 * abs(result.joints[0, spread])
    # Finger 1's links alone would give another number: the dependent counts.
    from exactgrasp.backends.exact.gradients import volume_moments
    from exactgrasp.hands.twists import link_twists

    _, links = volume_moments(backend.intersector(grasp), np.eye(4)[None])
    _, twists = link_twists(grasp.hand)
    own = grasp.hand.model.joint_links()["finger_1_prox_joint"]
    alone = sum(twists[spread, k] @ links[0, k] for k in own)
    assert abs(alone - result.joints[0, spread]) > 0.1 * abs(result.joints[0, spread])


def test_a_pose_apart_has_zero_derivatives():
    grasp = coupled_grasp()
    result = ExactBackend(n_jobs=1).volume_gradients(grasp, translation(0, 0, 5.0))
    assert result.volumes.tolist() == [0.0]
    assert not result.twist.any() and not result.joints.any()


# -- the kernel's moments against the boolean's --------------------------------------------------

REAL = (
    "barrett-grasps/study-records/CerealBox/obj5_sub4_grasp1_optimal0.json",
    "barrett-grasps/noise/spray_bottle_study_record.json",
    "barrett-grasps/study-records/SprayBottle/obj2_sub4_grasp6_optimal0.json",
)


@pytest.mark.parametrize("name", REAL)
def test_kernel_moments_agree_with_the_boolean(shared_data, name):
    from exactgrasp.backends.exact.gradients import boolean_volume_moments, volume_moments

    if not (shared_data / name).is_file():
        pytest.skip(f"{name} not in the shared data")
    grasp = eg.Grasp.from_file(shared_data / name)
    rng = np.random.default_rng(3)
    poses = np.stack(
        [np.eye(4)] + [exp_se3(rng.normal(0, 0.1, 3), rng.normal(0, 0.2, 3)) for _ in range(8)]
    )
    intersector = ExactBackend(n_jobs=1).intersector(grasp)
    volumes, kernel = volume_moments(intersector, poses)
    assert set(intersector.intersect(poses).pose_sources.reshape(-1)) == {"kernel"}
    _, boolean = boolean_volume_moments(intersector, poses)
    assert np.count_nonzero(volumes) >= 5
    scale = np.abs(boolean).max(axis=(1, 2), keepdims=True)
    assert np.all(np.abs(kernel - boolean) <= 1e-12 * scale)
    # Several links inside, each with its own moments.
    assert np.count_nonzero(np.abs(kernel[0]).sum(1)) >= 3
    threaded = ExactBackend(n_jobs=2).intersector(grasp)
    np.testing.assert_array_equal(volume_moments(threaded, poses)[1], kernel)


def test_coupled_slide_joints_of_the_gripper_in_closed_form():
    # The built-in gripper: finger 1 slides along +y, finger 2 (its mimic) along -y. A box
    # between them, 5 mm into each finger: opening by dq sheds both overlaps' faces,
    # 20 mm x 30 mm each, so dV/dq = -2 * 0.02 * 0.03 m^3 per metre (times scale^3 in
    # canonical units).
    hand = eg.hands.parallel_gripper().with_joints({"finger_1_joint": 0.03})
    lo, hi = hand.link_arrays()[1][0].min(0), hand.link_arrays()[1][0].max(0)
    assert np.allclose([lo[1], lo[0], hi[0], lo[2]], [0.03, -0.01, 0.01, 0.0])
    box = eg.Solid(*box_arrays([-0.02, -0.035, 0.01], [0.02, 0.035, 0.04]))
    grasp = eg.Grasp(hand, box, name="gripper")
    result = ExactBackend(n_jobs=1).volume_gradients(grasp, np.eye(4))
    assert result.joint_names == ("finger_1_joint",)
    s = grasp.frame.scale
    np.testing.assert_allclose(result.joints[0, 0], -2 * 0.02 * 0.03 * s**3, rtol=1e-12)
    assert result.volumes[0] == pytest.approx(2 * 0.02 * 0.005 * 0.03 * s**3, rel=1e-12)
    # Symmetric: no net push on the box.
    assert np.abs(result.twist[0, :3]).max() <= 1e-12 * 0.02 * 0.03 * s**2
