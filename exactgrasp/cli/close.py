"""``exactgrasp close GRASP.json -o closed.json``: the fingers closed onto the object.

The command-line face of `exactgrasp.grasp.closing.close_fingers` (as `close_grasp` applies
it to a grasp): writes the closed grasp file and prints, finger by finger, each closing
joint's value and whether the finger touches the object.
"""

from __future__ import annotations

import argparse
import inspect
import warnings
from typing import Any

from exactgrasp.cli.common import (
    FlagTerms,
    add_command,
    add_grasp_file,
    add_grasp_options,
    flag,
    grasp_from_args,
    in_flag_terms,
    options_named,
)
from exactgrasp.errors import ClosingError, JointError
from exactgrasp.geometry.bvh import ENGINES
from exactgrasp.grasp.closing import ClosingResult, close_fingers_result

__all__ = ["add_parser", "cmd_close", "summary_lines"]

#: Defaults of `close_fingers`' options, shown and used by the flags.
DEFAULTS = {k: p.default for k, p in inspect.signature(close_fingers_result).parameters.items()}
#: `close_fingers`' arguments and the flags that set them here.
CLOSING_TERMS = FlagTerms(
    {
        "joints": lambda fix: flag("--joints J1,J2,..." if fix.shown else "--joints")(fix),
        "backoff": lambda fix: "leave out --no-backoff" if fix.value is True else None,
        "tolerance": flag("--tolerance"),
        "step": flag("--step"),
    }
)


#: The command's line in ``exactgrasp --help``.
HELP = "close the fingers of a grasp onto its object; write the closed grasp file"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Open the closing joints of GRASP's hand, move the object out along the "
    "palm normal if the open hand still penetrates it, then close each finger until it "
    "touches the object (within --tolerance) or reaches its joint limits. Writes the "
    "closed grasp to --output and prints each closing joint's value and contact."
)
EXAMPLE = "exactgrasp close box.json -o box-closed.json"


def parse_joints(text: str | None) -> list[str] | None:
    """``--joints J1,J2,...`` as a list of names (None: the model's closing joints)."""
    if text is None:
        return None
    return [name.strip() for name in text.split(",") if name.strip()]


#: ``--direction`` signs and the sense each stands for (+1: towards the upper limit).
SIGNS = {"+": 1, "+1": 1, "1": 1, "upper": 1, "-": -1, "-1": -1, "lower": -1}


def parse_directions(items: list[str] | None) -> dict[str, int] | None:
    """``--direction JOINT=SIGN`` items as `close_fingers`' ``direction`` (None: none given).

    Raises
    ------
    ClosingError
        An item without ``=`` or with a sign other than ``+``/``-`` (``+1``, ``upper``, ...).
    """
    if not items:
        return None
    out = {}
    for item in items:
        joint, sep, sign = item.partition("=")
        if not sep or not joint.strip() or sign.strip() not in SIGNS:
            raise ClosingError(
                f"--direction {item!r}: expected JOINT=+ (closes towards the upper limit) or "
                "JOINT=- (towards the lower), e.g. --direction finger_joint=-"
            )
        out[joint.strip()] = SIGNS[sign.strip()]
    return out


def summary_lines(result: ClosingResult) -> list[str]:
    """Per finger and closing joint: the joint, its value, the limit it closed towards, and
    what the finger touches."""
    limits = result.hand.joint_limits
    width = max((len(j) for f in result.fingers for j in f.joints), default=5)
    lines = [f"{'finger':<7} {'joint':<{width}} {'value':>8}  {'closes to':<14}  contact"]
    for number, finger in enumerate(result.fingers, start=1):
        if finger.contact_links:
            contact = f"{', '.join(finger.contact_links)} (gap {finger.gap * 1e3:.3f} mm)"
        else:
            stopped = f"; at limit: {', '.join(finger.at_limit)}" if finger.at_limit else ""
            contact = f"none (gap {finger.gap * 1e3:.1f} mm{stopped})"
        senses = getattr(finger, "directions", ()) or (1,) * len(finger.joints)
        for k, (joint, sense) in enumerate(zip(finger.joints, senses, strict=True)):
            value = result.hand.joints[joint]
            limit = limits[joint][1] if sense > 0 else limits[joint][0]
            label = str(number) if k == 0 else ""
            tail = contact if k == 0 else ""
            towards = f"{'upper' if sense > 0 else 'lower'} {limit:.4f}"
            row = f"{label:<7} {joint:<{width}} {value:8.4f}  {towards:<14}"
            lines.append(f"{row}  {tail}".rstrip())
    return lines


def cmd_close(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp close``; prints the per-finger summary, returns 0."""
    joints, direction = parse_joints(args.joints), parse_directions(args.direction)
    grasp = grasp_from_args(args)
    try:
        with warnings.catch_warnings():
            # The summary below says how far the object moved, in the command's own words.
            warnings.filterwarnings("ignore", "close_fingers: the open hand penetrates")
            result = close_fingers_result(
                grasp.hand,
                grasp.object,
                grasp.object_pose,
                joints=joints,
                direction=direction,
                **options_named(args, "tolerance", "step", "backoff", "engine"),
            )
    except (ClosingError, JointError) as exc:
        raise in_flag_terms(exc, CLOSING_TERMS, f"grasp {grasp.name!r}: ") from exc
    from exactgrasp.grasp import Grasp

    closed = Grasp(result.hand, grasp.object, result.object_pose, name=grasp.name)
    out = closed.save(args.output)
    touching = sum(bool(f.contact_links) for f in result.fingers)
    moved = (
        f"; the object moved {result.backoff_distance * 1e3:.3f} mm out along the palm normal"
        if result.backoff_distance > 0
        else ""
    )
    print(
        f"{grasp.name}: {touching} of {len(result.fingers)} fingers touch the object "
        f"({args.engine}{moved}); joint values in rad (m for slide joints)"
    )
    print("\n".join(summary_lines(result)))
    print(f"-> {out}")
    return 0


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``close`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "close", cmd_close, HELP, DESCRIPTION, EXAMPLE)
    add_grasp_file(
        parser, "closed grasp JSON file to write", grasp="grasp JSON file (an articulated hand)"
    )
    parser.add_argument(
        "--joints",
        default=None,
        metavar="J1,J2,...",
        help="closing joints, comma-separated (default: the model's closing joints, else every "
        "limited flexion joint)",
    )
    parser.add_argument(
        "--direction",
        action="append",
        default=None,
        metavar="JOINT=SIGN",
        help="close JOINT towards its upper (+) or lower (-) limit (repeatable; default: the "
        "model's closing directions, else towards the hand's centre)",
    )
    parser.add_argument(
        "--engine",
        default=DEFAULTS["engine"],
        choices=tuple(ENGINES),
        help=f"distance library (default {DEFAULTS['engine']})",
    )
    for name, metavar, meaning in (
        ("tolerance", "M", "largest gap left between a touching link and the object, m (default"),
        ("step", "RAD", "largest joint change per advancement step, rad (m for slides; default"),
    ):
        parser.add_argument(
            f"--{name}",
            type=float,
            default=DEFAULTS[name],
            metavar=metavar,
            help=f"{meaning} {DEFAULTS[name]:g})",
        )
    parser.add_argument(
        "--backoff",
        action=argparse.BooleanOptionalAction,
        default=DEFAULTS["backoff"],
        help="move a penetrating object out along the palm normal first, or refuse (default: "
        f"{'move' if DEFAULTS['backoff'] else 'refuse'})",
    )
    add_grasp_options(parser)
    return parser
