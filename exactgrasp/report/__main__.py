"""``python -m exactgrasp.report --data D --out O``: the validation report without the
``exactgrasp`` command (the options of ``exactgrasp validate``; works from a checkout root
without installing, since ``-m`` puts the current folder on the path).

May import: `exactgrasp.errors`, `exactgrasp.report.args`; never `exactgrasp.cli`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from exactgrasp.errors import ExactGraspError
from exactgrasp.report.args import DESCRIPTION, add_arguments, run_from_args

PROG = "python -m exactgrasp.report"


def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default: the command line), run the report; returns the exit status."""
    parser = add_arguments(argparse.ArgumentParser(prog=PROG, description=DESCRIPTION))
    args = parser.parse_args(argv)
    try:
        return run_from_args(args, prog=PROG)
    except ExactGraspError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
