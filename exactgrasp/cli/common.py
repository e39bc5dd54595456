"""What the ``exactgrasp`` sub-commands share: ``--backend``, ``--sampler``/``--steps``,
``--progress``, the grasp-file options (``--units``, ``--repair``, ``--on-limit``) and reading a
grasp with them.

Each option is defined here once, so every command spells, checks and documents it the same
way; errors name the flag, never the Python argument behind it: `FlagTerms` spells the fixes
that errors carry (`exactgrasp.errors.Fix`) as flags. ``--param`` lives in
`exactgrasp.cli.params`.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from exactgrasp.backends.defaults import DEFAULT_BACKEND
from exactgrasp.errors import ExactGraspError, Fix, SamplerError
from exactgrasp.geometry.intake import UNITS
from exactgrasp.given import given
from exactgrasp.paths.presets import DEFAULT_PRESET, SAMPLER_PARAMETERS, as_sampler
from exactgrasp.paths.sampler import PRESETS, PathSampler

if TYPE_CHECKING:
    from exactgrasp.grasp import Grasp

__all__ = [
    "FILE_KEY_FLAGS",
    "GRASP_FLAGS",
    "GRASP_TERMS",
    "ON_LIMIT",
    "FlagTerms",
    "add_backend",
    "add_command",
    "add_grasp_file",
    "add_grasp_inputs",
    "add_grasp_options",
    "add_on_limit",
    "add_progress",
    "add_sampler",
    "add_steps",
    "described",
    "flag",
    "grasp_from_args",
    "in_flag_terms",
    "read_grasp",
    "sampler_and_grasp",
    "sampler_from_args",
    "timing",
]

ON_LIMIT = ("error", "clip")


# -- errors in the command line's terms ---------------------------------------------------


def flag(text: str) -> Callable[[Fix], str]:
    """The spelling of a fix set by the flag ``text`` (with the fix's verb: ``pass --repair``)."""

    def spell(fix: Fix) -> str:
        return f"{fix.form} {text}" if fix.form in ("pass", "Pass") else text

    return spell


def _units_flag(fix: Fix) -> str | None:
    if fix.value is ...:
        return flag("--units")(fix)
    return flag(f"--units {fix.value}")(fix) if fix.value in UNITS else None


#: The flags of the grasp-file options (`add_grasp_options`), by `run_batch`'s and
#: `Grasp.from_file`'s argument: the fix in the flag's words (None keeps the Python spelling).
GRASP_FLAGS: dict[str, Callable[[Fix], str | None]] = {
    "units": _units_flag,
    "repair": lambda fix: flag("--repair")(fix) if fix.value is True else None,
    "on_limit": lambda fix: (
        flag(f"--on-limit {fix.value}")(fix) if fix.value in ON_LIMIT else None
    ),
}
#: The grasp-file keys that the grasp-file flags override, and the argument behind each.
FILE_KEY_FLAGS = {"object_units": "units", "object_repair": "repair", "on_limit": "on_limit"}


@dataclass(frozen=True)
class FlagTerms:
    """A `Fix` in a command's words: the flag that sets its parameter; for a grasp-file key the
    command overrides, the flag and then the key (``pass --repair (or set "object_repair":
    true in the grasp file)``); any other, as the Python API or the grasp file spells it.

    Parameters
    ----------
    flags : dict of str to callable
        Argument -> its fix in the command's words (None keeps the Python spelling).
    """

    flags: Mapping[str, Callable[[Fix], str | None]]

    def __call__(self, fix: Fix) -> str | None:
        if fix.file_key is not None:
            return self._file_key(fix)
        if fix.form == "is" and fix.parameter in self.flags:
            return f"{fix.parameter} {fix.value}"  # the value in force: not a flag to pass
        spell = self.flags.get(fix.parameter)
        spelled = spell(fix) if spell is not None else None
        return fix.in_python() if spelled is None else spelled

    def _file_key(self, fix: Fix) -> str | None:
        from exactgrasp.grasp.files import file_terms

        parameter = FILE_KEY_FLAGS.get(fix.file_key)
        if parameter not in self.flags or fix.form not in ("pass", "Pass", "is", "where"):
            return file_terms(fix)
        if fix.form == "is":
            return f"{fix.parameter} {fix.value}"
        in_file = file_terms(fix.replace(form="where" if fix.form == "where" else "pass"))
        if fix.form == "where":
            return f"{self.flags[parameter](fix.replace(form=''))} (or {in_file})"
        return f"{self.flags[parameter](fix)} (or {in_file})"


#: The grasp-file options' spelling, for commands that read grasp files.
GRASP_TERMS = FlagTerms(GRASP_FLAGS)


def in_flag_terms(exc: ExactGraspError, terms: FlagTerms, *prefix: str) -> ExactGraspError:
    """``exc`` with its fixes spelled as ``terms``' flags (and ``prefix`` before it); raise it
    ``from exc``."""
    return exc.respelled(terms, *prefix)


def described(text: str, example: str) -> str:
    """A command's ``--help`` description: ``text``, one example and where the rest is."""
    return (
        f"{text} Example: {example} . Every flag, with examples: docs/cli.md; from your own "
        "hand and objects to a dataset's descriptors: docs/tutorial.md."
    )


def add_command(
    subparsers: Any,
    name: str,
    handler: Callable[[argparse.Namespace], int],
    summary: str,
    text: str,
    example: str,
) -> argparse.ArgumentParser:
    """Add a sub-command to the ``exactgrasp`` command's subparsers.

    Parameters
    ----------
    subparsers : argparse subparsers action
    name : str
    handler : callable
        Runs the command on the parsed arguments and returns its exit status.
    summary : str
        The command's line in ``exactgrasp --help``.
    text, example : str
        Its ``--help`` description (`described`).

    Returns
    -------
    argparse.ArgumentParser
        The command's parser, for its own options.
    """
    parser = subparsers.add_parser(name, help=summary, description=described(text, example))
    parser.set_defaults(func=handler)
    return parser


def options_named(args: argparse.Namespace, *names: str) -> dict[str, Any]:
    """The parsed options ``names`` as keyword arguments of the library call they are named
    after (each flag's destination is the parameter's name)."""
    return {name: getattr(args, name) for name in names}


def timing(metadata: dict) -> str:
    """``in 2.31 s``: a descriptor's wall ``seconds``, from its metadata."""
    return f"in {metadata['seconds']:.2f} s"


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


def _sampler_terms(fix: Fix) -> str | None:
    """`as_sampler`'s fixes on the command line: the flag names the value, and its forms."""
    if fix.form == "subject":
        return None
    return _sampler_forms() if fix.form == "forms" else fix.in_python()


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
        raise exc.respelled(_sampler_terms, f"--sampler {text!r}: ") from exc


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


def add_grasp_file(
    parser: argparse.ArgumentParser, output: str, grasp: str = "grasp JSON file"
) -> None:
    """The ``GRASP`` argument (described by ``grasp``) and the required ``-o/--output``
    (described by ``output``) of a command that writes what it makes of one grasp file."""
    parser.add_argument("grasp", metavar="GRASP", help=grasp)
    parser.add_argument("-o", "--output", required=True, help=output)


def add_grasp_inputs(parser: argparse.ArgumentParser) -> None:
    """The options of a command that samples paths around grasp files: ``--sampler`` and
    ``--steps`` (`add_sampler`), then the grasp-file overrides (`add_grasp_options`)."""
    add_sampler(parser)
    add_grasp_options(parser)


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

    overrides = given({"units": units, "repair": repair, "on_limit": on_limit})
    try:
        return Grasp.from_file(path, **overrides)
    except ExactGraspError as exc:
        if not exc.fixes:
            raise
        raise in_flag_terms(exc, GRASP_TERMS) from exc


def grasp_from_args(args: argparse.Namespace, path: str | os.PathLike | None = None) -> Grasp:
    """The grasp file ``path`` (default ``args.grasp``) read with the options of
    `add_grasp_options`."""
    return read_grasp(
        args.grasp if path is None else path,
        units=getattr(args, "units", None),
        repair=getattr(args, "repair", None),
        on_limit=getattr(args, "on_limit", None),
    )


def sampler_and_grasp(
    args: argparse.Namespace, check: Callable[[PathSampler], object] | None = None
) -> tuple[PathSampler, Grasp]:
    """The sampler of ``--sampler`` and ``--steps``, and the grasp file ``args.grasp`` read
    with the options of `add_grasp_options`.

    The sampler comes first and ``check(sampler)`` (the command's flags that depend on it)
    next, so that a wrong flag is refused, naming the flag, before the grasp's meshes load.
    """
    sampler = sampler_from_args(args)
    if check is not None:
        check(sampler)
    return sampler, grasp_from_args(args)
