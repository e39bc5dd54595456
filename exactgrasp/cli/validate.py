"""``exactgrasp validate``: the validation report (see ``docs/validation.md``)."""

from __future__ import annotations

import argparse
import shlex
import sys


def _overrides(args: argparse.Namespace) -> dict:
    """Config fields set on the command line."""
    out: dict = {}
    if args.n_cereal is not None:
        out["n_cereal"] = None if args.n_cereal < 0 else args.n_cereal
    for name in ("contact_per_object", "noise_copies", "joint_draws", "exact_joint_draws"):
        value = getattr(args, name)
        if value is not None:
            out[name] = value
    if args.exact_noise_samplers is not None:
        out["exact_noise_samplers"] = tuple(p for p in args.exact_noise_samplers.split(",") if p)
    return out


def cmd_validate(args: argparse.Namespace) -> int:
    """Run the report; a missing data folder is an error with exit status 2."""
    from exactgrasp.report import ValidationConfig, run_validation
    from exactgrasp.report.data import DataError, barrett_dir

    try:
        barrett_dir(args.data)
    except DataError as exc:
        print(f"exactgrasp validate: error: {exc}", file=sys.stderr)
        return 2
    size = "quick" if args.quick else args.size
    config = ValidationConfig.named(size, **_overrides(args))
    argv = [a for a in sys.argv[1:]]
    command = "exactgrasp " + shlex.join(argv) if "validate" in argv else "exactgrasp validate"
    log = (lambda line: None) if args.quiet else (lambda line: print(line, flush=True))
    run_validation(args.data, args.out, config, cache_dir=args.cache, command=command, log=log)
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``validate`` subcommand to the ``exactgrasp`` parser."""
    parser = subparsers.add_parser(
        "validate",
        help="report: voxel estimator against exact volumes, and the paper's noise tests",
        description=(
            "Write an HTML report (index.html, summary.md, summary.json, figures/) comparing "
            "the paper's voxel estimator with exact volumes on the real Barrett grasps, and "
            "redoing the paper's noise tests with both backends. Descriptors are cached, so "
            "an interrupted run picks up where it stopped."
        ),
    )
    parser.add_argument(
        "--data", required=True, help="shared data folder (holds barrett-grasps/, osu-objects/)"
    )
    parser.add_argument("--out", required=True, help="folder for the report")
    parser.add_argument(
        "--size",
        default="paper",
        choices=["paper", "standard", "quick"],
        help="paper (default, the committed report: the paper's sizes everywhere with both "
        "backends, about 36 min on 2 cores), standard (fewer grasps and exact draws, about "
        "13 min), quick (under a minute)",
    )
    parser.add_argument("--quick", action="store_true", help="the same as --size quick")
    parser.add_argument(
        "--cache", default=None, help="descriptor cache folder (default: OUT/cache)"
    )
    parser.add_argument(
        "--n-cereal", type=int, default=None, help="cereal-box grasps to use (-1: all 34)"
    )
    parser.add_argument(
        "--contact-per-object", type=int, default=None, help="closed study records per object"
    )
    parser.add_argument(
        "--noise-copies", type=int, default=None, help="object-pose noise copies per grasp"
    )
    parser.add_argument(
        "--joint-draws", type=int, default=None, help="joint-noise draws per level"
    )
    parser.add_argument(
        "--exact-joint-draws",
        type=int,
        default=None,
        help="joint-noise draws per level with the exact backend",
    )
    parser.add_argument(
        "--exact-noise-samplers",
        default=None,
        help="comma-separated samplers of the object-pose noise test also run with the exact "
        "backend (reduced, balanced, translations, rotations)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    parser.set_defaults(func=cmd_validate)
    return parser
