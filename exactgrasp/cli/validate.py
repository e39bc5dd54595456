"""``exactgrasp validate``: the validation report (see ``docs/validation.md``).

The options and the run live in `exactgrasp.report.args`, shared with
``python -m exactgrasp.report``; this module only hangs them under the ``exactgrasp`` command.
"""

from __future__ import annotations

import argparse
from typing import Any

from exactgrasp.cli.common import add_command
from exactgrasp.report.args import DESCRIPTION, HELP, add_arguments, run_from_args

__all__ = ["add_parser"]


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``validate`` sub-command to the ``exactgrasp`` command's subparsers."""
    example = "exactgrasp validate --quick --out report"
    parser = add_command(subparsers, "validate", run_from_args, HELP, DESCRIPTION, example)
    add_arguments(parser)
    return parser
