"""``exactgrasp compare``: distances between descriptor files, or backends pose by pose on one
grasp file.

The command-line face of `exactgrasp.descriptor.pairwise_distances` and
`exactgrasp.compare.compare_backends`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from exactgrasp.backends.defaults import COMPARED_BACKENDS
from exactgrasp.cli.common import (
    add_command,
    add_grasp_inputs,
    add_progress,
    grasp_from_args,
    sampler_from_args,
)
from exactgrasp.cli.params import add_param, build_backend, split_params
from exactgrasp.errors import ExactGraspError

__all__ = ["add_parser", "cmd_compare"]


#: The command's line in ``exactgrasp --help``.
HELP = "distances between descriptor files, or backends pose by pose on a grasp file"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "With two or more .npz descriptor files: their l2 and l2_diff distance "
    "matrices. With one grasp JSON file: every backend of --backends on the same poses, "
    "compared pose by pose with the last one (the reference)."
)
EXAMPLE = "exactgrasp compare box.json --backends voxel,exact -o poses.csv"


def _distances(inputs: list[Path]) -> int:
    from exactgrasp.descriptor import Descriptor, pairwise_distances

    descriptors = [Descriptor.load(p) for p in inputs]
    if len(descriptors) < 2:
        raise ExactGraspError("compare needs at least two .npz descriptors.")
    first = descriptors[0]
    for path, other in zip(inputs[1:], descriptors[1:], strict=True):
        if other.shape != first.shape or other.sampler.params != first.sampler.params:
            raise ExactGraspError(
                f"{inputs[0]} and {path} come from different samplers, so their paths do not "
                f"correspond: {inputs[0]}: {_sampler_text(first)}; {path}: "
                f"{_sampler_text(other)}. Compute both with the same --sampler and --steps "
                f"(exactgrasp descriptor GRASP --sampler '{_sampler_json(first)}' -o OUT.npz "
                f"gives {inputs[0].name}'s)."
            )
    for kind in ("l2", "l2_diff"):
        matrix = pairwise_distances(descriptors, kind=kind)
        print(f"{kind} distances:")
        for i, path in enumerate(inputs):
            row = "  ".join(f"{matrix[i, j]:10.6f}" for j in range(len(inputs)))
            print(f"  {path.name:30s} {row}")
    return 0


def _sampler_json(d) -> str:
    return json.dumps(d.sampler.params, separators=(", ", ": "))


def _sampler_text(d) -> str:
    return f"{d.shape[0]} paths x {d.shape[1]} steps, sampler {_sampler_json(d)}"


def cmd_compare(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp compare``; prints distance matrices or a backend summary."""
    inputs = [Path(p) for p in args.inputs]
    if all(p.suffix == ".npz" for p in inputs):
        if args.param:
            raise ExactGraspError(
                "--param sets backend parameters, which only compare on a grasp file uses; "
                "descriptor files were computed already."
            )
        return _distances(inputs)
    if len(inputs) == 1 and inputs[0].suffix == ".json":
        sampler = sampler_from_args(args)
        names = [b.strip() for b in args.backends.split(",") if b.strip()]
        if len(names) < 2:
            raise ExactGraspError(
                f"--backends {args.backends}: name at least two backends, the reference last, "
                f"e.g. --backends {','.join(COMPARED_BACKENDS)}."
            )
        params = split_params(args.param, names, flag="--backends")
        backends = [build_backend(name, params[name]) for name in names]
        grasp = grasp_from_args(args, inputs[0])
        from exactgrasp.compare import compare_backends, write_table

        result = compare_backends(grasp, sampler, backends=backends, progress=args.progress)
        print(result.summary_text())
        if args.output:
            print(f"per-pose table -> {write_table(result.table, args.output)}")
        return 0
    raise ExactGraspError(
        "compare takes either two or more descriptor files (.npz) or one grasp file (.json) "
        f"with --backends {','.join(COMPARED_BACKENDS)}."
    )


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``compare`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "compare", cmd_compare, HELP, DESCRIPTION, EXAMPLE)
    parser.add_argument("inputs", nargs="+", metavar="INPUT", help="a.npz b.npz ... or GRASP.json")
    parser.add_argument(
        "--backends",
        default=",".join(COMPARED_BACKENDS),
        metavar="B1,B2,...",
        help="for a grasp file; the last is the reference (default: %(default)s)",
    )
    parser.add_argument(
        "-o", "--output", default=None, help="write the per-pose table (.csv or .parquet)"
    )
    add_param(parser)
    add_grasp_inputs(parser)
    add_progress(parser)
    return parser
