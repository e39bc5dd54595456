"""`exactgrasp.torch`: the exact volume as an autograd function of vertex tensors, checked
with `torch.autograd.gradcheck` and against `intersection_volume_gradients`."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import exactgrasp as eg

torch = pytest.importorskip("torch")
egt = pytest.importorskip("exactgrasp.torch")


def meshes():
    a = trimesh.creation.icosphere(subdivisions=1, radius=0.5)
    b = trimesh.creation.box(extents=(0.6, 0.5, 0.4))
    return a, b


def poses(k: int) -> np.ndarray:
    out = np.tile(np.eye(4), (k, 1, 1))
    out[:, :3, :3] = Rotation.random(k, random_state=3).as_matrix()
    out[:, :3, 3] = np.random.default_rng(3).normal(size=(k, 3)) * 0.2
    return out


def test_gradcheck_on_small_meshes_at_generic_poses():
    a, b = meshes()
    va = torch.tensor(a.vertices, dtype=torch.float64, requires_grad=True)
    vb = torch.tensor(b.vertices, dtype=torch.float64, requires_grad=True)
    P = poses(2)

    def f(x, y):
        return egt.intersection_volume(x, a.faces, y, b.faces, P)

    assert (f(va, vb) > 0).all()
    assert torch.autograd.gradcheck(f, (va, vb), eps=1e-6, atol=1e-7, rtol=1e-4)
    # Batched vertices (one pair of meshes per pose), broadcast against one pose.
    vab = (
        va.detach()[None] + 0.01 * torch.randn(2, *va.shape, dtype=torch.float64)
    ).requires_grad_()
    assert torch.autograd.gradcheck(
        lambda x: egt.intersection_volume(x, a.faces, vb.detach(), b.faces, P[0]),
        (vab,),
        eps=1e-6,
        atol=1e-7,
        rtol=1e-4,
    )


def test_backward_is_intersection_volume_gradients():
    a, b = meshes()
    P = poses(3)
    va = torch.tensor(a.vertices, dtype=torch.float64, requires_grad=True)
    vb = torch.tensor(b.vertices, dtype=torch.float64, requires_grad=True)
    v = egt.intersection_volume(va, torch.as_tensor(a.faces), vb, b.faces, P)
    weights = torch.tensor([1.0, -2.0, 0.5], dtype=torch.float64)
    (v * weights).sum().backward()
    r = eg.intersection_volume_gradients(a, b, P)
    np.testing.assert_array_equal(v.detach().numpy(), r.volumes)
    w = weights.numpy()[:, None, None]
    np.testing.assert_allclose(va.grad.numpy(), (w * r.grad_a).sum(0), rtol=0, atol=1e-15)
    np.testing.assert_allclose(vb.grad.numpy(), (w * r.grad_b).sum(0), rtol=0, atol=1e-15)


def test_float32_and_other_devices_are_refused_with_the_fix():
    a, b = meshes()
    vb = torch.tensor(b.vertices, dtype=torch.float64)
    with pytest.raises(TypeError, match=r"vertices_a.double\(\)"):
        egt.intersection_volume(
            torch.tensor(a.vertices, dtype=torch.float32), a.faces, vb, b.faces
        )
    meta = torch.tensor(a.vertices, dtype=torch.float64, device="meta")
    with pytest.raises(ValueError, match=r"vertices_a.cpu\(\)"):
        egt.intersection_volume(meta, a.faces, vb, b.faces)
    with pytest.raises(ValueError, match=r"\(\.\.\., n, 3\)"):
        egt.intersection_volume(vb[:, :2].contiguous(), a.faces, vb, b.faces)
