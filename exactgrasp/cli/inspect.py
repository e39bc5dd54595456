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
import warnings
from pathlib import Path
from typing import Any

from exactgrasp.cli.common import FlagTerms, add_command, flag, in_flag_terms
from exactgrasp.errors import ExactGraspError, Fix, ModelError
from exactgrasp.hands.angles import ANGLES
from exactgrasp.hands.builtins import BUILTIN_HANDS, BUILTIN_MJCF

__all__ = ["add_parser", "cmd_inspect", "inspect_lines", "package_dirs_from_args"]


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


#: `load_model`'s options and the flags that set them here.
PACKAGE_DIR_TERMS = FlagTerms({"package_dirs": _package_dir, "angle": _angle})


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


def inspect_lines(
    model: str,
    geometry: str = "collision",
    package_dirs: Any = None,
    root_body: str | None = None,
    angle: str | None = None,
) -> list[str]:
    """What ``exactgrasp inspect`` prints, as lines.

    Parameters
    ----------
    model : str
        A URDF or MJCF file, or the name of a built-in hand (see
        `exactgrasp.hands.builtins.BUILTIN_HANDS`; ``adroit`` and ``shadow_hand`` are read
        from their package's file, cut at their root body unless ``root_body`` is given).
    geometry : {"collision", "visual", "all"}
    package_dirs : dict or list, optional
        See `exactgrasp.hands.loading.load_model`.
    root_body : str, optional
        The hand's root body, for the summary of the loaded hand.
    angle : {"degree", "radian"}, optional
        The unit of an MJCF file's angles (see `exactgrasp.hands.loading.load_model`).

    Returns
    -------
    list of str
    """
    from exactgrasp.grasp.closing import closing_directions
    from exactgrasp.hands.builtins import get_builtin
    from exactgrasp.hands.dexterous import DEXTEROUS_HANDS, model_file
    from exactgrasp.hands.hand import Hand
    from exactgrasp.hands.loading import compile_source, load_model
    from exactgrasp.hands.palm import missing_palm_fix
    from exactgrasp.hands.scene import body_tree

    xml = BUILTIN_MJCF.get(model) if not Path(model).exists() else None
    path = f"{model}.xml" if xml is not None else model
    packaged = model in DEXTEROUS_HANDS and not Path(model).exists()
    if packaged:  # a built-in hand read from its package's file, cut at its root body
        path = str(model_file(model))
        root_body = root_body or DEXTEROUS_HANDS[model]["root_body"]
    mj_model = compile_source(
        path, geometry=geometry, package_dirs=package_dirs, xml=xml, angle=angle
    )
    n_moving = sum(int(t) in (2, 3) for t in mj_model.jnt_type)
    lines = [
        f"{path}: {mj_model.nbody - 1} bodies, {mj_model.njnt} joints ({n_moving} hinge/slide), "
        f"{mj_model.ngeom} geoms, {mj_model.nsite} sites",
        "body tree (joint ranges in rad or m; geom boxes in the body's frame):",
        *body_tree(mj_model, geometry),
    ]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if (xml is not None and root_body is None) or (
                packaged and root_body == DEXTEROUS_HANDS[model]["root_body"]
            ):  # with its palm frame and options
                hand = get_builtin(model)().model
            else:
                hand = load_model(
                    path,
                    root_body=root_body,
                    geometry=geometry,
                    package_dirs=package_dirs,
                    xml=xml,
                    angle=angle,
                )
    except ExactGraspError as exc:
        return [*lines, f"as a hand: not loadable with these options: {exc}"]
    root = f"root_body={root_body!r}" if root_body else "the whole model"
    lines.append(f"as a hand ({root}): {len(hand.link_names)} links")
    lines.append(f"  user-facing joints: {', '.join(hand.joint_names) or 'none'}")
    for issue in getattr(hand, "issues", ()):
        lines.append(f"  warning: {in_flag_terms(issue, PACKAGE_DIR_TERMS)}")
    for dep, (driver, ratio, offset) in hand.couplings.items():
        lines.append(f"  {dep} = {offset:g} + {ratio:g} * {driver}")
    if hand.palm is None:
        lines.append(
            f"  palm frame: none; {missing_palm_fix(hand.source if xml is None else None)}"
        )
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
    dirs = package_dirs_from_args(args.package_dir)
    try:
        lines = inspect_lines(args.model, args.geometry, dirs, args.root_body, args.angle)
    except ModelError as exc:
        raise in_flag_terms(exc, PACKAGE_DIR_TERMS) from exc
    for line in lines:
        print(line)
    return 0


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
    return parser
