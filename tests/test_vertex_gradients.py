"""The volume's derivative by every vertex (`intersection_volume_gradients`): against exact
rational integrals (a box and a convex polytope), the twist and joint derivatives it must
chain to, central differences, and the intake's changes it follows or refuses."""

from __future__ import annotations

import contextlib
import warnings
from fractions import Fraction

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import exactgrasp as eg
from exactgrasp.backends.exact import ExactBackend
from tests.conftest import box_arrays


@contextlib.contextmanager
def quiet():
    """Warnings of the intake (said once per mesh) silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", eg.MeshWarning)
        yield


def posed(rotvec, t) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    pose[:3, 3] = t
    return pose


# -- an exact reference for convex meshes ------------------------------------------------------


def _frac(x) -> np.ndarray:
    return np.array([[Fraction(float(v)) for v in row] for row in np.atleast_2d(x)], dtype=object)


def _cross(u, v):
    return np.array(
        [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]],
        dtype=object,
    )


def _half_spaces(V, F):
    """The planes ``n · x <= d`` of a convex mesh's faces, exactly."""
    out = []
    for f in F:
        a, b, c = V[f[0]], V[f[1]], V[f[2]]
        n = _cross(b - a, c - a)
        out.append((n, n @ a))
    return out


def _clip(poly, n, d):
    """Sutherland-Hodgman: the part of a convex polygon with ``n · x <= d``, exactly."""
    out = []
    for i, p in enumerate(poly):
        q = poly[(i + 1) % len(poly)]
        sp, sq = n @ p - d, n @ q - d
        if sp <= 0:
            out.append(p)
        if (sp < 0 < sq) or (sq < 0 < sp):
            out.append(p + (q - p) * (sp / (sp - sq)))
    return out


def exact_vertex_gradients(V, F, others) -> np.ndarray:
    """``Σ_f (∫_{f ∩ other} φ_i dA) n_f`` per vertex of (V, F) (Fractions), the other solid
    convex with half-spaces ``others``: each face clipped exactly, fanned, and the area vector
    ``N_T / 2`` of each fan triangle weighted by ``φ_i`` at its centroid."""
    grad = np.zeros((len(V), 3), dtype=object)
    for f in F:
        a, b, c = V[f[0]], V[f[1]], V[f[2]]
        N = _cross(b - a, c - a)
        nn = N @ N
        poly = [a, b, c]
        for n, d in others:
            poly = _clip(poly, n, d)
            if len(poly) < 3:
                break
        for k in range(1, len(poly) - 1):
            p0, p1, p2 = poly[0], poly[k], poly[k + 1]
            half = _cross(p1 - p0, p2 - p0) / 2
            centre = (p0 + p1 + p2) / 3
            for j, (y, z) in enumerate(((b, c), (c, a), (a, b))):
                phi = (_cross(z - y, centre - y) @ N) / nn
                grad[f[j]] += phi * half
    return grad.astype(float)


def test_two_boxes_and_a_box_with_a_polytope_match_exact_integrals():
    box = box_arrays([0.0, 0.0, 0.0], [0.05, 0.04, 0.03])
    other = box_arrays([0.031, -0.013, 0.011], [0.083, 0.017, 0.052])
    ball = trimesh.convex.convex_hull(trimesh.creation.icosphere(subdivisions=1, radius=0.03))
    cases = [
        (other, np.eye(4)),
        (
            (np.asarray(ball.vertices), np.asarray(ball.faces)),
            posed([0.3, -0.2, 0.5], [0.04, 0.03, 0.02]),
        ),
    ]
    for (VB, FB), pose in cases:
        r = eg.intersection_volume_gradients(box, (VB, FB), pose)
        assert r.volumes > 0
        VA = _frac(box[0])
        moved = _frac(np.asarray(VB) @ pose[:3, :3].T + pose[:3, 3])
        expect_a = exact_vertex_gradients(VA, box[1], _half_spaces(moved, FB))
        expect_b = exact_vertex_gradients(moved, FB, _half_spaces(VA, box[1])) @ pose[:3, :3]
        scale = np.abs(expect_a).max()
        assert np.abs(r.grad_a - expect_a).max() <= 1e-12 * scale
        assert np.abs(r.grad_b - expect_b).max() <= 1e-12 * scale
    # Closed form: the vertices of A's face x = 0.05 move that face, inside B on the overlap's
    # rectangle (y in [0, 0.017], z in [0.011, 0.03]).
    r = eg.intersection_volume_gradients(box, other)
    face = np.isclose(box[0][:, 0], 0.05)
    assert r.grad_a[face, 0].sum() == pytest.approx(0.017 * 0.019, rel=1e-12)
    assert r.volumes == pytest.approx(0.019 * 0.017 * 0.019, rel=1e-12)


# -- consistency with the twist and the joints -------------------------------------------------


def test_vertex_gradients_chain_to_the_twist_gradient():
    a = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    b = trimesh.creation.box(extents=(0.05, 0.04, 0.03))
    poses = np.stack(
        [posed([0.3, 0.2, 0.1], [0.03, 0.01, 0.0]), posed([1.0, -0.4, 2.0], [0.0, 0.04, 0.02])]
    )
    r = eg.intersection_volume_gradients(a, b, poses)
    twist = eg.intersection_gradient(a, b, poses)
    assert r.grad_a.shape == (2, len(a.vertices), 3) and r.grad_b.shape == (2, 8, 3)
    for k, pose in enumerate(poses):
        R, t = pose[:3, :3], pose[:3, 3]
        gw = r.grad_b[k] @ R.T  # by the moved vertices
        y = b.vertices @ R.T + t
        from_b = np.concatenate([gw.sum(0), np.cross(y, gw).sum(0)])
        # Moving a is moving b the opposite way.
        from_a = -np.concatenate([r.grad_a[k].sum(0), np.cross(a.vertices, r.grad_a[k]).sum(0)])
        scale = np.abs(twist[k]).max()
        assert np.abs(from_b - twist[k]).max() <= 1e-9 * scale
        assert np.abs(from_a - twist[k]).max() <= 1e-9 * scale


def coupled_grasp():
    """The built-in Barrett hand spread open, with a box through both spreading knuckles."""
    hand = eg.hands.barrett().with_joints({"finger_1_prox_joint": 0.4, "finger_1_med_joint": 0.3})
    box = eg.Solid(*box_arrays([-0.045, -0.05, 0.07], [0.045, 0.005, 0.095]))
    return eg.Grasp(hand, box, name="coupled")


def test_hand_vertex_gradients_chain_to_the_joint_and_twist_derivatives():
    from exactgrasp.hands.twists import link_twists

    grasp = coupled_grasp()
    r = eg.intersection_volume_gradients(grasp)
    result = ExactBackend(n_jobs=1).volume_gradients(grasp, np.eye(4))
    s = grasp.frame.scale
    M = grasp.frame.matrix
    Rf, T = M[:3, :3] / s, M[:3, 3]
    names, twists = link_twists(grasp.hand)
    links = grasp.hand.link_arrays()
    offsets = np.cumsum([0] + [len(V) for V, _ in links])
    joints = np.zeros(len(names))
    for ell, (V, _) in enumerate(links):
        g = r.grad_a[offsets[ell] : offsets[ell + 1]]
        xc = s * V @ Rf.T + T
        for j in range(len(names)):
            v, w = twists[j, ell, :3], twists[j, ell, 3:]
            velocity = (v + np.cross(w, xc)) @ Rf / s  # metres per radian, hand coordinates
            joints[j] += np.einsum("ij,ij->", g, velocity)
    expected = result.joints[0] / s**3
    assert np.abs(expected).max() > 0
    assert np.abs(joints - expected).max() <= 1e-9 * np.abs(expected).max()
    # The object's vertices, chained through a rigid motion, give intersection_gradient.
    R, t = grasp.object_pose[:3, :3], grasp.object_pose[:3, 3]
    gw = r.grad_b @ R.T
    y = grasp.object.vertices @ R.T + t
    twist = eg.intersection_gradient(grasp)
    got = np.concatenate([gw.sum(0), np.cross(y, gw).sum(0)])
    assert np.abs(got - twist).max() <= 1e-9 * np.abs(twist).max()
    assert r.volumes == pytest.approx(eg.intersection_volume(grasp), rel=1e-12)


# -- the kernel's rows against a plain evaluation, threads, the limit ---------------------------


def barrett_in(name: str, n: int = 8):
    """The built-in Barrett hand (medial joints at 1 rad) around a built-in object 8 cm above
    its frame, and ``n`` seeded poses near there (the last the same as the first)."""
    hand = eg.hands.barrett()
    hand = hand.with_joints({j: 1.0 for j in hand.joint_names if "med" in j})
    place = np.eye(4)
    place[:3, 3] = (0.0, 0.0, 0.08)
    grasp = eg.Grasp(hand, eg.objects.get(name), place, name=name)
    rng = np.random.default_rng(3)
    poses = np.stack(
        [posed(rng.uniform(-0.1, 0.1, 3), rng.uniform(-0.01, 0.01, 3)) for _ in range(n)]
    )
    poses[-1] = poses[0]
    return grasp, poses


def plain_vertex_gradients(grasp, poses):
    """The derivatives from the per-face intersector's dense rows (`volume_moments`, the input
    frame, the object's in its own), face by face in numpy: area ``F · n``, first moment
    ``n × M + n (n · a) A``, ``∫ φ_j dA = ((z - y) × (P - A y)) · N / |N|²``."""
    A = grasp.hand.link_arrays()
    B = [(grasp.object.vertices @ grasp.object_pose[:3, :3].T + grasp.object_pose[:3, 3],
          grasp.object.faces)]  # fmt: skip
    intersector = ExactBackend(n_jobs=1).intersector_of(A, B, faces=True)
    volumes, rows = intersector.volume_moments(poses)
    out = []
    split = np.split(rows, [len(intersector.face_sources[0])], axis=1)
    for meshes, src, part in zip((A, B), intersector.face_sources, split, strict=True):
        offsets = np.cumsum([0] + [len(V) for V, _ in meshes])
        grad = np.zeros((len(poses), offsets[-1], 3))
        for r, (mesh, face) in enumerate(src):
            V, F = meshes[mesh]
            a, b, c = V[F[face]]
            N = np.cross(b - a, c - a)
            n = N / np.linalg.norm(N)
            area = part[:, r, :3] @ n
            first = np.cross(n, part[:, r, 3:]) + n * (n @ a * area)[:, None]
            for j, (y, z) in enumerate(((b, c), (c, a), (a, b))):
                w = np.cross(z - y, first - area[:, None] * y) @ N / (N @ N)
                grad[:, offsets[mesh] + F[face, j]] += w[:, None] * n
        out.append(grad)
    return volumes, out[0], out[1] @ grasp.object_pose[:3, :3]


@pytest.mark.parametrize("name", ["bottle_with_handle", "box"])
def test_kernel_rows_summed_onto_vertices_match_a_plain_evaluation(name):
    # The box holds most of the hand: its parts classified whole go by their markers.
    grasp, poses = barrett_in(name)
    r = eg.intersection_volume_gradients(grasp, poses=poses, backend=ExactBackend(n_jobs=1))
    volumes, ga, gb = plain_vertex_gradients(grasp, poses)
    assert np.abs(r.volumes - volumes).max() <= 1e-12 * volumes.max() and volumes.min() > 0
    for got, want in ((r.grad_a, ga), (r.grad_b, gb)):
        assert np.abs(want).max() > 0
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
    # Threads, and a repeated pose: the same numbers to the bit.
    two = eg.intersection_volume_gradients(grasp, poses=poses, backend=ExactBackend(n_jobs=2))
    np.testing.assert_array_equal(two.grad_a, r.grad_a)
    np.testing.assert_array_equal(two.grad_b, r.grad_b)
    np.testing.assert_array_equal(r.grad_a[-1], r.grad_a[0])


def test_vertex_markers_stand_for_the_faces_rows_they_replace():
    # With a marker per vertex, an inside vertex of a part classified vertex by vertex lists
    # its marker instead of adding its whole edges' shares to its faces' rows: the same
    # volumes, fewer face rows listed, and the same rows once the markers are expanded.
    from exactgrasp.backends.exact.moment_entries import dense

    grasp, poses = barrett_in("box")
    A = grasp.hand.link_arrays()
    B = [(grasp.object.vertices + grasp.object_pose[:3, 3], grasp.object.faces)]
    x = ExactBackend(n_jobs=1).intersector_of(A, B, faces=True)
    volumes, plain = x.moment_entries(poses)
    again, marked = x.moment_entries(poses, x.vertex_moment_tables)
    np.testing.assert_array_equal(again, volumes)
    part_from = x.moment_tables.part_from[0]
    vertex_from = part_from + len(x.hand_tables.parts) - 1
    assert (marked.rows >= vertex_from).sum() > len(poses)
    assert (marked.rows < part_from).sum() < 0.7 * (plain.rows < part_from).sum()
    want = dense(plain, x.moment_rows, x.moment_tables)
    got = dense(marked, x.moment_rows, x.vertex_moment_tables)
    assert np.abs(want).max() > 0
    assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()


def test_poses_the_kernel_does_not_sum_are_written_too():
    # The kernel writes the rows of the poses it sums; a pose far away (culled, or of volume
    # 0) and a repeated one are written after: every element, over NaNs here.
    from exactgrasp.backends.exact.face_gradients import mesh_tables, vertex_gradients

    grasp, poses = barrett_in("box", 4)
    far = posed([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    poses = np.concatenate([poses, far[None], poses[1:2]])
    A = grasp.hand.link_arrays()
    B = [(grasp.object.vertices + grasp.object_pose[:3, 3], grasp.object.faces)]
    x = ExactBackend(n_jobs=1).intersector_of(A, B, faces=True)
    tables = mesh_tables(x, A, B)
    out_a = np.full((len(poses), sum(len(V) for V, _ in A), 3), np.nan)
    out_b = np.full((len(poses), len(B[0][0]), 3), np.nan)
    volumes = vertex_gradients(x, tables, poses, out_a, out_b)
    assert volumes[4] == 0.0 and volumes[1] > 0.0
    assert not out_a[4].any() and not out_b[4].any()
    np.testing.assert_array_equal(out_a[5], out_a[1])
    np.testing.assert_array_equal(out_b[5], out_b[1])
    r = eg.intersection_volume_gradients(grasp, poses=poses[:4], backend=ExactBackend(n_jobs=1))
    np.testing.assert_array_equal(out_a[:4], r.grad_a)
    assert np.abs(out_a[1]).max() > 0


def test_poses_the_kernel_runs_again_give_the_same_derivatives():
    # A crossing buffer far too small: every pose is run again with a larger one
    # (`extrapolate`), its rows made dense there (the parts' markers expanded) and listed again.
    grasp, poses = barrett_in("box", 4)
    r = eg.intersection_volume_gradients(grasp, poses=poses, backend=ExactBackend(n_jobs=1))
    small = ExactBackend(n_jobs=1, capacity=16)
    again = eg.intersection_volume_gradients(grasp, poses=poses, backend=small)
    np.testing.assert_array_equal(again.volumes, r.volumes)
    for got, want in ((again.grad_a, r.grad_a), (again.grad_b, r.grad_b)):
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()


# -- central differences ------------------------------------------------------------------------


def test_vertex_gradients_match_central_differences_on_fuzzed_poses():
    a = trimesh.creation.icosphere(subdivisions=1, radius=0.05)
    b = trimesh.creation.box(extents=(0.06, 0.04, 0.05))
    A = (np.array(a.vertices), np.array(a.faces))
    B = (np.array(b.vertices), np.array(b.faces))
    rng = np.random.default_rng(7)
    errors = []
    for _ in range(3):
        pose = posed(rng.normal(size=3), rng.normal(size=3) * 0.02)
        r = eg.intersection_volume_gradients(A, B, pose)
        for which, (V, F), grad in ((0, A, r.grad_a), (1, B, r.grad_b)):
            touched = np.flatnonzero(np.abs(grad).max(1) > 0)
            for i in rng.choice(touched, min(4, len(touched)), replace=False):
                for d in range(3):
                    h = 1e-6
                    values = []
                    for sign in (1, -1):
                        W = V.copy()
                        W[i, d] += sign * h
                        pair = ((W, F), B) if which == 0 else (A, (W, F))
                        values.append(eg.intersection_volume(*pair, pose))
                    fd = (values[0] - values[1]) / (2 * h)
                    errors.append(abs(fd - grad[i, d]) / max(np.abs(grad[i]).max(), 1e-300))
    assert len(errors) >= 48
    assert np.median(errors) <= 1e-4


# -- the intake's changes ---------------------------------------------------------------------


def test_duplicated_vertices_and_split_four_face_edges_get_their_own_gradients():
    a = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    b = trimesh.creation.box(extents=(0.05, 0.04, 0.03))
    pose = posed([0.3, 0.2, 0.1], [0.03, 0.01, 0.0])
    whole = eg.intersection_volume_gradients(a, b, pose)
    # An STL's corners: every face its own three vertices.
    V = a.vertices[a.faces].reshape(-1, 3)
    F = np.arange(len(V)).reshape(-1, 3)
    split = eg.intersection_volume_gradients((V, F), b, pose)
    summed = np.zeros_like(whole.grad_a)
    np.add.at(summed, a.faces.reshape(-1), split.grad_a)
    assert np.abs(summed - whole.grad_a).max() <= 1e-15
    # Two boxes sharing an edge (four faces on it): the intake splits the edge's vertices, and
    # their copies' derivatives go back onto the input's.
    V1, F1 = box_arrays([0.0, 0.0, 0.0], [0.02, 0.02, 0.02])
    V2, F2 = box_arrays([0.02, 0.02, 0.0], [0.04, 0.04, 0.02])
    V, inv = np.unique(np.vstack([V1, V2]), axis=0, return_inverse=True)
    F = inv.reshape(-1)[np.vstack([F1, F2 + len(V1)])]
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.012)
    pose = posed([0.1, 0.2, 0.3], [0.021, 0.019, 0.013])
    with quiet():
        r = eg.intersection_volume_gradients((V, F), ball, pose)
        assert len(eg.Solid(V, F).vertices) == len(V) + 2  # the edge's two vertices split
    assert r.grad_a.shape == (len(V), 3)
    shared = np.flatnonzero(np.all(np.isclose(V[:, :2], 0.02), axis=1))
    assert len(shared) == 2 and np.abs(r.grad_a[shared]).max() > 0
    for i in shared:
        for d in range(3):
            values = []
            for sign in (1, -1):
                W = V.copy()
                W[i, d] += sign * 1e-7
                with quiet():
                    values.append(eg.intersection_volume((W, F), ball, pose))
            fd = (values[0] - values[1]) / 2e-7
            assert abs(fd - r.grad_a[i, d]) <= 1e-5 * np.abs(r.grad_a[i]).max()


def test_a_hole_closed_on_input_vertices_chains_and_new_vertices_are_refused():
    b = trimesh.creation.box(extents=(0.05, 0.04, 0.03))
    pose = posed([0.3, 0.2, 0.1], [0.03, 0.01, 0.0])
    a = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    whole = eg.intersection_volume_gradients(a, b, pose)
    # One triangle missing: repair closes it with that triangle, on the input's vertices.
    open_faces = np.asarray(a.faces)[1:]
    with quiet():
        r = eg.intersection_volume_gradients((a.vertices, open_faces), b, pose, repair=True)
    assert np.abs(r.grad_a - whole.grad_a).max() <= 1e-15 + 1e-12 * np.abs(whole.grad_a).max()
    # A wide hole: pymeshfix adds vertices that are no input vertices.
    s = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    keep = s.triangles_center[:, 2] < 0.85 * 0.05
    with quiet(), pytest.raises(eg.MeshError, match="no input vertex"):
        eg.intersection_volume_gradients((s.vertices, s.faces[keep]), b, pose, repair=True)
    # Overlapping shells in one mesh: merged with new vertices; the message says what to pass.
    V1, F1 = box_arrays([0.0, 0.0, 0.0], [0.02, 0.02, 0.02])
    V2, F2 = box_arrays([0.01, 0.013, 0.007], [0.03, 0.03, 0.03])
    both = (np.vstack([V1, V2]), np.vstack([F1, F2 + len(V1)]))
    with quiet(), pytest.raises(eg.MeshError, match="Hand"):
        eg.intersection_volume_gradients(both, b, pose)
    # The Solid itself: derivatives by its own vertices.
    with quiet():
        solid = eg.Solid(*both)
    r = eg.intersection_volume_gradients(solid, b, pose)
    assert r.grad_a.shape == (len(solid.vertices), 3)


def test_shapes_zero_and_refusals():
    a = trimesh.creation.box(extents=(0.05, 0.05, 0.05))
    b = trimesh.creation.icosphere(subdivisions=1, radius=0.01)
    apart = posed([0, 0, 0], [1.0, 0, 0])
    r = eg.intersection_volume_gradients(a, b, np.stack([apart, apart])[None])
    assert r.volumes.shape == (1, 2) and r.grad_a.shape == (1, 2, 8, 3)
    assert r.grad_b.shape == (1, 2, len(b.vertices), 3)
    assert not r.grad_a.any() and not r.grad_b.any() and not r.volumes.any()
    empty = eg.intersection_volume_gradients(a, b, np.zeros((0, 4, 4)))
    assert empty.volumes.shape == (0,) and empty.grad_b.shape == (0, len(b.vertices), 3)
    with pytest.raises(eg.MeshError, match="b: missing"):
        eg.intersection_volume_gradients(a)
    with pytest.raises(eg.BackendError, match="voxel"):
        eg.intersection_volume_gradients(a, b, backend="voxel")
    # Millimetres: the same derivatives, per metre.
    mm = eg.intersection_volume_gradients(
        (a.vertices * 1000, a.faces), (b.vertices * 1000, b.faces), units="mm"
    )
    m = eg.intersection_volume_gradients(a, b)
    assert np.abs(mm.grad_b - m.grad_b).max() <= 1e-12 * np.abs(m.grad_b).max()
