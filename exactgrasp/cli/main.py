"""The ``exactgrasp`` command: `build_parser` and `main`.

Each sub-command is one module of `exactgrasp.cli` with ``add_parser(subparsers)``, which
adds its sub-parser and sets ``func`` (the handler: parsed arguments in, exit status out).
Adding a command is a new module plus one entry in `COMMANDS`, whose order is the order of
``exactgrasp --help``. Handlers raise `ExactGraspError` for bad input; `main` turns it into
a message and exit status 2 (`exactgrasp.errors.run_reporting_errors`, which also ends a
command whose reader has gone, ``| head``, quietly with status 141). Python warnings print as
``Category: message`` (`format_warning`), without the line of code they are attributed to.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence

from exactgrasp.cli import (
    batch,
    close,
    compare,
    demo,
    descriptor,
    evaluate,
    inspect,
    overlap,
    separate,
    show,
    validate,
)
from exactgrasp.diagnostics import ignores_third_party_warnings
from exactgrasp.errors import run_reporting_errors
from exactgrasp.version import __version__

__all__ = ["COMMANDS", "build_parser", "format_warning", "main"]

#: The sub-command modules, in the order ``exactgrasp --help`` lists them.
COMMANDS = (
    demo,
    descriptor,
    compare,
    close,
    separate,
    inspect,
    show,
    overlap,
    validate,
    batch,
    evaluate,
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``exactgrasp`` command."""
    parser = argparse.ArgumentParser(
        prog="exactgrasp",
        description="Grasp descriptors from hand-object intersection along rigid paths. "
        "Start with `exactgrasp demo --quick`; `exactgrasp COMMAND --help` shows a command's "
        "flags and an example; every command: docs/cli.md; from your own hand and objects to "
        "a dataset's descriptors: docs/tutorial.md.",
    )
    parser.add_argument("--version", action="version", version=f"exactgrasp {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.add_parser(sub)
    return parser


def format_warning(message, category, filename, lineno, line=None) -> str:
    """A warning as the command prints it: ``Category: message``. The line of code it is
    attributed to (the console script's own, for exactgrasp's warnings) means nothing to
    someone at a shell. Signature of `warnings.formatwarning`: only the text changes, so a
    caller that records warnings (`warnings.catch_warnings`) still gets them."""
    return f"{category.__name__}: {message}\n"


@ignores_third_party_warnings
def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``exactgrasp`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    formatted = warnings.formatwarning
    warnings.formatwarning = format_warning
    try:
        return run_reporting_errors(args.func, args, prog=f"exactgrasp {args.command}")
    finally:
        warnings.formatwarning = formatted


if __name__ == "__main__":
    sys.exit(main())
