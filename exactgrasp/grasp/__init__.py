"""A grasp (hand, object, pose), its file format, noise and finger closing."""

from exactgrasp.grasp.grasp import FORMAT, Grasp, check_pose

__all__ = ["FORMAT", "Grasp", "check_pose"]
