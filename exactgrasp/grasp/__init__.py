"""A grasp (hand, object, pose), its file format, noise and finger closing.

Modules here import `exactgrasp.errors`, `exactgrasp.cache`, `exactgrasp.geometry`,
`exactgrasp.hands` and each other (never paths or backends). `exactgrasp.grasp.closing` is
not imported here (it needs coal or python-fcl on use).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from exactgrasp.lazy import lazy_names

if TYPE_CHECKING:
    from exactgrasp.grasp.grasp import FORMAT, Grasp, check_pose

__getattr__, __dir__ = lazy_names(
    __name__,
    {"exactgrasp.grasp.grasp": ("FORMAT", "Grasp", "check_pose")},
)

__all__ = ["FORMAT", "Grasp", "check_pose"]
