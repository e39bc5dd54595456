"""What the ``exactgrasp`` sub-commands share: ``--backend``, ``--sampler``/``--steps``,
``--progress``, the grasp-file options (``--units``, ``--repair``, ``--on-limit``) and reading a
grasp with them.

Each option is defined here once, so every command spells, checks and documents it the same
way; errors name the flag, never the Python argument behind it. ``--param`` lives in
`exactgrasp.cli.params`.

May import: `exactgrasp.errors`, `exactgrasp.geometry.intake`, `exactgrasp.paths`,
`exactgrasp.grasp`, `exactgrasp.backends.defaults`; no other `exactgrasp.cli` module.
"""

from __future__ import annotations

import argparse
import json
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

from exactgrasp.backends.defaults import DEFAULT_BACKEND
from exactgrasp.errors import ExactGraspError, SamplerError
from exactgrasp.geometry.intake import UNITS
from exactgrasp.paths.presets import DEFAULT_PRESET, SAMPLER_PARAMETERS, accepted_forms, as_sampler
from exactgrasp.paths.sampler import PRESETS, PathSampler

if TYPE_CHECKING:
    from exactgrasp.grasp import Grasp

__all__ = [
    "FILE_KEYS_TO_FLAGS",
    "ON_LIMIT",
    "PYTHON_TO_FLAGS",
    "add_backend",
    "add_grasp_options",
    "add_on_limit",
    "add_progress",
    "add_sampler",
    "add_steps",
    "described",
    "flag_message",
    "grasp_from_args",
    "read_grasp",
    "renamed",
    "sampler_from_args",
    "timing",
]

ON_LIMIT = ("error", "clip")
#: Python spellings in library messages and the flags that set the same thing here.
PYTHON_TO_FLAGS = (
    *((f"in units={unit!r}", f"in units {unit}") for unit in UNITS),
    *((f"units={unit!r}", f"--units {unit}") for unit in UNITS),
    ("repair=True", "--repair"),
    ("on_limit='clip'", "--on-limit clip"),
)


def _file_key_fixes(key: str, value: str, flag: str) -> tuple[tuple[str, str], ...]:
    """How a grasp file's error spells the fix ``key: value``, and the flag that makes it."""
    spelled = f"{json.dumps(key)}: {value}"
    return (
        (f"set {spelled} in the grasp file", f"pass {flag} (or set {spelled} in the grasp file)"),
        (f"Set {spelled} in the grasp file", f"Pass {flag} (or set {spelled} in the grasp file)"),
    )


#: The grasp-file keys that errors from reading a grasp file name (``set "object_units": "mm"
#: in the grasp file``) and the flags that override them.
FILE_KEYS_TO_FLAGS = (
    *((f'in "object_units": "{u}"', f"in units {u}") for u in UNITS),
    *(f for u in UNITS for f in _file_key_fixes("object_units", json.dumps(u), f"--units {u}")),
    *_file_key_fixes("object_repair", "true", "--repair"),
    *_file_key_fixes("on_limit", '"clip"', "--on-limit clip"),
    (
        'takes "object_units" in the grasp file',
        'takes --units (or "object_units" in the grasp file)',
    ),
    *PYTHON_TO_FLAGS,
)


def flag_message(message: str, pairs: tuple[tuple[str, str], ...] = PYTHON_TO_FLAGS) -> str:
    """A library message with its Python argument spellings replaced by the flags."""
    for python, flag in pairs:
        message = message.replace(python, flag)
    return message


def renamed(exc: ExactGraspError, message: str) -> ExactGraspError:
    """An error of the same class as ``exc`` with another message (the base class where that
    class takes other constructor arguments)."""
    try:
        return type(exc)(message)
    except TypeError:
        return ExactGraspError(message)


def described(text: str, example: str) -> str:
    """A command's ``--help`` description: ``text``, one example and where the rest is."""
    return (
        f"{text} Example: {example} . Every flag, with examples: docs/cli.md; from your own "
        "hand and objects to a dataset's descriptors: docs/tutorial.md."
    )


def timing(metadata: dict) -> str:
    """``in 2.31 s``, with the seconds spent compiling the kernels said apart (a descriptor's
    ``seconds`` include them; they are spent once, on first use)."""
    compiled = float(metadata.get("compile_seconds", 0.0))
    text = f"in {metadata['seconds'] - compiled:.2f} s"
    if compiled >= 0.05:
        text += f" (and {compiled:.1f} s compiling the kernels, first use only)"
    return text


# -- --backend -------------------------------------------------------------------------------


def add_backend(parser: argparse.ArgumentParser) -> None:
    """The ``--backend NAME`` option of a command that runs one backend (default: the
    paper's estimator, `exactgrasp.backends.defaults.DEFAULT_BACKEND`)."""
    parser.add_argument(
        "--backend",
        default=DEFAULT_BACKEND,
        help=f"backend name: {DEFAULT_BACKEND} (default), exact or a registered one",
    )


# -- --sampler and --steps --------------------------------------------------------------------


def _sampler_forms() -> str:
    return (
        f"use a preset ({', '.join(PRESETS)}), JSON text of PathSampler parameters "
        f"({', '.join(SAMPLER_PARAMETERS)}) or the path of a JSON file holding them"
    )


def add_steps(parser: argparse.ArgumentParser) -> None:
    """The ``--steps N`` option (poses per path, replacing the sampler's ``n_steps``)."""
    parser.add_argument(
        "--steps",
        type=int,
        default=None,
        metavar="N",
        help="poses per path, replacing the sampler's n_steps (default: the sampler's, 9 for "
        "the presets)",
    )


def add_sampler(parser: argparse.ArgumentParser) -> None:
    """``--sampler`` (preset, JSON text or JSON file, through `as_sampler`) and ``--steps``."""
    parser.add_argument(
        "--sampler",
        default=DEFAULT_PRESET,
        metavar="SAMPLER",
        help=f"path sampler: a preset ({', '.join(PRESETS)}), PathSampler parameters as JSON "
        'text (e.g. \'{"n_translations": 6, "n_axes": 2, "n_amounts": 2}\') or a JSON file of '
        f"them (default: {DEFAULT_PRESET})",
    )
    add_steps(parser)


def sampler_from_args(args: argparse.Namespace) -> PathSampler:
    """The sampler of ``--sampler`` and ``--steps``, through `exactgrasp.paths.as_sampler`.

    Raises
    ------
    SamplerError
        Naming ``--steps`` or ``--sampler`` and what each accepts.
    """
    steps = getattr(args, "steps", None)
    text = getattr(args, "sampler", None)
    if text is not None and text not in PRESETS and not text.lstrip().startswith("{"):
        if not Path(text).is_file():
            raise SamplerError(
                f"--sampler {text!r}: not a preset, JSON text or a JSON file; {_sampler_forms()}."
            )
        text_or_file = Path(text)
    else:
        text_or_file = text
    if steps is not None and steps < 1:
        raise SamplerError(f"--steps must be a positive number of poses per path, got {steps}.")
    try:
        return as_sampler(text_or_file, n_steps=steps)
    except SamplerError as exc:
        # The library's message names the value and the Python forms; here, the flag's.
        reason = str(exc).replace(accepted_forms(), _sampler_forms())
        reason = re.sub(r"^sampler (file )?('[^']*'|\{.*?\}): ", "", reason)
        raise SamplerError(f"--sampler {text!r}: {reason}") from exc


# -- --progress ------------------------------------------------------------------------------


def add_progress(parser: argparse.ArgumentParser) -> None:
    """The ``--progress/--no-progress`` option."""
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar (default: only on a terminal)",
    )


# -- grasp files -----------------------------------------------------------------------------


def add_on_limit(parser: argparse.ArgumentParser) -> None:
    """The ``--on-limit {error,clip}`` option (default: what each grasp file says)."""
    parser.add_argument(
        "--on-limit",
        default=None,
        choices=ON_LIMIT,
        help="joint values outside the limits: refuse (error) or clip with a warning (default: "
        "the grasp file's on_limit, else error)",
    )


def add_grasp_options(parser: argparse.ArgumentParser) -> None:
    """``--units``, ``--repair/--no-repair`` and ``--on-limit``: overrides of a grasp file."""
    parser.add_argument(
        "--units",
        default=None,
        choices=tuple(UNITS),
        help="units of the object's mesh file, replacing the grasp file's object_units "
        "(default: the file's, else m)",
    )
    parser.add_argument(
        "--repair",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="close and orient the object's mesh (trimesh, pymeshfix) or not, replacing the "
        "grasp file's object_repair (default: the file's, else no)",
    )
    add_on_limit(parser)


def read_grasp(
    path: str | os.PathLike,
    units: str | None = None,
    repair: bool | None = None,
    on_limit: str | None = None,
) -> Grasp:
    """`Grasp.from_file` with the command line's overrides; None keeps what the file says.

    Parameters
    ----------
    path : path-like
        Grasp JSON file.
    units : {"m", "cm", "mm", "inch", "in"}, optional
        Replaces the file's ``object_units``.
    repair : bool, optional
        Replaces the file's ``object_repair``.
    on_limit : {"error", "clip"}, optional
        Replaces the file's ``on_limit``.

    Returns
    -------
    Grasp

    Raises
    ------
    ExactGraspError
        As `Grasp.from_file`, with the fixes it names (grasp-file keys, Python arguments)
        spelled as the flags that make them.
    """
    from exactgrasp.grasp import Grasp

    given = (("units", units), ("repair", repair), ("on_limit", on_limit))
    overrides = {key: value for key, value in given if value is not None}
    try:
        return Grasp.from_file(path, **overrides)
    except ExactGraspError as exc:
        message = flag_message(str(exc), FILE_KEYS_TO_FLAGS)
        if message == str(exc):
            raise
        raise renamed(exc, message) from exc


def grasp_from_args(args: argparse.Namespace, path: str | os.PathLike | None = None) -> Grasp:
    """The grasp file ``path`` (default ``args.grasp``) read with the options of
    `add_grasp_options`."""
    return read_grasp(
        args.grasp if path is None else path,
        units=getattr(args, "units", None),
        repair=getattr(args, "repair", None),
        on_limit=getattr(args, "on_limit", None),
    )
