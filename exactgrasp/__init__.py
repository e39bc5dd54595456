"""exactgrasp: grasp descriptors from hand-object intersection along rigid paths.

The public names::

    import exactgrasp as eg
    sampler = eg.PathSampler.preset("balanced")
    grasp = eg.Grasp(eg.hands.barrett(), eg.objects.box(), object_pose=T)
    d = eg.compute_descriptor(grasp, sampler, backend="voxel")
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.errors import (
    BackendError,
    BatchError,
    ClosingError,
    DataError,
    DescriptorError,
    EvaluationError,
    ExactGraspError,
    FrameError,
    GraspError,
    GraspFileError,
    JointError,
    MeshError,
    MeshWarning,
    MissingDependencyError,
    ModelError,
    NoiseError,
    SamplerError,
    SeparationError,
    UncertainCrossingError,
    UncertainPoseError,
)
from exactgrasp.lazy import lazy_names
from exactgrasp.version import __version__

if TYPE_CHECKING:
    from exactgrasp import hands
    from exactgrasp.backends import Backend, available_backends, get_backend, register_backend
    from exactgrasp.batch import read_batch, run_batch
    from exactgrasp.compare import compare_backends
    from exactgrasp.descriptor import (
        Descriptor,
        compute_descriptor,
        distance,
        pairwise_distances,
    )
    from exactgrasp.geometry import objects
    from exactgrasp.geometry.solid import Solid
    from exactgrasp.grasp import Grasp
    from exactgrasp.grasp.closing import close_fingers, close_fingers_result
    from exactgrasp.grasp.noise import joint_noise, object_pose_noise
    from exactgrasp.hands.frame import HandFrame
    from exactgrasp.hands.hand import Hand
    from exactgrasp.overlap import intersection, intersection_volume
    from exactgrasp.paths.sampler import PathSampler
    from exactgrasp.view import show

# Every other public name loads on first use (`exactgrasp.lazy`): ``import exactgrasp`` and the
# command line's ``--help`` do not pay for trimesh, scipy, mujoco and the compiled kernels.
__getattr__, __dir__ = lazy_names(
    __name__,
    {
        "exactgrasp.backends": (
            "Backend",
            "available_backends",
            "get_backend",
            "register_backend",
        ),
        "exactgrasp.descriptor": (
            "Descriptor",
            "compute_descriptor",
            "distance",
            "pairwise_distances",
        ),
        "exactgrasp.geometry.solid": ("Solid",),
        "exactgrasp.grasp": ("Grasp",),
        "exactgrasp.grasp.noise": ("joint_noise", "object_pose_noise"),
        "exactgrasp.hands.frame": ("HandFrame",),
        "exactgrasp.hands.hand": ("Hand",),
        "exactgrasp.paths.sampler": ("PathSampler",),
        "exactgrasp.grasp.closing": ("close_fingers", "close_fingers_result"),
        "exactgrasp.compare": ("compare_backends",),
        "exactgrasp.batch": ("run_batch", "read_batch"),
        "exactgrasp.overlap": ("intersection", "intersection_gradient", "intersection_volume"),
        "exactgrasp.separation": ("separate",),
        "exactgrasp.vertex_gradients": ("VertexGradients", "intersection_volume_gradients"),
        "exactgrasp.view": ("show",),
    },
    {"hands": "exactgrasp.hands", "objects": "exactgrasp.geometry.objects"},
)

__all__ = [
    "Backend",
    "BackendError",
    "BatchError",
    "ClosingError",
    "DataError",
    "Descriptor",
    "DescriptorError",
    "EvaluationError",
    "ExactGraspError",
    "FrameError",
    "Grasp",
    "GraspError",
    "GraspFileError",
    "Hand",
    "HandFrame",
    "JointError",
    "MeshError",
    "MeshWarning",
    "MissingDependencyError",
    "ModelError",
    "NoiseError",
    "PathSampler",
    "SamplerError",
    "SeparationError",
    "Solid",
    "UncertainCrossingError",
    "UncertainPoseError",
    "VertexGradients",
    "__version__",
    "available_backends",
    "close_fingers",
    "close_fingers_result",
    "compare_backends",
    "compute_descriptor",
    "distance",
    "get_backend",
    "hands",
    "intersection",
    "intersection_gradient",
    "intersection_volume",
    "intersection_volume_gradients",
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
