"""The angle unit of MJCF files: ``angle=`` of `exactgrasp.hands.loading.load_model`, and
the hinge ranges MuJoCo reads in degrees only because the file does not say.

MuJoCo reads an MJCF file's angles (joint ranges and references, ``euler`` and ``axisangle``
orientations) in degrees unless its ``<compiler angle="radian"/>`` says otherwise. Gripper files
written to be included in a robot model often leave the compiler to the including file, which
says radian; loaded on their own, a 0.8 rad finger becomes a 0.8 degree one. `angle_problem`
tells when that is likely: the file sets no angle unit and every hinge range would fit within
a turn either way (within +-2 pi as radians).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

from exactgrasp.errors import Fix, ModelError

__all__ = ["ANGLES", "angle_problem", "check_angle", "written_angle"]

#: Values of ``angle=``: the unit MuJoCo reads the file's angles in (None: as the file says).
ANGLES = ("degree", "radian")


def check_angle(angle: object) -> str | None:
    """``angle`` if it is "degree", "radian" or None; otherwise `ModelError` naming it."""
    if angle is None or (isinstance(angle, str) and angle in ANGLES):
        return angle
    raise ModelError(
        Fix("angle"),
        " must be 'degree', 'radian' or None (the unit the MJCF file's <compiler angle> "
        f"says, else MuJoCo's default, degree), got {angle!r}",
    )


def written_angle(path: Path, xml: str | None = None) -> str | None:
    """The angle unit an MJCF file (or text) writes in a ``<compiler angle=...>``, following
    its ``<include file=...>`` (relative to the model file's folder); None when none does.

    Parameters
    ----------
    path : pathlib.Path
        The model file (for ``xml=``: its folder resolves includes).
    xml : str, optional
        The model text, instead of reading ``path``.

    Returns
    -------
    str or None
        The last ``angle`` attribute written, as MuJoCo applies them in order.
    """
    seen: set[Path] = set()

    def scan(root: ET.Element) -> str | None:
        unit = None
        for element in root.iter():
            if element.tag == "compiler" and element.get("angle") is not None:
                unit = element.get("angle")
            elif element.tag == "include" and element.get("file"):
                included = (path.parent / element.get("file")).resolve()
                if included in seen or not included.is_file():
                    continue
                seen.add(included)
                try:
                    unit = scan(ET.parse(included).getroot()) or unit
                except ET.ParseError:
                    continue  # MuJoCo reports an unreadable include itself
        return unit

    try:
        root = ET.fromstring(xml) if xml is not None else ET.parse(path).getroot()
    except ET.ParseError:
        return None  # MuJoCo reports an unreadable file itself
    return scan(root)


def angle_problem(source: str, spec, written: str | None) -> ModelError | None:
    """The hinge ranges MuJoCo reads in degrees because the file sets no angle unit, when
    each of them would fit within +-2 pi read as radians.

    Parameters
    ----------
    source : str
        The model file, for the message.
    spec : mujoco.MjSpec
        The parsed model (ranges as written in the file).
    written : str or None
        `written_angle` of the file.

    Returns
    -------
    ModelError or None
        Not raised: naming the file, the joints and ``angle=`` (a warning, or one line of
        the model's report of problems); None when the file says its unit, when MuJoCo was
        told one, or when a range is wider than +-2 pi (then degrees are meant).
    """
    import mujoco  # here, not at the top: importing exactgrasp stays light

    if written is not None or not spec.compiler.degree:
        return None
    ranges = {
        joint.name or f"joint {i}": (float(joint.range[0]), float(joint.range[1]))
        for i, joint in enumerate(spec.joints)
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE
        and joint.limited != mujoco.mjtLimited.mjLIMITED_FALSE
        and (joint.range[0], joint.range[1]) != (0.0, 0.0)
    }
    if not ranges or any(abs(v) > 2 * math.pi for pair in ranges.values() for v in pair):
        return None
    listed = ", ".join(f"{name} [{lo:g}, {hi:g}]" for name, (lo, hi) in ranges.items())
    return ModelError(
        f"{source}: the file sets no <compiler angle=...>, so MuJoCo read its hinge ranges in "
        f"degrees ({listed} degrees), though each would fit within +-2 pi as radians, as in a "
        "gripper file written for a robot model whose compiler says radian; ",
        Fix("angle", "radian", "pass"),
        " to read the file's angles as radians",
        Fix("angle", "degree", before=", or ", after=" to keep degrees"),
        ' (either, or <compiler angle="radian"/> in the file, ends this warning)',
    )
