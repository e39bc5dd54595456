"""The exact backend: certified intersection volumes, the plain boolean and the kernel."""

from exactgrasp.backends.exact.backend import (
    FLOOR,
    RTOL,
    ExactBackend,
    ExactIntersector,
    agrees,
    plain_volumes,
    repeated_poses,
)

__all__ = [
    "FLOOR",
    "RTOL",
    "ExactBackend",
    "ExactIntersector",
    "agrees",
    "plain_volumes",
    "repeated_poses",
]
