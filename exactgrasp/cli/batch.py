"""``exactgrasp batch``: the command-line face of `exactgrasp.batch.run_batch`.

``--units``, ``--repair`` and ``--on-limit`` replace what every grasp file of the manifest says,
as `run_batch`'s ``units``, ``repair`` and ``on_limit`` do; errors name the flags, not those
arguments.

May import: `exactgrasp.errors`, `exactgrasp.cli.common`, `exactgrasp.cli.params`,
`exactgrasp.batch` (pyarrow and distributed load only when a batch runs).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from exactgrasp.batch.run import DEFAULT_PART_SIZE, run_batch
from exactgrasp.cli.common import (
    add_backend,
    add_grasp_options,
    add_progress,
    add_sampler,
    flag_message,
    renamed,
    sampler_from_args,
)
from exactgrasp.cli.params import add_param, build_backend, split_params
from exactgrasp.errors import BatchError

__all__ = ["BATCH_FLAGS", "add_parser", "cmd_batch"]

#: `run_batch`'s spellings of its arguments in messages, and the flags that set them here.
BATCH_FLAGS = (
    (
        "workers= sets up a local cluster; with scheduler= use its workers.",
        "--workers sets up a local cluster; with --scheduler the cluster's own workers "
        "compute: leave --workers out.",
    ),
    ("workers must be an integer >= 0, got", "--workers must be an integer >= 0, got"),
    ("part_size must be an integer >= 1, got", "--part-size must be an integer >= 1, got"),
)


def cmd_batch(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp batch``; returns 0 when every row succeeded, 1 otherwise."""
    sampler = sampler_from_args(args)
    params = split_params(args.param, [args.backend])[args.backend]
    build_backend(args.backend, params)  # refuses bad parameters before any work starts
    try:
        summary = _run(args, sampler, params)
    except BatchError as exc:
        message = flag_message(str(exc), BATCH_FLAGS)
        if message == str(exc):
            raise
        raise renamed(exc, message) from exc
    print(summary.text(), file=sys.stdout)
    return summary.exit_status


def _run(args: argparse.Namespace, sampler, params: dict):
    """`run_batch` with the command's arguments."""
    return run_batch(
        args.manifest,
        args.out,
        backend=args.backend,
        sampler=sampler,
        workers=args.workers,
        scheduler=args.scheduler,
        backend_params=params,
        progress=args.progress,
        part_size=args.part_size,
        on_limit=args.on_limit,
        retry_failed=args.retry_failed,
        units=args.units,
        repair=args.repair,
    )


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``batch`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = subparsers.add_parser(
        "batch",
        help="descriptors of every grasp in a manifest, resumable, on local cores or a cluster",
        description=(
            "Compute the descriptor of every grasp listed in MANIFEST (.jsonl or .parquet; rows "
            '{"id": ..., "grasp": "path/to/grasp.json" or an inline grasp}) into --out. Run the '
            "same command again after a kill to finish what is left. Exit status 1 when any "
            "row failed (see OUT/errors.jsonl), 2 on a bad manifest or arguments."
        ),
    )
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
    parser.set_defaults(func=cmd_batch)
    return parser
