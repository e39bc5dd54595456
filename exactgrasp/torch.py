"""The exact intersection volume as a differentiable function of vertex tensors (PyTorch).

`intersection_volume(vertices_a, faces_a, vertices_b, faces_b, poses)` returns the exact
volume of the two meshes' intersection as a tensor whose gradient flows back to both vertex
tensors, through `VolumeFunction` (a `torch.autograd.Function`): the forward pass and the
derivatives come from one call of `exactgrasp.intersection_volume_gradients` per distinct
pair of meshes. Needs the ``torch`` extra (``pip install exactgrasp[torch]``).

Tensors must be float64 on the CPU: the volume is computed exactly in double precision, and a
float32 tensor, or one on another device, is refused with the conversion to make (no silent
copy, no silent rounding of the gradient). ``poses`` (rigid motions of ``b``) are constants.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from exactgrasp.vertex_gradients import intersection_volume_gradients

__all__ = ["VolumeFunction", "intersection_volume"]


def _checked(tensor: Any, name: str) -> torch.Tensor:
    """A vertex tensor (..., n, 3), float64 on the CPU, or a `TypeError` / `ValueError` that
    names it and the fix."""
    if not isinstance(tensor, torch.Tensor):
        raise TypeError(f"{name}: got {type(tensor).__name__}; pass a torch.Tensor (..., n, 3).")
    if tensor.dtype != torch.float64:
        raise TypeError(
            f"{name}: dtype {tensor.dtype}; exactgrasp's volume is exact in float64 and its "
            f"gradient would be rounded in {tensor.dtype}: pass {name}.double() (and cast the "
            "loss back if the rest of the model is float32)."
        )
    if tensor.device.type != "cpu":
        raise ValueError(
            f"{name} is on {tensor.device}; exactgrasp computes on the CPU: pass "
            f"{name}.cpu() (the gradient comes back on the CPU; move it with .to(device))."
        )
    if tensor.ndim < 2 or tensor.shape[-1] != 3:
        raise ValueError(f"{name}: shape {tuple(tensor.shape)}; pass vertices (..., n, 3).")
    return tensor


class VolumeFunction(torch.autograd.Function):
    """``V(vertices_a, vertices_b)`` per pose; `intersection_volume` is its entry."""

    @staticmethod
    def forward(ctx, vertices_a, vertices_b, faces_a, faces_b, poses, backend):
        batch = torch.broadcast_shapes(
            vertices_a.shape[:-2], vertices_b.shape[:-2], tuple(poses.shape[:-2])
        )
        va = vertices_a.detach().numpy()
        vb = vertices_b.detach().numpy()
        volumes = np.zeros(batch)
        ga = np.zeros((*batch, *vertices_a.shape[-2:]))
        gb = np.zeros((*batch, *vertices_b.shape[-2:]))
        if va.ndim == 2 and vb.ndim == 2:
            # One pair of meshes: one call for every pose.
            r = intersection_volume_gradients(
                (va, faces_a), (vb, faces_b), np.broadcast_to(poses, (*batch, 4, 4)), backend
            )
            volumes[...], ga[...], gb[...] = r.volumes, r.grad_a, r.grad_b
        else:
            va = np.broadcast_to(va, ga.shape)
            vb = np.broadcast_to(vb, gb.shape)
            pb = np.broadcast_to(poses, (*batch, 4, 4))
            for i in np.ndindex(*batch):
                r = intersection_volume_gradients(
                    (va[i], faces_a), (vb[i], faces_b), pb[i], backend
                )
                volumes[i], ga[i], gb[i] = r.volumes, r.grad_a, r.grad_b
        ctx.save_for_backward(torch.from_numpy(ga), torch.from_numpy(gb))
        ctx.shapes = (vertices_a.shape, vertices_b.shape)
        return torch.from_numpy(volumes)

    @staticmethod
    def backward(ctx, grad_volumes):
        ga, gb = ctx.saved_tensors
        shape_a, shape_b = ctx.shapes
        weight = grad_volumes[..., None, None]
        grad_a = (weight * ga).sum_to_size(shape_a) if ctx.needs_input_grad[0] else None
        grad_b = (weight * gb).sum_to_size(shape_b) if ctx.needs_input_grad[1] else None
        return grad_a, grad_b, None, None, None, None


def intersection_volume(
    vertices_a: torch.Tensor,
    faces_a: Any,
    vertices_b: torch.Tensor,
    faces_b: Any,
    poses: Any = None,
    backend: Any = "exact",
) -> torch.Tensor:
    """Exact volume of mesh a ∩ mesh b (moved by each pose), differentiable in both meshes'
    vertices.

    Parameters
    ----------
    vertices_a, vertices_b : torch.Tensor, shape (..., n_a, 3) and (..., n_b, 3), float64, CPU
        Vertices in metres (batch dimensions broadcast with each other and with ``poses``);
        each mesh is read as `exactgrasp.intersection_volume_gradients` reads a (vertices,
        faces) pair, so a mesh the intake would change in a way the derivatives cannot
        follow is refused there.
    faces_a, faces_b : array_like or torch.Tensor, shape (m, 3), int
        Outward-oriented triangles, fixed.
    poses : array_like or torch.Tensor, shape (4, 4) or (..., 4, 4), optional
        Rigid motions of ``b`` (constants, no gradient). None: ``b`` as given.
    backend : "exact" or ExactBackend

    Returns
    -------
    torch.Tensor, shape: the broadcast batch shape, float64
        m^3; its gradient by a vertex is m^3 per metre (`VertexGradients`).

    Raises
    ------
    TypeError
        A vertex tensor that is not float64 (or not a tensor); the message gives the cast.
    ValueError
        A vertex tensor on another device than the CPU, or not of shape (..., n, 3).
    """
    vertices_a = _checked(vertices_a, "vertices_a")
    vertices_b = _checked(vertices_b, "vertices_b")
    faces_a, faces_b = (
        np.asarray(f.detach().cpu().numpy() if isinstance(f, torch.Tensor) else f, np.int64)
        for f in (faces_a, faces_b)
    )
    if poses is None:
        poses = np.eye(4)
    elif isinstance(poses, torch.Tensor):
        poses = poses.detach().cpu().numpy()
    poses = np.asarray(poses, dtype=np.float64)
    return VolumeFunction.apply(vertices_a, vertices_b, faces_a, faces_b, poses, backend)
