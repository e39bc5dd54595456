"""Fixed tendons of a compiled MuJoCo model as joint couplings.

A fixed tendon's length is a linear sum of joint values, ``L = sum_i a_i q_i``. An
``<equality><tendon>`` holds one tendon at its reference length (``tendon1`` alone) or ties two
(``L1 - L1_0 = c0 + c1 (L2 - L2_0)``, ``polycoef="c0 c1 0 0 0"``), where ``L_0`` is the length
at the reference pose (``qpos0``), as MuJoCo's constraint is written. Over the joints of the
two tendons that is one linear relation ``sum_k g_k (q_k - qpos0_k) = c0``; when it holds
exactly two joints, one follows the other, which is a coupling in the form of
`exactgrasp.hands.joints` (``dependent = offset + ratio * driver``), as four-bar grippers
written for MuJoCo close as one. A fixed tendon with stiffness and no equality ties its joints
only softly: MuJoCo's spring pulls them together in simulation, here they stay independent,
which `soft_tendons` says.
"""

from __future__ import annotations

import numpy as np

from exactgrasp.errors import warn_caller

__all__ = ["EQ_TENDON", "WRAP_JOINT", "soft_tendons", "tendon_couplings"]

#: MuJoCo's ``mjtEq`` code of a tendon equality and ``mjtWrap`` code of a joint in a tendon.
EQ_TENDON, WRAP_JOINT = 3, 1
#: Relative size under which a joint's coefficient in a tendon relation is zero (the joint
#: cancels between the two tendons).
CANCELS = 1e-12


def _fixed(m, t: int) -> dict[int, float] | None:
    """``{joint id: coefficient}`` of fixed tendon ``t`` in its listed order (None: spatial)."""
    adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
    if num == 0 or np.any(m.wrap_type[adr : adr + num] != WRAP_JOINT):
        return None
    coefs: dict[int, float] = {}
    for w in range(adr, adr + num):
        j = int(m.wrap_objid[w])
        coefs[j] = coefs.get(j, 0.0) + float(m.wrap_prm[w])
    return coefs


def _name(m, t: int) -> str:
    return m.tendon(t).name or f"tendon {t}"


def _relation(m, e: int, source: str) -> tuple[dict[int, float], float, int] | None:
    """Equality ``e`` as ``({joint: g_k}, c0, first driver candidate)``; None (warned) when it
    is not a linear relation of fixed tendons."""
    t1, t2, coef = int(m.eq_obj1id[e]), int(m.eq_obj2id[e]), m.eq_data[e][:5]
    tendons = [t1] if t2 < 0 else [t1, t2]
    named = " and ".join(repr(_name(m, t)) for t in tendons)
    fixed = [_fixed(m, t) for t in tendons]
    if any(f is None for f in fixed):
        warn_caller(
            f"{source}: tendon equality on {named} ignored: only fixed tendons (sums of "
            "joint values) become couplings"
        )
        return None
    if t2 >= 0 and np.any(coef[2:] != 0):
        warn_caller(
            f"{source}: non-linear tendon equality on {named} ignored (its joints are left "
            "independent)"
        )
        return None
    gamma = dict(fixed[0])
    for j, a in (fixed[1] if t2 >= 0 else {}).items():
        gamma[j] = gamma.get(j, 0.0) - float(coef[1]) * a
    largest = max((abs(g) for g in gamma.values()), default=0.0)
    gamma = {j: g for j, g in gamma.items() if abs(g) > CANCELS * largest}
    # joint2 of a joint equality drives; likewise tendon2, else the first joint listed
    first = next((j for j in (fixed[-1] if t2 >= 0 else fixed[0]) if j in gamma), -1)
    return gamma, float(coef[0]), first


def tendon_couplings(m, source: str) -> dict[str, tuple[str, float, float]]:
    """The couplings of a model's active ``<equality><tendon>`` on fixed tendons.

    Parameters
    ----------
    m : mujoco.MjModel
    source : str
        The model file, for warnings.

    Returns
    -------
    dict of str to (str, float, float)
        ``{dependent: (driver, ratio, offset)}`` on joint values. An equality over more or
        fewer than two joints (not one joint following another), on a spatial tendon or
        non-linear is left out with a warning naming its tendons and ``couplings=``.
    """
    out = {}
    for e in range(m.neq):
        if m.eq_type[e] != EQ_TENDON or not m.eq_active0[e]:
            continue
        relation = _relation(m, e, source)
        if relation is None:
            continue
        gamma, c0, drv = relation
        if len(gamma) != 2:
            joints = ", ".join(m.joint(j).name for j in gamma) or "none"
            warn_caller(
                f"{source}: the tendon equality on {_name(m, int(m.eq_obj1id[e]))!r} ties "
                f"{len(gamma)} joint(s) ({joints}), not one joint to another: its joints are "
                "left independent; pass couplings={dependent: (driver, ratio, offset)} to tie "
                "them"
            )
            continue
        (dep,) = [j for j in gamma if j != drv]
        ref_dep, ref_drv = (float(m.qpos0[m.jnt_qposadr[j]]) for j in (dep, drv))
        # g_dep (q_dep - ref_dep) + g_drv (q_drv - ref_drv) = c0, solved for q_dep
        ratio = -gamma[drv] / gamma[dep]
        offset = ref_dep + c0 / gamma[dep] - ratio * ref_drv
        out[m.joint(dep).name] = (m.joint(drv).name, ratio, offset)
    return out


def soft_tendons(m, source: str, joints: set[str], coupled: set[str]) -> None:
    """Warn about fixed tendons with stiffness that no equality holds, whose joints here move
    independently: naming the joints and the ``couplings=`` entry that would tie them.

    Parameters
    ----------
    m : mujoco.MjModel
    source : str
        The model file, for the warning.
    joints : set of str
        The hand's hinge/slide joints; tendons of none of them are not the hand's.
    coupled : set of str
        Joints already coupled (a tendon one of whose joints is, is tied already).
    """
    held = {int(m.eq_obj1id[e]) for e in range(m.neq) if m.eq_type[e] == EQ_TENDON}
    held |= {int(m.eq_obj2id[e]) for e in range(m.neq) if m.eq_type[e] == EQ_TENDON}
    lines = []
    for t in range(m.ntendon):
        coefs = _fixed(m, t)
        if coefs is None or t in held or not float(np.max(m.tendon_stiffness[t])) > 0:
            continue
        names = [m.joint(j).name for j in coefs]
        if not set(names) & joints or set(names) & coupled:
            continue
        line = f"{_name(m, t)!r} ties {', '.join(names)}"
        if len(coefs) == 2:
            (drv, a_drv), (dep, a_dep) = coefs.items()
            rest = float(np.mean(m.tendon_lengthspring[t]))  # the spring's rest length
            entry = (m.joint(drv).name, -a_drv / a_dep, rest / a_dep)
            line += (
                f" (couplings={{{m.joint(dep).name!r}: {_tuple(entry)}}} holds its rest length)"
            )
        lines.append(line)
    if lines:
        warn_caller(
            f"{source}: fixed tendons with stiffness and no <equality><tendon> couple their "
            "joints only softly, so here the joints move independently: "
            + "; ".join(lines)
            + "; pass couplings={dependent: (driver, ratio, offset)} to tie them"
        )


def _tuple(entry: tuple[str, float, float]) -> str:
    return f"({entry[0]!r}, {entry[1]:.6g}, {entry[2]:.6g})"
