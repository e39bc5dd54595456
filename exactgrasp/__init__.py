"""exactgrasp: grasp descriptors from hand-object intersection along rigid paths.

The public names::

    import exactgrasp as eg
    sampler = eg.PathSampler.preset("balanced")
    grasp = eg.Grasp(eg.hands.barrett(), eg.objects.box(), object_pose=T)
    d = eg.compute_descriptor(grasp, sampler, backend="voxel")
"""

from __future__ import annotations

from exactgrasp.backends import Backend, available_backends, get_backend, register_backend
from exactgrasp.descriptor import Descriptor, compute_descriptor, distance, pairwise_distances
from exactgrasp.errors import (
    BackendError,
    BatchError,
    ClosingError,
    DataError,
    DescriptorError,
    ExactGraspError,
    FrameError,
    GraspFileError,
    JointError,
    MeshError,
    MissingDependencyError,
    ModelError,
    NoiseError,
    SamplerError,
    SeparationError,
)
from exactgrasp.geometry import objects
from exactgrasp.geometry.solid import Solid
from exactgrasp.grasp import Grasp
from exactgrasp.grasp.noise import joint_noise, object_pose_noise
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.hand import Hand
from exactgrasp.paths.sampler import PathSampler
from exactgrasp.version import __version__


def __getattr__(name: str):
    # Modules that pull in heavier optional packages load on first use.
    import importlib

    lazy = {
        "hands": ("exactgrasp.hands", None),
        "close_fingers": ("exactgrasp.grasp.closing", "close_fingers"),
        "compare_backends": ("exactgrasp.compare", "compare_backends"),
        "run_batch": ("exactgrasp.batch", "run_batch"),
        "read_batch": ("exactgrasp.batch", "read_batch"),
        "intersection_volume": ("exactgrasp.overlap", "intersection_volume"),
        "intersection_gradient": ("exactgrasp.overlap", "intersection_gradient"),
        "separate": ("exactgrasp.separation", "separate"),
        "show": ("exactgrasp.view", "show"),
    }
    if name in lazy:
        module_name, attr = lazy[name]
        module = importlib.import_module(module_name)
        return module if attr is None else getattr(module, attr)
    raise AttributeError(f"module 'exactgrasp' has no attribute {name!r}")


__all__ = [
    "Backend",
    "BackendError",
    "BatchError",
    "ClosingError",
    "DataError",
    "Descriptor",
    "DescriptorError",
    "ExactGraspError",
    "FrameError",
    "Grasp",
    "GraspFileError",
    "Hand",
    "HandFrame",
    "JointError",
    "MeshError",
    "MissingDependencyError",
    "ModelError",
    "NoiseError",
    "PathSampler",
    "SamplerError",
    "SeparationError",
    "Solid",
    "__version__",
    "available_backends",
    "close_fingers",
    "compare_backends",
    "compute_descriptor",
    "distance",
    "get_backend",
    "hands",
    "intersection_gradient",
    "intersection_volume",
    "joint_noise",
    "object_pose_noise",
    "objects",
    "pairwise_distances",
    "read_batch",
    "register_backend",
    "run_batch",
    "separate",
    "show",
]
