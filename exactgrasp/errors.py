"""Exception types.

Every message names the input, what is wrong with it and how to fix it.
"""

from __future__ import annotations


class ExactGraspError(Exception):
    """Base class of every error raised on purpose by exactgrasp."""


class MeshError(ExactGraspError, ValueError):
    """A mesh is unusable as a solid (not closed, NaN coordinates, no faces, ...)."""


class GraspFileError(ExactGraspError, ValueError):
    """A grasp JSON file is malformed or names files that do not exist."""


class JointError(ExactGraspError, ValueError):
    """Unknown joint names or joint values outside the limits."""


class ModelError(ExactGraspError, ValueError):
    """A hand model (MJCF, URDF) cannot be turned into closed link meshes."""


class BackendError(ExactGraspError, ValueError):
    """An unknown backend name, or bad backend parameters."""


class MissingDependencyError(ExactGraspError, ImportError):
    """An optional dependency needed for the requested feature is not installed."""

    def __init__(self, feature: str, package: str, extra: str):
        self.feature = feature
        self.package = package
        self.extra = extra
        super().__init__(
            f"{feature} needs the optional package {package!r}, which is not installed; "
            f'install it with `pip install {package}` or `pip install "exactgrasp[{extra}]"`.'
        )


def require(module: str, feature: str, package: str | None = None, extra: str = "all"):
    """Import an optional dependency or raise a `MissingDependencyError` naming it.

    Parameters
    ----------
    module : str
        Importable module name, e.g. ``"coal"``.
    feature : str
        What the user asked for, used in the message (``"the exact backend"``).
    package : str, optional
        The pip package name when it differs from the module name.
    extra : str
        The exactgrasp extra that installs it.

    Returns
    -------
    module
        The imported module.
    """
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingDependencyError(feature, package or module, extra) from exc
