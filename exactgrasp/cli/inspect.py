"""``exactgrasp inspect MODEL``: the body tree of a URDF/MJCF model (or a built-in hand).

Prints every body with its joints (type, axis, limits), its geoms (how many, which kinds, the
size of the box around them) and its sites, then the joint couplings, the top-level bodies
that could be the hand, and what `exactgrasp.hands.loading.load_model` makes of the model
(joints, palm frame, the joints `exactgrasp.grasp.closing.close_fingers` closes and their
directions): enough to choose ``root_body``, the palm frame and the closing joints without
reading XML.
"""

from __future__ import annotations

import argparse
import json
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from exactgrasp.cli.common import GRASP_FLAGS, FlagTerms, add_command, flag, in_flag_terms
from exactgrasp.errors import ExactGraspError, Fix, ModelError
from exactgrasp.hands.angles import ANGLES
from exactgrasp.hands.builtins import BUILTIN_HANDS, BUILTIN_MJCF

__all__ = ["add_parser", "cmd_inspect", "inspect_lines", "json_option", "package_dirs_from_args"]


#: The command's line in ``exactgrasp --help``.
HELP = "the body tree of a URDF/MJCF hand model: joints, limits, geoms, sites"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Print the bodies of a URDF or MJCF model (or of a built-in hand: "
    f"{', '.join(sorted(BUILTIN_HANDS))}) with their joints (type, axis, limits), "
    "geoms (count, kinds, size) and sites, the top-level bodies that could be the "
    "hand, and the hand load_model makes of it: to choose root_body, the palm frame "
    "and the closing joints."
)
EXAMPLE = "exactgrasp inspect my_hand.urdf --package-dir my_hand_description=./meshes"


def _package_dir(fix: Fix) -> str:
    """``package_dirs`` as ``--package-dir`` items: ``NAME=DIR`` for a dict, ``DIR`` for a
    list; an entry named in a message ends with a colon."""
    value = fix.value
    if isinstance(value, dict):
        text = " ".join(f"--package-dir {name}={folder}" for name, folder in value.items())
    elif isinstance(value, list):
        text = " ".join(f"--package-dir {folder}" for folder in value)
    else:
        return "--package-dir"
    return f"{text}:" if fix.form == "entry" else flag(text)(fix)


def _angle(fix: Fix) -> str:
    """``angle`` as ``--angle UNIT`` (the bare flag when the fix names no unit)."""
    return flag("--angle" if fix.value is ... else f"--angle {fix.value}")(fix)


def _json_flag(name: str) -> Callable[[Fix], str]:
    """A JSON-valued option as its flag, with the value when the fix shows one."""

    def spell(fix: Fix) -> str:
        return flag(name if fix.shown is None else f"{name} '{fix.shown}'")(fix)

    return spell


#: `load_model`'s options and the flags that set them here.
MODEL_TERMS = FlagTerms(
    {
        "package_dirs": _package_dir,
        "angle": _angle,
        "repair": GRASP_FLAGS["repair"],
        "palm": _json_flag("--palm"),
        "couplings": _json_flag("--couplings"),
    }
)


def package_dirs_from_args(values: list[str] | None) -> Any:
    """``--package-dir`` values as `load_model`'s ``package_dirs``: ``NAME=DIR`` entries make
    a dict, plain ``DIR`` entries a list (mixing both is refused)."""
    if not values:
        return None
    named = [v.partition("=") for v in values if "=" in v]
    plain = [v for v in values if "=" not in v]
    if named and plain:
        raise ModelError("--package-dir: give either NAME=DIR entries or DIR entries, not both")
    return {name: folder for name, _, folder in named} if named else plain


def inspect_lines(model: str, **options: Any) -> list[str]:
    """What ``exactgrasp inspect`` prints, as lines (fixes spelled as its flags).

    Parameters
    ----------
    model : str
        A URDF or MJCF file, or the name of a built-in hand (see
        `exactgrasp.hands.builtins.BUILTIN_HANDS`; ``adroit`` and ``shadow_hand`` are read
        from their package's file, cut at their root body unless ``root_body`` is given).
    **options
        `exactgrasp.hands.loading.load_model`'s ``root_body``, ``geometry``,
        ``package_dirs``, ``angle``, ``palm``, ``repair`` and ``couplings``; a built-in hand
        without them is loaded as its own function loads it.

    Returns
    -------
    list of str
    """
    from exactgrasp.hands.builtins import get_builtin
    from exactgrasp.hands.dexterous import DEXTEROUS_HANDS, model_file
    from exactgrasp.hands.loading import compile_source, load_model
    from exactgrasp.hands.scene import body_tree

    options = {key: value for key, value in options.items() if value is not None}
    geometry = options.setdefault("geometry", "collision")
    xml = BUILTIN_MJCF.get(model) if not Path(model).exists() else None
    path = f"{model}.xml" if xml is not None else model
    builtin = xml is not None and options.keys() <= {"geometry"}
    if model in DEXTEROUS_HANDS and not Path(model).exists():  # read from its package's file
        path = str(model_file(model))
        root = DEXTEROUS_HANDS[model]["root_body"]
        builtin = options.setdefault("root_body", root) == root and options.keys() <= {
            "geometry",
            "root_body",
        }
    compiled = {k: options[k] for k in ("geometry", "package_dirs", "angle") if k in options}
    mj_model = compile_source(path, xml=xml, **compiled)
    n_moving = sum(int(t) in (2, 3) for t in mj_model.jnt_type)
    lines = [
        f"{path}: {mj_model.nbody - 1} bodies, {mj_model.njnt} joints ({n_moving} hinge/slide), "
        f"{mj_model.ngeom} geoms, {mj_model.nsite} sites",
        "body tree (joint ranges in rad or m; geom boxes in the body's frame):",
        *body_tree(mj_model, geometry),
    ]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # what matters is printed below
            if builtin:  # with its palm frame and options
                hand = get_builtin(model)().model
            else:
                hand = load_model(path, xml=xml, **options)
    except ExactGraspError as exc:
        return [*lines, *_report(exc, path if xml is None else None, options)]
    root = f"root_body={options['root_body']!r}" if options.get("root_body") else "the whole model"
    lines.append(f"as a hand ({root}): {len(hand.link_names)} links")
    return [*lines, *_hand_lines(hand, xml is None)]


def _report(exc: ExactGraspError, source: str | None, options: dict) -> list[str]:
    """A model that does not load: every problem on its line, with the missing palm frame
    among them (as `Hand.from_mjcf` reports it), each fix spelled as a flag."""
    from exactgrasp.hands.palm import missing_palm, palm_missing

    problems = list(exc.problems) if isinstance(exc, ModelError) else [exc]
    if source is not None and palm_missing(Path(source), options.get("palm")):
        problems.append(missing_palm(Path(source).stem, source))
    return [
        f"as a hand: not loadable with these options ({len(problems)} problem(s), "
        "each with its fix):",
        *(f"  - {in_flag_terms(problem, MODEL_TERMS)}" for problem in problems),
    ]


def _hand_lines(hand: Any, from_file: bool) -> list[str]:
    """The loaded hand: joints, warnings, couplings, palm frame and closing joints."""
    from exactgrasp.grasp.closing import closing_directions
    from exactgrasp.hands.hand import Hand
    from exactgrasp.hands.palm import missing_palm_fix

    lines = [f"  user-facing joints: {', '.join(hand.joint_names) or 'none'}"]
    for caution in getattr(hand, "cautions", ()):
        lines.append(f"  warning: {in_flag_terms(caution, MODEL_TERMS)}")
    for dep, (driver, ratio, offset) in hand.couplings.items():
        lines.append(f"  {dep} = {offset:g} + {ratio:g} * {driver}")
    if hand.palm is None:
        fix = ExactGraspError(*missing_palm_fix(hand.source if from_file else None))
        lines.append(f"  palm frame: none; {in_flag_terms(fix, MODEL_TERMS)}")
        return [*lines, "  closing joints: found from the palm frame, once it is written"]
    p = hand.palm
    lines.append(
        f"  palm frame: origin {_xyz(p.origin)}, normal {_xyz(p.normal)}, up {_xyz(p.up)}, "
        f"depth {p.depth:g} m"
    )
    try:
        senses = closing_directions(Hand(hand))
    except ExactGraspError as exc:
        return [*lines, f"  closing joints: none found by the axis rule ({exc})"]
    lines.append(
        "  closing joints (close_fingers' default; + towards the upper limit): "
        + ", ".join(f"{n} {'+' if d > 0 else '-'}" for n, d in senses.items())
    )
    return lines


def _xyz(values) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in values) + ")"


def cmd_inspect(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp inspect``; prints the tree, returns 0."""
    try:
        options = {
            "geometry": args.geometry,
            "root_body": args.root_body,
            "package_dirs": package_dirs_from_args(args.package_dir),
            "angle": args.angle,
            "palm": json_option(args.palm, "--palm"),
            "repair": args.repair or None,
            "couplings": json_option(args.couplings, "--couplings"),
        }
        lines = inspect_lines(args.model, **options)
    except ModelError as exc:
        raise in_flag_terms(exc, MODEL_TERMS) from exc
    for line in lines:
        print(line)
    return 0


def json_option(text: str | None, name: str) -> Any:
    """A flag's value given as JSON text or as a JSON file (None when not given); `ModelError`
    naming the flag when it is neither."""
    if text is None:
        return None
    if not text.lstrip().startswith(("{", "[")) and text not in ("false", "null"):
        if not Path(text).is_file():
            raise ModelError(f"{name} {text!r}: neither JSON text nor a JSON file")
        text = Path(text).read_text()
    try:
        return json.loads(text)
    except ValueError as exc:
        raise ModelError(f"{name}: not valid JSON ({exc})") from None


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``inspect`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "inspect", cmd_inspect, HELP, DESCRIPTION, EXAMPLE)
    parser.add_argument("model", metavar="MODEL", help="URDF/MJCF file or built-in hand name")
    parser.add_argument(
        "--geometry",
        choices=("collision", "visual", "all"),
        default="collision",
        help="which geoms count as the hand's (default collision)",
    )
    parser.add_argument(
        "--root-body", default=None, help="the hand's root body, for the hand summary"
    )
    parser.add_argument(
        "--package-dir",
        action="append",
        metavar="[NAME=]DIR",
        help="where package:// and model:// mesh names are found (repeatable)",
    )
    parser.add_argument(
        "--angle",
        choices=ANGLES,
        default=None,
        help="the unit of an MJCF file's angles, replacing its <compiler angle> (default: "
        "as the file says, else degree)",
    )
    parser.add_argument(
        "--palm",
        default=None,
        metavar="PALM",
        help='the palm frame as JSON text or a JSON file: {"origin": [x, y, z], "normal": '
        '"+z", "up": "+y", "depth": d}, optionally with "body" or "site" (default: '
        "palm_frame.json beside the model file)",
    )
    parser.add_argument(
        "--repair",
        action="store_true",
        help="repair the model's mesh geoms that are not closed solids",
    )
    parser.add_argument(
        "--couplings",
        default=None,
        metavar="COUPLINGS",
        help='joints driven by others, as JSON text or a JSON file: {"dependent": ["driver", '
        "ratio, offset]} (added to the model's own)",
    )
    return parser
