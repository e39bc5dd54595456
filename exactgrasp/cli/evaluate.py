"""``exactgrasp evaluate``: descriptor distances and baselines against a CSV of labelled pairs.

The command-line face of `exactgrasp.evaluation.evaluate`; writes ``evaluation.md``,
``evaluation.json`` and ``roc.png`` (`exactgrasp.evaluation.write`).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from exactgrasp.cli.common import (
    add_backend,
    add_command,
    add_grasp_inputs,
    options_named,
    read_grasp,
    sampler_from_args,
)
from exactgrasp.cli.params import add_param, build_backend, split_params
from exactgrasp.evaluation.names import (
    BASELINES,
    BOOTSTRAP_UNITS,
    DEFAULT_DISTANCES,
    DISTANCES,
    SYMMETRY_NAMES,
)

if TYPE_CHECKING:
    from exactgrasp.grasp import Grasp

__all__ = ["add_parser", "cmd_evaluate"]


#: The command's line in ``exactgrasp --help``.
HELP = "AUC of descriptor distances on labelled pairs of grasps"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Read PAIRS (a CSV with columns a,b,label and optionally group; a and b are grasp "
    "files relative to the CSV, or ids of --manifest; label is same/different or a "
    "grade), compute the grasps' descriptors and write the AUC of each distance and "
    "baseline with a bootstrap interval, the ROC curves and a per-group breakdown."
)
EXAMPLE = "exactgrasp evaluate pairs.csv -o evaluation --backend voxel"


def _grasps(args: argparse.Namespace, sources: list) -> list[Grasp]:
    from exactgrasp.grasp import Grasp

    base = Path(args.manifest).resolve().parent if args.manifest else Path(args.pairs).parent
    grasps = []
    for source in sources:
        if isinstance(source, dict):
            grasp = Grasp.from_dict(source, base_dir=base, source=str(args.manifest))
        else:
            grasp = read_grasp(source, args.units, args.repair, args.on_limit)
        grasps.append(grasp)
    return grasps


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp evaluate``; prints the AUC table, returns 0."""
    from exactgrasp.evaluation.evaluate import evaluate
    from exactgrasp.evaluation.pairs import read_pairs
    from exactgrasp.evaluation.write import write_evaluation

    pairs, sources = read_pairs(args.pairs, args.manifest)
    sampler = sampler_from_args(args)
    params = split_params(args.param, [args.backend])[args.backend]
    # The name alone means the defaults (and the settings record no parameters).
    backend = build_backend(args.backend, params) if params else args.backend
    grasps = _grasps(args, sources)
    baselines = None if args.baseline is None else [b for b in args.baseline if b != "none"]
    result = evaluate(
        grasps,
        pairs,
        distances=args.distance or DEFAULT_DISTANCES,
        baselines=baselines,
        backend=backend,
        sampler=sampler,
        symmetries=args.symmetry,
        cache_dir=args.cache,
        unit=args.bootstrap,
        **options_named(args, "n_boot", "seed"),
    )
    command = "exactgrasp " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    files = write_evaluation(result, args.output, command=command)
    width = max(len(n) for n in result.evaluations)
    for name, ev in result.evaluations.items():
        print(f"{name:{width}s}  AUC {ev.auc:.3f}  ({ev.low:.3f} .. {ev.high:.3f})")
    print(f"-> {files['markdown']}")
    return 0


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``evaluate`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "evaluate", cmd_evaluate, HELP, DESCRIPTION, EXAMPLE)
    parser.add_argument("pairs", metavar="PAIRS", help="CSV of labelled pairs")
    parser.add_argument("-o", "--output", required=True, help="output folder")
    parser.add_argument("--manifest", help="batch manifest (.jsonl) whose ids PAIRS names")
    parser.add_argument(
        "--distance",
        action="append",
        metavar="NAME",
        help=f"descriptor distance, repeatable: {', '.join(DISTANCES)} (escape:T sets the "
        f"threshold T, a fraction of the hand volume); default: {', '.join(DEFAULT_DISTANCES)}",
    )
    parser.add_argument(
        "--baseline",
        action="append",
        choices=(*BASELINES, "none"),
        help="baseline, repeatable (default: every one that applies; 'none' for none)",
    )
    parser.add_argument(
        "--symmetry",
        help="hand symmetries to minimise over, comma-separated: "
        f"{', '.join(SYMMETRY_NAMES)} (the Barrett: mirror-x)",
    )
    parser.add_argument("--cache", help="folder of cached descriptors (default: none)")
    parser.add_argument("--n-boot", type=int, default=2000, help="bootstrap replicates")
    parser.add_argument("--seed", type=int, default=0, help="bootstrap seed (default 0)")
    parser.add_argument(
        "--bootstrap",
        choices=BOOTSTRAP_UNITS,
        default="grasp",
        help="what the bootstrap resamples (default: grasp)",
    )
    add_backend(parser)
    add_param(parser)
    add_grasp_inputs(parser)
    return parser
