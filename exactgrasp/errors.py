"""Exception types, `require` for optional dependencies, `warn_caller` and
`run_reporting_errors`.

Every message names the input, what is wrong with it and how to fix it. Every exception class
of exactgrasp is defined here (and exported from `exactgrasp`). This module imports nothing from
exactgrasp; it must stay at the package root (`warn_caller` skips the frames under its folder).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable

_PACKAGE_DIR = str(Path(__file__).resolve().parent)


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


class FrameError(ExactGraspError, ValueError):
    """Bad palm-frame parameters."""


class SamplerError(ExactGraspError, ValueError):
    """Bad `PathSampler` parameters."""


class NoiseError(ExactGraspError, ValueError):
    """Bad noise parameters."""


class DescriptorError(ExactGraspError, ValueError):
    """Incomparable descriptors, unreadable descriptor files, or a failed computation."""


class BatchError(ExactGraspError, ValueError):
    """A bad manifest, an output folder holding another run, or a run that cannot go on."""


class ClosingError(ExactGraspError, ValueError):
    """Fingers cannot be closed: bad options, a penetrating open hand, an object out of reach."""


class SeparationError(ExactGraspError, ValueError):
    """A penetrating grasp cannot be separated: the object enclosed by the hand, or no motion
    found within the limits."""


class DataError(ExactGraspError, FileNotFoundError):
    """The shared data folder is missing or incomplete."""


def warn_caller(message: str) -> None:
    """Warn at the first caller outside exactgrasp, however deep inside the package we are."""
    frame, level = sys._getframe(1), 2
    while frame is not None and frame.f_code.co_filename.startswith(_PACKAGE_DIR):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, UserWarning, stacklevel=level)


def run_reporting_errors(
    handler: Callable[[argparse.Namespace], int | None], args: argparse.Namespace, prog: str
) -> int:
    """Run a command's handler, turning an `ExactGraspError` or Ctrl-C into a message.

    Parameters
    ----------
    handler : callable
        Takes the parsed arguments, returns the exit status (None is 0).
    args : argparse.Namespace
        The parsed arguments.
    prog : str
        The command, for the error message (``"exactgrasp descriptor"``).

    Returns
    -------
    int
        The handler's exit status; 2 after printing ``PROG: error: MESSAGE`` to stderr for an
        `ExactGraspError`; 130 after printing ``interrupted`` for a KeyboardInterrupt.
    """
    try:
        return int(handler(args) or 0)
    except ExactGraspError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


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
