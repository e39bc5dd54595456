"""``exactgrasp descriptor``: the descriptor of one grasp file, written as ``.npz``.

The command-line face of `exactgrasp.descriptor.compute_descriptor`.
"""

from __future__ import annotations

import argparse
from typing import Any

from exactgrasp.cli.common import (
    add_backend,
    add_command,
    add_grasp_file,
    add_grasp_inputs,
    add_progress,
    grasp_from_args,
    sampler_from_args,
    timing,
)
from exactgrasp.cli.params import add_param, build_backend, split_params

__all__ = ["add_parser", "cmd_descriptor"]


#: The command's line in ``exactgrasp --help``.
HELP = "the descriptor of one grasp file"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Compute the descriptor of GRASP (a grasp JSON file) with one backend and "
    "write it as a .npz file (values: paths x steps, intersection volume / hand volume)."
)
EXAMPLE = "exactgrasp descriptor box.json --backend exact -o box.npz"


def cmd_descriptor(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp descriptor``; prints a one-line summary, returns 0."""
    from exactgrasp.descriptor import compute_descriptor

    sampler = sampler_from_args(args)
    backend = build_backend(args.backend, split_params(args.param, [args.backend])[args.backend])
    grasp = grasp_from_args(args)
    descriptor = compute_descriptor(grasp, sampler, backend=backend, progress=args.progress)
    out = descriptor.save(args.output)
    values = descriptor.values
    print(
        f"{grasp.name}: {values.shape[0]} paths x {values.shape[1]} steps with "
        f"{args.backend!r} {timing(descriptor.metadata)}; "
        f"mean {values.mean():.5f}, max {values.max():.5f} -> {out}"
    )
    return 0


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``descriptor`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "descriptor", cmd_descriptor, HELP, DESCRIPTION, EXAMPLE)
    add_grasp_file(parser, "output .npz file")
    add_backend(parser)
    add_param(parser)
    add_grasp_inputs(parser)
    add_progress(parser)
    return parser
