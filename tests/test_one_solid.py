"""One solid, one answer: for any hand and pose, the exact backend's volume (what the
descriptor divides by the hand's volume) equals inclusion-exclusion over the links' own
`intersection_volume` results, on every hand of the test suite, and on a hand of links that
overlap, touch along a face and an edge, and hold a cavity touching the outer shell, the
union's exact volume by CGAL's arrangement."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import exactgrasp as eg
from exactgrasp.backends.exact import ExactBackend
from exactgrasp.datapath import examples_dir
from exactgrasp.geometry.manifold import mesh_arrays, to_manifold
from exactgrasp.geometry.topology import join_meshes
from tests.conftest import box_arrays
from tests.exact_reference import cgal_intersection_volume
from tests.touching_meshes import FAMILY

SETTINGS = settings(max_examples=6, derandomize=True, deadline=None, database=None)


def touching_hand() -> eg.Hand:
    """Links (cm-sized, in metres) that overlap, touch along a face and along an edge, and a
    link with a cavity touching its outer shell along an edge (four-face edges)."""
    V, F = FAMILY["cavity touching at an edge"]()
    links = [
        box_arrays([0, 0, 0], [0.02, 0.02, 0.02]),
        box_arrays([0.015, 0.005, 0.005], [0.04, 0.015, 0.015]),  # overlaps the first
        box_arrays([0.0, 0.02, 0.0], [0.02, 0.03, 0.01]),  # touches it along a face
        box_arrays([0.02, -0.01, 0.02], [0.03, 0.0, 0.03]),  # touches it along an edge
        (V * 0.02 + [0.0, -0.03, 0.0], F),  # its own four-face edge
    ]
    frame = eg.HandFrame.from_palm([0.01, 0.0, 0.02], [0, 0, 1], [0, 1, 0], 0.06)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eg.Hand.from_meshes(links, frame=frame)


HANDS = {
    "touching links": touching_hand,
    "barrett": lambda: eg.hands.barrett({f"finger_{i}_med_joint": 0.9 for i in (1, 2, 3)}),
    "parallel gripper": lambda: eg.hands.parallel_gripper(),
    "two-finger URDF": lambda: eg.Hand.from_urdf(
        examples_dir() / "hand" / "two_finger.urdf", joints={"left_proximal_joint": 0.05}
    ),
    "adroit": lambda: eg.hands.adroit(),
    "shadow hand": lambda: eg.hands.shadow_hand(),
}


def inclusion_exclusion_terms(links, obj) -> list:
    """The terms of vol(∪ L_i ∩ moved obj) = Σ vol(L_i ∩ obj) - Σ vol(L_i ∩ L_j ∩ obj) + ...:
    (sign, an exact intersector of that common part with the object) for every set of links
    grown from parts of positive volume; the common parts from manifold3d (2-manifold input),
    each term's volume by the exact backend, as `intersection_volume` computes it."""
    backend = ExactBackend(broadphase=None, n_jobs=1)
    solids = [to_manifold(V, F) for V, F in links]
    terms = []
    level = [((i,), s) for i, s in enumerate(solids)]
    sign = 1.0
    while level:
        for idx, solid in level:
            mesh = links[idx[0]] if len(idx) == 1 else mesh_arrays(solid)
            terms.append((sign, backend.intersector_of([mesh], [obj])))
        grown = []
        for idx, solid in level:
            for j in range(idx[-1] + 1, len(solids)):
                common = solid ^ solids[j]
                if common.volume() > 0:
                    grown.append(((*idx, j), common))
        level, sign = grown, -sign
    return terms


def places(links) -> np.ndarray:
    """Where the links overlap (centres of their pairwise common parts) and their vertices."""
    solids = [to_manifold(V, F) for V, F in links]
    centres = []
    for i in range(len(solids)):
        for j in range(i + 1, len(solids)):
            common = solids[i] ^ solids[j]
            if common.volume() > 0:
                centres.append(mesh_arrays(common)[0].mean(0))
    return np.array(centres + [V[0] for V, _ in links])


@pytest.fixture(scope="module")
def scenes():
    built = {}

    def get(name):
        if name not in built:
            hand = HANDS[name]()
            size = float(np.ptp(np.concatenate([V for V, _ in hand.canonical_links()]), 0).max())
            ball = trimesh.creation.icosphere(2, radius=size / 6)
            grasp = eg.Grasp(hand, eg.Solid(ball.vertices / hand.frame.scale, ball.faces))
            links = grasp.canonical_hand_links()
            obj = join_meshes(grasp.canonical_object_bodies())
            terms = inclusion_exclusion_terms(links, obj)
            built[name] = grasp, links, obj, places(links), terms
        return built[name]

    return get


@pytest.mark.parametrize("name", HANDS)
@SETTINGS
@given(seed=st.integers(0, 2**32 - 1))
def test_the_union_is_inclusion_exclusion_over_the_links(scenes, name, seed):
    if name in ("adroit", "shadow hand"):
        pytest.importorskip("gymnasium_robotics", reason="the hands extra is not installed")
    grasp, _, obj, where, terms = scenes(name)
    rng = np.random.default_rng(seed)
    poses = np.tile(np.eye(4), (4, 1, 1))
    q = np.linalg.qr(rng.normal(size=(4, 3, 3)))[0]
    poses[:, :3, :3] = q * np.sign(np.linalg.det(q))[:, None, None]
    spread = 0.05 * np.ptp(where, 0).max()
    # The ball's centre moved to each place, give or take.
    targets = where[rng.integers(len(where), size=4)] + rng.normal(scale=spread, size=(4, 3))
    poses[:, :3, 3] = targets - poses[:, :3, :3] @ obj[0].mean(0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        union = ExactBackend(broadphase=None, n_jobs=1).volumes(grasp, poses)
        parts = sum(sign * ex.volumes(poses) for sign, ex in terms)
    assert np.all(union > 0)  # a ball around a link's vertex or two links' common part
    floor = 1e-6 * grasp.canonical_hand_volume
    np.testing.assert_array_less(np.abs(union - parts), 1e-9 * np.maximum(union, floor) + 1e-300)


def test_the_touching_hand_matches_cgal_on_the_union_of_its_links(scenes):
    grasp, links, obj, where, _ = scenes("touching links")
    union = join_meshes(links)  # CGAL reads the joined links as the points of winding >= 1
    poses = np.tile(np.eye(4), (len(where), 1, 1))
    poses[:, :3, 3] = where - obj[0].mean(0)
    got = ExactBackend(broadphase=None, n_jobs=1).volumes(grasp, poses)
    want = [cgal_intersection_volume(union, (obj[0] + p[:3, 3], obj[1])) for p in poses]
    assert np.count_nonzero(got) >= 4
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-15 * grasp.canonical_hand_volume)
    # The descriptor's values are the union's exact volumes over the hand's.
    sampler = eg.PathSampler(n_translations=3, n_axes=1, n_amounts=1, n_steps=3)
    d = eg.compute_descriptor(grasp, sampler, backend="exact")
    P = sampler.poses().reshape(-1, 4, 4)
    want = [cgal_intersection_volume(union, (obj[0] @ p[:3, :3].T + p[:3, 3], obj[1])) for p in P]
    np.testing.assert_allclose(
        d.values.reshape(-1) * grasp.canonical_hand_volume, want, rtol=1e-9, atol=1e-15
    )
    assert np.count_nonzero(want) >= 3
