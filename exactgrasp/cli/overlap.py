"""``exactgrasp overlap A B``: the exact intersection volume of two mesh files.

The command-line face of `exactgrasp.overlap.intersection_volume`: prints the volume of A ∩ B
(B moved by ``--pose``) and its certified error bound, in m^3 (see
``docs/penetration-volume.md``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from exactgrasp.backends.base import check_poses
from exactgrasp.cli.common import GRASP_FLAGS, FlagTerms, add_command, flag, in_flag_terms
from exactgrasp.errors import ExactGraspError
from exactgrasp.geometry.intake import UNITS

__all__ = ["add_parser", "cmd_overlap", "read_pose", "read_units"]

#: Keys of a JSON object that hold the pose(s), in the order they are looked for.
POSE_KEYS = ("poses", "pose", "object_pose_in_hand")
UNIT_NAMES = sorted(set(UNITS) - {"in"})
#: The intake's arguments and the flags that set them here.
TERMS = FlagTerms(
    {
        **GRASP_FLAGS,
        "check_scale": lambda fix: flag("--no-check-scale")(fix) if fix.value is False else None,
    }
)


#: The command's line in ``exactgrasp --help``.
HELP = "exact intersection volume of two closed meshes (m^3)"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Print the exact volume of A ∩ B in m^3, B moved by --pose, with its certified "
    "error bound. Both files must hold closed surfaces (--repair lets trimesh and "
    "pymeshfix close them)."
)
EXAMPLE = "exactgrasp overlap hand.stl object.stl --units mm --pose pose.json"


def read_pose(text: str) -> np.ndarray:
    """The ``--pose`` value: a ``.npy`` file, a JSON file, or JSON text.

    Parameters
    ----------
    text : str
        Path of a ``.npy`` array or a JSON file, or inline JSON: a 4x4 matrix, a list of them,
        or an object with one of the keys ``poses``, ``pose``, ``object_pose_in_hand`` (a
        grasp file's pose of the object in the hand).

    Returns
    -------
    numpy.ndarray, shape (4, 4) or (..., 4, 4), float64
        Checked to be rigid motions (translations in metres).
    """
    inline = text.lstrip().startswith(("[", "{"))
    path = Path(text)
    if not inline and not path.is_file():
        raise ExactGraspError(
            f"--pose {text}: no such file; pass a .npy or JSON file, or JSON text such as "
            "'[[1,0,0,0.01],[0,1,0,0],[0,0,1,0],[0,0,0,1]]'."
        )
    try:
        if inline:
            value: Any = json.loads(text)
        elif path.suffix == ".npy":
            value = np.load(path, allow_pickle=False)
        else:
            value = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ExactGraspError(
            f"--pose {text!r}: not a readable .npy file, JSON file or JSON text ({exc}); pass "
            "e.g. pose.npy, pose.json or '[[1,0,0,0.01],[0,1,0,0],[0,0,1,0],[0,0,0,1]]'."
        ) from exc
    if isinstance(value, dict):
        key = next((k for k in POSE_KEYS if k in value), None)
        if key is None:
            raise ExactGraspError(
                f"--pose {text}: a JSON object needs one of the keys {list(POSE_KEYS)}."
            )
        value = value[key]
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ExactGraspError(f"--pose {text}: not an array of numbers ({exc}).") from exc
    return check_poses(arr, name="--pose")


def read_units(text: str) -> tuple[str, str]:
    """``--units U`` (both meshes) or ``--units UA,UB`` as (units of A, units of B)."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) == 1:
        parts = parts * 2
    if len(parts) != 2 or not all(p in UNITS for p in parts):
        raise ExactGraspError(
            f"--units {text!r}: use one of {UNIT_NAMES} for both meshes, or two separated by a "
            "comma (units of A, units of B), e.g. --units m,mm."
        )
    return parts[0], parts[1]


def cmd_overlap(args: argparse.Namespace) -> int:
    """Print the volume of A ∩ moved B and its bound (exit status 0).

    Raises
    ------
    ExactGraspError
        Naming the flag (``--pose``, ``--units``, ...) or the file (``A``, ``B``) at fault.
    """
    from exactgrasp.overlap import as_solid, intersection

    units_a, units_b = read_units(args.units)
    poses = None if args.pose is None else read_pose(args.pose)
    options = {"repair": args.repair, "check_scale": args.check_scale}
    try:
        a = as_solid(args.a, "A", units=units_a, **options)
        b = as_solid(args.b, "B", units=units_b, **options)
        result = intersection(a, b, poses)
        volumes, bounds = result.volumes, result.bounds
    except ExactGraspError as exc:
        raise in_flag_terms(exc, TERMS) from exc
    if np.ndim(volumes) == 0:
        print(f"volume {volumes:.12g} m^3 (bound {bounds:.2g} m^3)")
        return 0
    for index in np.ndindex(np.shape(volumes)):
        label = ", ".join(map(str, index))
        print(f"pose[{label}] volume {volumes[index]:.12g} m^3 (bound {bounds[index]:.2g} m^3)")
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``overlap`` subcommand to the ``exactgrasp`` parser."""
    parser = add_command(subparsers, "overlap", cmd_overlap, HELP, DESCRIPTION, EXAMPLE)
    parser.add_argument("a", metavar="A", help="mesh file that stays (STL, OBJ, PLY, OFF, GLB)")
    parser.add_argument("b", metavar="B", help="mesh file that moves")
    parser.add_argument(
        "--pose",
        default=None,
        metavar="POSE",
        help=(
            "rigid pose(s) of B in A's frame, translations in metres: a .npy file of shape "
            "(4, 4) or (n, 4, 4), a JSON file or JSON text (a matrix, a list, or an object "
            "with 'poses', 'pose' or 'object_pose_in_hand'); default: B as it is"
        ),
    )
    parser.add_argument(
        "--units",
        default="m",
        metavar="U[,U]",
        help=f"units of the files, one of {UNIT_NAMES}, or one per file as A,B (default m)",
    )
    parser.add_argument("--repair", action="store_true", help="close and orient the meshes")
    parser.add_argument(
        "--check-scale",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="refuse meshes longer than 5 m after the unit conversion (default: on)",
    )
    return parser
