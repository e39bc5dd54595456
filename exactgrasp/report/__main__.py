"""``python -m exactgrasp.report --data D --out O``: the validation report without the
``exactgrasp`` command (the options of ``exactgrasp validate``; works from a checkout root
without installing, since ``-m`` puts the current folder on the path).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from functools import partial

from exactgrasp.errors import run_reporting_errors
from exactgrasp.report.args import DESCRIPTION, add_arguments, run_from_args

PROG = "python -m exactgrasp.report"


def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default: the command line), run the report; returns the exit status."""
    parser = add_arguments(argparse.ArgumentParser(prog=PROG, description=DESCRIPTION))
    args = parser.parse_args(argv)
    return run_reporting_errors(partial(run_from_args, prog=PROG), args, prog=PROG)


if __name__ == "__main__":
    sys.exit(main())
