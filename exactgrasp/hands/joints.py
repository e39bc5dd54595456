"""Joints of a compiled MuJoCo hand: limit tolerances, couplings and `collect_joints`."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from exactgrasp.errors import ModelError, warn_once
from exactgrasp.hands.geoms import JOINT_HINGE, JOINT_SLIDE
from exactgrasp.hands.tendons import soft_tendons, tendon_couplings

__all__ = ["JOINT_LIMIT_TOL", "SLIDE_LIMIT_TOL", "JointTable", "collect_joints"]

#: Default slack on joint limits, radians for hinges (metres for slides: 1e-5). Recorded
#: grasps sit a hair outside limits rounded in the model file (Barrett distal 0.837758 rad
#: against a URDF limit of 0.837), so 1e-3 rad (0.06 degree) accepts rounding but nothing a
#: person would call a different pose. Values inside the slack are kept as given, not clipped,
#: so that forward kinematics reproduces the record exactly.
JOINT_LIMIT_TOL = 1e-3
#: Default slack on the limits of slide joints (m).
SLIDE_LIMIT_TOL = 1e-5


class JointTable(NamedTuple):
    """The hinge/slide joints of a hand (see `collect_joints`).

    Attributes
    ----------
    joint_ids : dict of str to int
        MuJoCo joint id of every hinge/slide joint of the hand, coupled ones included.
    couplings : dict of str to (str or None, float, float)
        ``{dependent: (driver, ratio, offset)}``: ``dependent = offset + ratio * driver``.
    joint_names : tuple of str
        The independent (user-facing) joints, in model order.
    joint_limits : dict of str to (float, float)
        Limits of the independent joints (rad or m; ``(-inf, inf)`` when unlimited).
    tols : dict of str to float
        Default limit slack of every joint in ``joint_ids``.
    default_joints : dict of str to float
        The model's reference pose of the independent joints, clipped into the limits.
    """

    joint_ids: dict[str, int]
    couplings: dict[str, tuple[str | None, float, float]]
    joint_names: tuple[str, ...]
    joint_limits: dict[str, tuple[float, float]]
    tols: dict[str, float]
    default_joints: dict[str, float]


def _model_couplings(m, source: str) -> dict[str, tuple[str | None, float, float]]:
    """The model's active linear ``<equality><joint>`` constraints (joint1 = poly(joint2)),
    as ``{dependent: (driver, ratio, offset)}`` on joint values."""
    eq = {}
    for e in range(m.neq):
        if m.eq_type[e] != 2 or not m.eq_active0[e]:
            continue
        dep, drv, coef = int(m.eq_obj1id[e]), int(m.eq_obj2id[e]), m.eq_data[e][:5]
        if np.any(coef[2:] != 0):
            warn_once(
                f"{source}: non-linear joint equality on "
                f"{m.joint(dep).name} ignored (joint left independent)"
            )
            continue
        # MuJoCo's equality holds between displacements from the reference pose (qpos0):
        # dep - ref_dep = c0 + c1 (drv - ref_drv); written here on the joint values.
        ref_dep = float(m.qpos0[m.jnt_qposadr[dep]])
        ref_drv = float(m.qpos0[m.jnt_qposadr[drv]]) if drv >= 0 else 0.0
        eq[m.joint(dep).name] = (
            m.joint(drv).name if drv >= 0 else None,
            float(coef[1]),
            float(coef[0]) + ref_dep - float(coef[1]) * ref_drv,
        )
    return eq


def collect_joints(mj_model, in_tree: np.ndarray, root: int, couplings, source: str) -> JointTable:
    """The hand's hinge/slide joints, its couplings, limits and defaults.

    Parameters
    ----------
    mj_model : mujoco.MjModel
    in_tree : numpy.ndarray, shape (nbody,) bool
        Bodies in the hand's subtree.
    root : int
        The hand's root body; its own joints place it in the scene and are left out.
    couplings : dict, optional
        User couplings ``{dependent: (driver, ratio[, offset])}``, added to (and overriding)
        the model's own linear joint equalities and fixed-tendon equalities
        (`exactgrasp.hands.tendons`).
    source : str
        The model file, for messages.

    Returns
    -------
    JointTable
    """
    m = mj_model
    hinge_slide, held = [], []
    for j in range(m.njnt):
        b = int(m.jnt_bodyid[j])
        # Joints of the root body place it in the scene; meshes are in its frame anyway.
        if not in_tree[b] or (b == root and root != 0):
            continue
        (hinge_slide if m.jnt_type[j] in (JOINT_HINGE, JOINT_SLIDE) else held).append(j)
    if held:
        warn_once(
            f"{source}: free/ball joints {[m.joint(j).name for j in held]} "
            "are held at their initial pose (only hinge and slide joints are "
            "exposed)"
        )
    joint_ids = {m.joint(j).name: j for j in hinge_slide}
    eq = {**tendon_couplings(m, source), **_model_couplings(m, source)}
    for dep, spec in (couplings or {}).items():
        if isinstance(spec, str) or len(spec) not in (2, 3):
            raise ModelError(
                f"coupling of {dep!r}: expected (driver, ratio) or "
                f"(driver, ratio, offset), got {spec!r}"
            )
        eq[dep] = (spec[0], float(spec[1]), float(spec[2]) if len(spec) == 3 else 0.0)
    for dep, (driver, _, _) in eq.items():
        for joint in (dep, driver):
            if joint is not None and joint not in joint_ids:
                raise ModelError(
                    f"{source}: coupling {dep!r} <- {driver!r} names "
                    f"{joint!r}, not a hinge/slide joint of the hand"
                )
        if driver in eq:
            raise ModelError(
                f"{source}: coupling driver {driver!r} is itself "
                "coupled; chains of couplings are not supported"
            )
    soft_tendons(m, source, set(joint_ids), set(eq))
    joint_names = tuple(n for n in joint_ids if n not in eq)
    joint_limits = {}
    for n in joint_names:
        j = joint_ids[n]
        lo, hi = m.jnt_range[j] if m.jnt_limited[j] else (-math.inf, math.inf)
        joint_limits[n] = (float(lo), float(hi))
    tols = {
        n: SLIDE_LIMIT_TOL if m.jnt_type[j] == JOINT_SLIDE else JOINT_LIMIT_TOL
        for n, j in joint_ids.items()
    }
    default_joints = {
        n: float(np.clip(m.qpos0[m.jnt_qposadr[joint_ids[n]]], *joint_limits[n]))
        for n in joint_names
    }
    return JointTable(joint_ids, eq, joint_names, joint_limits, tols, default_joints)
