"""Every available backend passes `check_backend`, and the checks catch broken backends."""

from __future__ import annotations

import numpy as np
import pytest

import exactgrasp as eg
from exactgrasp.backends import check_poses
from exactgrasp.backends.testing import CHECKS, check_backend

AVAILABLE = sorted(eg.available_backends())


@pytest.mark.parametrize("check", list(CHECKS))
@pytest.mark.parametrize("name", AVAILABLE)
def test_available_backend_passes_the_conformance_check(name, check):
    check_backend(eg.get_backend(name), checks=[check])


def test_builtins_are_checked():
    assert {"voxel", "exact"} <= set(AVAILABLE)


def test_exact_backend_without_broad_phase_passes_at_its_declared_tolerance():
    backend = eg.get_backend("exact", broadphase=None)
    assert backend.volume_rtol is not None and backend.volume_rtol <= 1e-9
    check_backend(backend)


class BoxBackend(eg.Backend):
    """Overlap of the bounding boxes of hand links and moved object (rotations ignored): exact
    for the conformance scene's axis-aligned boxes; `flaw` breaks one rule of the contract."""

    name = "box"
    volume_rtol = 1e-12

    def __init__(self, flaw: str = ""):
        self.flaw = flaw

    @property
    def params(self):
        return {"flaw": self.flaw, **({"bad": np.float32(1)} if self.flaw == "params" else {})}

    def volumes(self, grasp, poses):
        if self.flaw != "poses":
            poses = check_poses(poses)
        shift = np.asarray(poses, float)[..., :3, 3]
        (V, _), *_ = grasp.canonical_object_bodies()
        out = np.zeros(shift.shape[:-1])
        for L, _ in grasp.canonical_hand_links():
            lo = np.maximum(L.min(0), V.min(0) + shift)
            hi = np.minimum(L.max(0), V.max(0) + shift)
            out += np.prod(np.clip(hi - lo, 0, None), axis=-1)
        if self.flaw == "shape":
            out = out.reshape(-1)
        if self.flaw == "far":
            out = out + 1e-12
        return out


def test_a_conforming_toy_backend_passes():
    check_backend(BoxBackend())


@pytest.mark.parametrize(
    ("flaw", "check", "message"),
    [
        ("poses", "rigid poses", r"fails 'rigid poses': a scaled pose at index 2 was accepted"),
        ("shape", "shapes", r"poses of shape \(4, 4\) gave volumes of shape \(1,\)"),
        ("far", "far pose", "'far pose': the object 1.7 m from the hand gave volume"),
        ("params", "params", "are not JSON"),
    ],
)
def test_the_checks_name_what_a_broken_backend_gets_wrong(flaw, check, message):
    with pytest.raises(AssertionError, match=message):
        check_backend(BoxBackend(flaw), checks=[check])


def test_check_backend_refuses_unknown_checks_and_non_backends():
    with pytest.raises(ValueError, match=r"unknown checks \['speed'\]"):
        check_backend(BoxBackend(), checks=["speed"])
    with pytest.raises(TypeError, match="needs a Backend instance"):
        check_backend("voxel")
