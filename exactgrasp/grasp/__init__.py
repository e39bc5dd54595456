"""A grasp (hand, object, pose), its file format, noise and finger closing.

Modules here import `exactgrasp.errors`, `exactgrasp.cache`, `exactgrasp.geometry`,
`exactgrasp.hands` and each other (never paths or backends). `exactgrasp.grasp.closing` is
not imported here (it needs coal or python-fcl on use).
"""

from exactgrasp.grasp.grasp import FORMAT, Grasp, check_pose

__all__ = ["FORMAT", "Grasp", "check_pose"]
