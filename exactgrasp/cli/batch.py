"""``exactgrasp batch``: the command-line face of `exactgrasp.batch.run_batch`.

``--units``, ``--repair`` and ``--on-limit`` replace what every grasp file of the manifest says,
as `run_batch`'s ``units``, ``repair`` and ``on_limit`` do; errors name the flags, not those
arguments.

pyarrow and distributed load only when a batch runs.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from exactgrasp.batch.manifest import DEFAULT_PART_SIZE
from exactgrasp.cli.common import (
    FlagTerms,
    add_backend,
    add_command,
    add_grasp_options,
    add_progress,
    add_sampler,
    flag,
    in_flag_terms,
    options_named,
    sampler_from_args,
)
from exactgrasp.cli.params import add_param, build_backend, split_params
from exactgrasp.errors import BatchError, Fix

__all__ = ["BATCH_TERMS", "add_parser", "cmd_batch"]


#: The command's line in ``exactgrasp --help``.
HELP = "descriptors of every grasp in a manifest, resumable, on local cores or a cluster"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Compute the descriptor of every grasp listed in MANIFEST (.jsonl or .parquet; "
    'rows {"id": ..., "grasp": "path/to/grasp.json" or an inline grasp}) into '
    "--out. Run the same command again after a kill to finish what is left. Exit "
    "status 1 when any row failed (see OUT/errors.jsonl), 2 on a bad manifest or "
    "arguments."
)
EXAMPLE = "exactgrasp batch manifest.jsonl --out run --workers 2"


def _workers(fix: Fix) -> str:
    if fix.form == "pass" and fix.value is None:  # with a scheduler: leave workers out
        return "the cluster's own workers compute: leave --workers out"
    return "--workers"


#: `run_batch`'s arguments and the flags that set them here.
BATCH_TERMS = FlagTerms(
    {"workers": _workers, "scheduler": flag("--scheduler"), "part_size": flag("--part-size")}
)


def cmd_batch(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp batch``; returns 0 when every row succeeded, 1 otherwise."""
    sampler = sampler_from_args(args)
    # Built here, so that bad parameters are refused before any work starts.
    backend = build_backend(args.backend, split_params(args.param, [args.backend])[args.backend])
    try:
        summary = _run(args, sampler, backend)
    except BatchError as exc:
        if not exc.fixes:
            raise
        raise in_flag_terms(exc, BATCH_TERMS) from exc
    print(summary.text(), file=sys.stdout)
    return summary.exit_status


def _run(args: argparse.Namespace, sampler, backend):
    """`run_batch` with the command's arguments."""
    from exactgrasp.batch.run import run_batch

    return run_batch(
        args.manifest,
        args.out,
        backend=backend,
        sampler=sampler,
        **options_named(
            args, "workers", "scheduler", "progress", "part_size", "on_limit", "retry_failed",
            "units", "repair",
        ),
    )  # fmt: skip


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``batch`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "batch", cmd_batch, HELP, DESCRIPTION, EXAMPLE)
    parser.add_argument("manifest", metavar="MANIFEST", help="manifest file (.jsonl or .parquet)")
    parser.add_argument("--out", required=True, help="output folder (created; resumed if there)")
    add_backend(parser)
    add_param(parser)
    add_sampler(parser)
    parser.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: all cores)"
    )
    parser.add_argument("--scheduler", default=None, help="address of a running dask scheduler")
    parser.add_argument(
        "--part-size",
        type=int,
        default=DEFAULT_PART_SIZE,
        help=(
            f"rows per output part, the unit of resuming (default {DEFAULT_PART_SIZE}); the "
            "work is cut into tasks sized from the rows and the workers"
        ),
    )
    parser.add_argument(
        "--retry-failed", action="store_true", help="compute the parts with failed rows again"
    )
    add_grasp_options(parser)
    add_progress(parser)
    return parser
