"""Exception types, `Fix` (the setting that fixes an error), `require` for optional
dependencies, `warn_caller`, `warn_once` (with `recording_warnings`) and
`run_reporting_errors`.

Every message names the input, what is wrong with it and how to fix it. Every exception class
of exactgrasp is defined here (and exported from `exactgrasp`). This module imports nothing from
exactgrasp; it must stay at the package root (`warn_caller` skips the frames under its folder).

Errors are data: a message is a sequence of parts, text and `Fix` es (the parameter that fixes
the error, the value that does and how the sentence uses it). ``str(exc)`` spells each fix as a
Python argument (``pass repair=True``); a front end that sets the same parameter another way
(a grasp-file key, a command-line flag) re-spells the same parts with `ExactGraspError.respelled`
and a function from a `Fix` to its own words. Nothing parses a message's text.

Long because every exception class of the package is here, with the helpers that warn.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import os
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable, Iterator, Sequence
    from types import FrameType

_PACKAGE_DIR = str(Path(__file__).resolve().parent)


@dataclass(frozen=True)
class Fix:
    """A setting that a message names: the parameter, and the value that fixes the error.

    Parameters
    ----------
    parameter : str
        The Python argument (``"repair"``).
    value : object
        The value that fixes the error; ``...`` when the message only names the parameter.
    form : {"", "pass", "Pass", "is", "where"}
        How the sentence uses it: ``""`` names it (``repair=True``, or ``joints`` without a
        value), ``"pass"``/``"Pass"`` asks for it (``pass repair=True``), ``"is"`` states the
        value in force (``in units='m'``), ``"where"`` says where the setting lives
        (``takes Solid(..., units=...)``).
    shown : str, optional
        The value as Python shows it when not ``repr(value)`` (``"[...]"``; ``""`` for a bare
        ``workers=``).
    python : str, optional
        The whole Python spelling, when it is not ``parameter=value`` (``package_dirs['hand']``).
    before, after : str
        Words around the fix that go with it: a front end that has no such setting drops them
        with it (``", or "`` .. ``" if this size is intended"``).
    file_key : str, optional
        The grasp-file key that sets the parameter (dotted when nested), filled in by the
        grasp-file reader; ``""`` for a Python-only escape hatch that no key reaches.
    """

    parameter: str
    value: Any = ...
    form: str = ""
    shown: str | None = None
    python: str | None = None
    before: str = ""
    after: str = ""
    file_key: str | None = None

    def assignment(self) -> str:
        """``parameter=value`` as Python spells it (the bare name without a value)."""
        if self.shown is not None:
            return f"{self.parameter}={self.shown}"
        return self.parameter if self.value is ... else f"{self.parameter}={self.value!r}"

    def in_python(self) -> str:
        """The fix as the Python API spells it, without `before` and `after`."""
        if self.python is not None:
            return self.python
        if self.form in ("pass", "Pass"):
            return f"{self.form} {self.assignment()}"
        return self.assignment()

    def replace(self, **changes: Any) -> Fix:
        """A copy with ``changes`` (`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)


def _in_python(fix: Fix) -> str:
    return fix.in_python()


class ExactGraspError(Exception):
    """Base class of every error raised on purpose by exactgrasp.

    Parameters
    ----------
    *parts : str or Fix
        The message: text, and the settings that fix the error (spelled by `spelling`).

    Attributes
    ----------
    parts : tuple of (str or Fix)
    spelling : callable
        A `Fix` -> its words in the front end that raised the error (None drops it); the
        Python API's spelling unless `respelled`.
    """

    def __init__(self, *parts: str | Fix):
        super().__init__(*parts)
        self.parts = parts
        self.spelling: Callable[[Fix], str | None] = _in_python

    def __str__(self) -> str:
        text = []
        for part in self.parts:
            if isinstance(part, Fix):
                spelled = self.spelling(part)
                part = "" if spelled is None else f"{part.before}{spelled}{part.after}"
            text.append(str(part))
        return "".join(text)

    @property
    def fixes(self) -> tuple[Fix, ...]:
        """The settings the message names, in order."""
        return tuple(p for p in self.parts if isinstance(p, Fix))

    @property
    def parameter(self) -> str | None:
        """The parameter of the first fix (None when the message names none)."""
        return self.fixes[0].parameter if self.fixes else None

    @property
    def subject(self) -> str | None:
        """The parameter the message is about, when it starts by naming it (``n_steps must
        be ...``); None when it starts with text."""
        first = self.parts[0] if self.parts else None
        return first.parameter if isinstance(first, Fix) else None

    def prefixed(self, *prefix: str | Fix) -> ExactGraspError:
        """The same error (class, fields, spelling) with ``prefix`` before its message (``"B: "``);
        raise it ``from`` this one to keep the chain."""
        return self.respelled(self.spelling, *prefix)

    def respelled(
        self,
        spelling: Callable[[Fix], str | None],
        *prefix: str | Fix,
        keys: dict[str, str] | None = None,
        cls: type[ExactGraspError] | None = None,
    ) -> ExactGraspError:
        """The same error for another front end: its fixes in ``spelling``'s words.

        Parameters
        ----------
        spelling : callable
            A `Fix` -> its words (None drops it).
        *prefix : str or Fix
            Parts put before the message (``"g.json: object: "``).
        keys : dict of str to str, optional
            Parameter -> the grasp-file key that sets it, recorded in each fix's `file_key`.
        cls : type, optional
            The class of the new error (default: this one's).

        Returns
        -------
        ExactGraspError
            Of class ``cls`` (or this error's class), with the same fields; raise it ``from``
            this one to keep the chain.
        """
        keys = keys or {}
        parts = tuple(
            p.replace(file_key=keys[p.parameter])
            if isinstance(p, Fix) and p.file_key is None and p.parameter in keys
            else p
            for p in (*prefix, *self.parts)
        )
        cls = cls or type(self)
        new = cls.__new__(cls)
        new.__dict__.update(self.__dict__)
        Exception.__init__(new, *parts)
        new.parts = parts
        new.spelling = spelling
        return new


class MeshError(ExactGraspError, ValueError):
    """A mesh is unusable as a solid (not closed, NaN coordinates, no faces, ...)."""


class UncertainCrossingError(MeshError):
    """A surface crosses or touches itself exactly at an edge or a corner, where floating-point
    signs cannot tell how, so the floating-point cut cannot decide it. The resolution of
    solids catches it and cuts in exact arithmetic instead (`exactgrasp.geometry.untangle`),
    so it does not reach a caller of `exactgrasp.Solid`.

    Attributes
    ----------
    why : str
        What was found, in words.
    point : numpy.ndarray, shape (3,)
        A point near it, in the mesh's coordinates.
    """

    def __init__(self, why: str, point):
        self.why = why
        self.point = point
        super().__init__(f"{why} near ({point[0]:.6g}, {point[1]:.6g}, {point[2]:.6g})")


class GraspError(ExactGraspError, ValueError):
    """A grasp that cannot be: a hand or object of the wrong kind, a pose that is not a rigid
    transform."""


class GraspFileError(GraspError):
    """A grasp JSON file is malformed, names files that do not exist, or holds a grasp that
    cannot be."""


class JointError(ExactGraspError, ValueError):
    """Unknown joint names or joint values outside the limits."""


class ModelError(ExactGraspError, ValueError):
    """A hand model (MJCF, URDF) cannot be turned into closed link meshes.

    Attributes
    ----------
    problems : tuple of ExactGraspError
        Each problem found, with its own fixes: the lines of a `report`, else this error.
    """

    @property
    def problems(self) -> tuple[ExactGraspError, ...]:
        return self.__dict__.get("listed", (self,))

    @classmethod
    def report(cls, source: str, problems: Sequence[ExactGraspError]) -> ExactGraspError:
        """One error for all of a model's ``problems``: one line each, with its fixes.

        ``source`` names the model file; a `ModelError` among ``problems`` brings its own
        `problems`. Returns the one problem itself, or a `ModelError` with a line per problem
        whose `problems` holds them; raise it.
        """
        listed = tuple(
            p
            for problem in problems
            for p in (problem.problems if isinstance(problem, ModelError) else (problem,))
        )
        if len(listed) == 1:
            return listed[0]
        parts: list[str | Fix] = [f"{source}: {len(listed)} problems, each with its fix:"]
        for problem in listed:
            parts += ["\n  - ", *problem.parts]
        error = cls(*parts)
        error.listed = listed
        return error


class BackendError(ExactGraspError, ValueError):
    """An unknown backend name, or bad backend parameters."""


class UncertainPoseError(ExactGraspError, ArithmeticError):
    """A pose at which the exact backend cannot certify the volume: the surfaces coincide
    exactly there, and no small translation gives certified volumes on one cubic (see
    ``docs/exact-backend.md``, "When the kernel cannot certify a pose").

    Attributes
    ----------
    pose : numpy.ndarray, shape (4, 4)
        The object's motion, about the exact backend's local origin.
    """

    def __init__(self, pose):
        self.pose = pose
        t = pose[:3, 3]
        super().__init__(
            "the exact volume cannot be certified at the pose translating the object by "
            f"({t[0]:.6g}, {t[1]:.6g}, {t[2]:.6g}) about the hand's centre: the surfaces "
            "coincide exactly there and the volume's limit along three small translations "
            "could not be certified either; move the object by a small amount (1e-9 of its "
            "size changes the volume by less than that) and compute again."
        )


class MissingDependencyError(ExactGraspError, ImportError):
    """An optional dependency needed for the requested feature is not installed."""

    def __init__(self, feature: str, package: str, extra: str):
        super().__init__(
            f"{feature} needs the optional package {package!r}, which is not installed; "
            f'install it with `pip install {package}` or `pip install "exactgrasp[{extra}]"`.'
        )
        self.feature = feature
        self.package = package
        self.extra = extra


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


class MeshWarning(UserWarning):
    """A mesh, its shells or a hand model was changed on loading (repaired, merged, flipped),
    or parts of it were left out: given once per distinct message per process (`warn_once`).
    """


class DataError(ExactGraspError, FileNotFoundError):
    """The shared data folder is missing or incomplete."""


class EvaluationError(ExactGraspError, ValueError):
    """Labelled pairs that cannot be evaluated: bad labels, unknown grasps, one class only."""


def _first_outside(frame: FrameType | None) -> tuple[FrameType | None, int]:
    """The first frame at or above ``frame`` whose code is not exactgrasp's, and how many
    frames up from ``frame`` it is."""
    steps = 0
    while frame is not None and frame.f_code.co_filename.startswith(_PACKAGE_DIR):
        frame, steps = frame.f_back, steps + 1
    return frame, steps


def outside_caller() -> tuple[str, int]:
    """(file, line) of the first caller outside exactgrasp: where a `warn_caller` warning given
    now, from inside the package, is attributed."""
    frame, _ = _first_outside(sys._getframe(1))
    return ("", 0) if frame is None else (frame.f_code.co_filename, frame.f_lineno)


def warned_here(warning: warnings.WarningMessage, site: tuple[str, int]) -> bool:
    """Whether a caught warning is exactgrasp's own: attributed to a line of the package, or
    to ``site``, the `outside_caller` of the code that caught it, where `warn_caller` puts
    exactgrasp's warnings (another library's is attributed to its own code, or to ours)."""
    return warning.filename.startswith(_PACKAGE_DIR) or (warning.filename, warning.lineno) == site


def warn_caller(message: str, category: type[Warning] = UserWarning) -> None:
    """Warn at the first caller outside exactgrasp, however deep inside the package we are."""
    _, steps = _first_outside(sys._getframe(1))
    warnings.warn(message, category, stacklevel=2 + steps)


#: The `warn_once` messages given in this process (clear it to hear them again).
WARNED: set[str] = set()
# Set while `recording_warnings` records what a build says, to be replayed (and counted) by
# the caller: a record kept in a cache, on disk too, must hold every message.
_RECORDING: contextvars.ContextVar[bool] = contextvars.ContextVar("recording", default=False)


def warn_once(message: str) -> None:
    """`warn_caller` with a `MeshWarning`, once per distinct message per process: the same
    mesh loaded or intersected again has nothing new to say (`WARNED` keeps what was said)."""
    recording = _RECORDING.get()
    if message in WARNED and not recording:
        return
    _, steps = _first_outside(sys._getframe(1))
    warnings.warn(message, MeshWarning, stacklevel=2 + steps)
    if not recording:  # after: a warning turned into an error (-W error) is raised again
        WARNED.add(message)


@contextlib.contextmanager
def recording_warnings() -> Iterator[list[warnings.WarningMessage]]:
    """Record every warning given inside the block (`warn_once`'s too, repeated or not, and
    not counted as given): for a cached build whose warnings its callers replay."""
    token = _RECORDING.set(True)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield caught
    finally:
        _RECORDING.reset(token)


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
        `ExactGraspError`; 130 after printing ``interrupted`` for a KeyboardInterrupt; 141,
        silently, when the reader of stdout has gone (``| head``): what a Unix tool killed by
        SIGPIPE gives the shell (128 + 13).
    """
    try:
        status = int(handler(args) or 0)
        sys.stdout.flush()  # here, where a closed pipe can still be told apart
        return status
    except ExactGraspError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # What is still buffered would fail again at exit, with a traceback: drop it.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141


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
