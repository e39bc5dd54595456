"""The ``exactgrasp`` command: demo, descriptor, compare (and validate, batch when installed)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from exactgrasp.errors import ExactGraspError


def _parse_value(text: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return None if text == "None" else text


def _backend_params(items: Sequence[str]) -> dict[str, Any]:
    params = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep:
            raise ExactGraspError(
                f"--param {item!r}: expected KEY=VALUE, e.g. object_resolution=50."
            )
        params[key.replace("-", "_")] = _parse_value(value)
    return params


def _sampler(args: argparse.Namespace):
    from exactgrasp.paths.sampler import PathSampler

    overrides = {"n_steps": args.steps} if getattr(args, "steps", None) else {}
    return PathSampler.preset(args.sampler, **overrides)


def cmd_descriptor(args: argparse.Namespace) -> int:
    from exactgrasp.descriptor import compute_descriptor
    from exactgrasp.grasp import Grasp

    grasp = Grasp.from_file(args.grasp, on_limit=args.on_limit)
    descriptor = compute_descriptor(
        grasp,
        _sampler(args),
        backend=args.backend,
        progress=args.progress,
        **_backend_params(args.param),
    )
    out = descriptor.save(args.output)
    values = descriptor.values
    print(
        f"{grasp.name}: {values.shape[0]} paths x {values.shape[1]} steps with "
        f"{args.backend!r} in {descriptor.metadata['seconds']:.2f} s; "
        f"mean {values.mean():.5f}, max {values.max():.5f} -> {out}"
    )
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    inputs = [Path(p) for p in args.inputs]
    if all(p.suffix == ".npz" for p in inputs):
        from exactgrasp.descriptor import Descriptor, pairwise_distances

        descriptors = [Descriptor.load(p) for p in inputs]
        if len(descriptors) < 2:
            raise ExactGraspError("compare needs at least two .npz descriptors.")
        for kind in ("l2", "l2_diff"):
            matrix = pairwise_distances(descriptors, kind=kind)
            print(f"{kind} distances:")
            for i, path in enumerate(inputs):
                row = "  ".join(f"{matrix[i, j]:10.6f}" for j in range(len(inputs)))
                print(f"  {path.name:30s} {row}")
        return 0
    if len(inputs) == 1 and inputs[0].suffix == ".json":
        from exactgrasp.compare import compare_backends, write_table
        from exactgrasp.grasp import Grasp

        grasp = Grasp.from_file(inputs[0], on_limit=args.on_limit)
        backends = tuple(b.strip() for b in args.backends.split(",") if b.strip())
        result = compare_backends(grasp, _sampler(args), backends=backends, progress=args.progress)
        print(result.summary_text())
        if args.output:
            print(f"per-pose table -> {write_table(result.table, args.output)}")
        return 0
    raise ExactGraspError(
        "compare takes either two or more descriptor files (.npz) or one grasp file (.json) "
        "with --backends voxel,exact."
    )


def cmd_demo(args: argparse.Namespace) -> int:
    from exactgrasp.cli.demo import run_demo

    return run_demo(
        Path(args.out), sampler_name=args.sampler, quick=args.quick, progress=args.progress
    )


def _add_common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--sampler",
        default="balanced",
        choices=["balanced", "translations", "rotations"],
        help="path sampler preset (default: balanced)",
    )
    parser.add_argument("--steps", type=int, default=None, help="poses per path (default 9)")
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar (default: only on a terminal)",
    )
    parser.add_argument(
        "--on-limit",
        default="error",
        choices=["error", "clip"],
        help="joint values outside the limits: refuse or clip with a warning",
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``exactgrasp`` command."""
    from exactgrasp.version import __version__

    parser = argparse.ArgumentParser(
        prog="exactgrasp",
        description="Grasp descriptors from hand-object intersection along rigid paths.",
    )
    parser.add_argument("--version", action="version", version=f"exactgrasp {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("demo", help="built-in grasps on every available backend")
    demo.add_argument("--out", default="demo-output", help="folder for the plot and table")
    demo.add_argument("--quick", action="store_true", help="a small sampler, for a fast look")
    _add_common(demo)
    demo.set_defaults(func=cmd_demo)

    desc = sub.add_parser("descriptor", help="the descriptor of one grasp file")
    desc.add_argument("grasp", help="grasp JSON file")
    desc.add_argument("--backend", default="voxel", help="voxel (default) or exact")
    desc.add_argument("-o", "--output", required=True, help="output .npz file")
    desc.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="backend parameter, e.g. --param object_resolution=50",
    )
    _add_common(desc)
    desc.set_defaults(func=cmd_descriptor)

    comp = sub.add_parser(
        "compare",
        help="distances between descriptor files, or backends pose by pose on a grasp file",
    )
    comp.add_argument("inputs", nargs="+", help="a.npz b.npz ... or GRASP.json")
    comp.add_argument("--backends", default="voxel,exact", help="for a grasp file")
    comp.add_argument(
        "-o", "--output", default=None, help="write the per-pose table (.csv or .parquet)"
    )
    _add_common(comp)
    comp.set_defaults(func=cmd_compare)

    for module in ("exactgrasp.cli.validate", "exactgrasp.batch.run"):
        try:
            __import__(module)
        except ImportError:
            continue
        sys.modules[module].add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``exactgrasp`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ExactGraspError as exc:
        print(f"exactgrasp {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
