"""``python -m exactgrasp.evaluation``: build the report "What the descriptor tells you"."""

from __future__ import annotations

import argparse
import shlex
import sys

from exactgrasp.datapath import data_dir
from exactgrasp.errors import run_reporting_errors
from exactgrasp.evaluation.run import SECTIONS, build_report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m exactgrasp.evaluation",
        description="Build docs/reports/descriptor-meaning/: descriptor distances on the "
        "authors' cereal-box clusters, the noise test, the sampling trade-off, raw against "
        "contact-adjusted grasps and three hands.",
    )
    parser.add_argument("--data", default=None, help="shared data folder (default: found)")
    parser.add_argument("--out", default="docs/reports/descriptor-meaning", help="report folder")
    parser.add_argument(
        "--cache", default=".evaluation-cache", help="descriptor and section cache folder"
    )
    parser.add_argument("--quick", action="store_true", help="small samplers: minutes")
    parser.add_argument("--fresh", action="store_true", help="recompute the sections")
    parser.add_argument("--n-boot", type=int, default=2000, help="bootstrap replicates")
    parser.add_argument(
        "--sections",
        default=None,
        help=f"comma-separated sections to compute ({', '.join(SECTIONS)}); the others keep "
        "the numbers and figures of the report's existing summary.json (default: all)",
    )
    args = parser.parse_args(argv)
    command = "python -m exactgrasp.evaluation " + " ".join(map(shlex.quote, argv or sys.argv[1:]))

    def run(a: argparse.Namespace) -> int:
        sections = None if a.sections is None else tuple(filter(None, a.sections.split(",")))
        build_report(
            a.data or data_dir(),
            a.out,
            a.cache,
            a.quick,
            a.fresh,
            a.n_boot,
            command.strip(),
            sections=sections,
        )
        return 0

    return run_reporting_errors(run, args, prog="python -m exactgrasp.evaluation")


if __name__ == "__main__":
    sys.exit(main())
