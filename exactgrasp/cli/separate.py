"""``exactgrasp separate GRASP.json -o separated.json``: penetration removed by the smallest
rigid motion of the object.

The command-line face of `exactgrasp.separation.separate`: writes the separated grasp file
and prints what moved (the object's centroid in mm, its rotation in degrees, each joint that
changed) and whether the result is in contact.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from exactgrasp.cli.common import add_command, add_grasp_file, add_grasp_options, grasp_from_args

__all__ = ["add_parser", "cmd_separate"]


#: The command's line in ``exactgrasp --help``.
HELP = "move a penetrating object out of the hand by the smallest rigid motion"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Move GRASP's object out of the hand by gradient steps on the exact intersection "
    "volume until it reads 0, leaving the object within --tolerance-mm of the hand (in "
    "contact). Where a finger is buried in the object (--fingers auto, the default) or with "
    "--fingers reclose, the fingers open first and close onto the object again. Refuses "
    "(exit status 2) when the object is enclosed by the hand."
)
EXAMPLE = "exactgrasp separate grasp.json -o separated.json --fingers keep"
#: ``--fingers``: `exactgrasp.separation.FINGERS`, written out so that ``--help`` loads no
#: geometry (a test checks that the two agree).
FINGERS = ("auto", "keep", "reclose")


def cmd_separate(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp separate``; prints what it did, returns 0."""
    from exactgrasp.separation import PUSH_MM, separate

    grasp = grasp_from_args(args)
    result = separate(
        grasp,
        fingers=args.fingers,
        rotation=args.rotation,
        tolerance_mm=args.tolerance_mm,
        max_steps=args.max_steps,
    )
    out = result.grasp.save(args.output)
    summary = {
        "grasp": grasp.name,
        "volume_before_m3": result.volume_before,
        "translation_mm": result.translation_mm,
        "rotation_deg": result.rotation_deg,
        "joint_changes_rad": result.joint_changes,
        "in_contact": result.in_contact,
        "steps": result.steps,
        "fingers": result.fingers,
        "buried_links": result.buried_links,
        "output": str(out),
    }
    if args.json:
        print(json.dumps(summary, indent=1))
        return 0
    print(
        f"{grasp.name}: {result.volume_before:.4g} m^3 inside; the object moved "
        f"{result.translation_mm:.3f} mm (centroid) and turned {result.rotation_deg:.3f} deg "
        f"in {result.steps} gradient steps"
    )
    if result.fingers == "reclose":
        why = f" (buried: {', '.join(result.buried_links)})" if result.buried_links else ""
        print(f"fingers opened and closed again{why}")
    for name, change in result.joint_changes.items():
        print(f"  {name}: {change:+.4f} rad")
    contact = "in contact" if result.in_contact else "apart"
    print(f"{contact} (volume 0; a {PUSH_MM:g} mm push back penetrates: {result.in_contact})")
    print(f"-> {out}")
    return 0


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``separate`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "separate", cmd_separate, HELP, DESCRIPTION, EXAMPLE)
    add_grasp_file(parser, "separated grasp JSON file to write")
    parser.add_argument(
        "--fingers",
        choices=FINGERS,
        default="auto",
        help="reclose: open the closing joints first and close them onto the moved object "
        "after; keep: leave the joints; auto (default): reclose where a finger link has more "
        "than a thousandth of its volume inside the object, else keep",
    )
    parser.add_argument(
        "--rotation",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="let the object rotate as well as translate (default: yes)",
    )
    parser.add_argument(
        "--tolerance-mm",
        type=float,
        default=0.01,
        metavar="MM",
        help="largest gap left along the separating direction, mm (default 0.01)",
    )
    parser.add_argument(
        "--max-steps", type=int, default=60, help="gradient steps before giving up (default 60)"
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_grasp_options(parser)
    return parser
