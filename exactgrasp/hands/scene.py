"""Which bodies of a compiled MuJoCo model are the hand, and the body tree for inspection.

A scene file holds more than the hand: a table, a target object, an arm. `hand_subtree` picks
the hand's bodies: the subtree of ``root_body``, or, without it, the whole model when at most
one top-level body carries geometry (a hand, perhaps on a ground plane); several such bodies
are refused with the candidates listed. A body with a free joint is a loose object and never a
hand link unless it is the hand's own root. `body_tree` lists bodies, joints, geoms and sites
(the ``exactgrasp inspect`` command), so that ``root_body``, the palm frame and the closing
joints can be chosen without reading the XML.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from exactgrasp.errors import Fix, ModelError, warn_once
from exactgrasp.hands.geoms import (
    GEOM_HFIELD,
    GEOM_KIND,
    GEOM_MESH,
    GEOM_PLANE,
    JOINT_FREE,
    JOINT_HINGE,
    JOINT_SLIDE,
)

__all__ = ["Candidate", "body_tree", "candidates", "hand_geom", "hand_subtree"]

_JOINT_KIND = {0: "free", 1: "ball", 2: "slide", 3: "hinge"}


class Candidate(NamedTuple):
    """A top-level body that carries hand geometry.

    Attributes
    ----------
    body : int
        Body id.
    name : str
    joints : int
        Hinge and slide joints in its subtree.
    geoms : int
        Solid geoms of the chosen kind in its subtree.
    size : float
        Largest side of the box around those geoms at the reference pose (m).
    free : bool
        The body has a free joint (a loose object).
    """

    body: int
    name: str
    joints: int
    geoms: int
    size: float
    free: bool

    def describe(self) -> str:
        joints = f"{self.joints} hinge/slide joint{'s' * (self.joints != 1)}"
        free = ", free joint: a loose object" if self.free else ""
        geoms = f"{self.geoms} geom{'s' * (self.geoms != 1)}"
        return f"{self.name!r} ({joints}, {geoms}, {self.size:.3g} m across{free})"


def hand_geom(mj_model, g: int, geometry: str) -> bool:
    """Is geom ``g`` a closed solid of the kind ``geometry`` selects (see `load_model`)?"""
    m, kind = mj_model, int(mj_model.geom_type[g])
    visual = m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0
    if geometry != "all" and visual != (geometry == "visual"):
        return False
    return kind not in (GEOM_PLANE, GEOM_HFIELD) and kind <= GEOM_MESH


def _world_boxes(mj_model) -> np.ndarray:
    """``(ngeom, 2, 3)`` world-frame boxes around every geom's bounding sphere at qpos0."""
    import mujoco  # here, not at the top: importing exactgrasp stays light

    data = mujoco.MjData(mj_model)
    mujoco.mj_kinematics(mj_model, data)
    r = mj_model.geom_rbound[:, None]
    return np.stack([data.geom_xpos - r, data.geom_xpos + r], axis=1)


def candidates(mj_model, geometry: str) -> list[Candidate]:
    """Top-level bodies with hand geometry, the most hand-like first.

    Bodies with more hinge/slide joints come first, then those with more geoms, then larger
    ones; loose (free-jointed) bodies come last.
    """
    m = mj_model
    top = np.asarray(m.body_rootid)
    boxes = _world_boxes(m)
    out = []
    for b in range(1, m.nbody):
        if m.body_parentid[b] != 0:
            continue
        geoms = [
            g for g in range(m.ngeom) if top[m.geom_bodyid[g]] == b and hand_geom(m, g, geometry)
        ]
        if not geoms:
            continue
        joints = [j for j in range(m.njnt) if top[m.jnt_bodyid[j]] == b]
        moving = sum(int(m.jnt_type[j]) in (JOINT_HINGE, JOINT_SLIDE) for j in joints)
        free = any(int(m.jnt_type[j]) == JOINT_FREE and m.jnt_bodyid[j] == b for j in joints)
        lo, hi = boxes[geoms, 0].min(axis=0), boxes[geoms, 1].max(axis=0)
        out.append(Candidate(b, m.body(b).name, moving, len(geoms), float(np.max(hi - lo)), free))
    return sorted(out, key=lambda c: (c.free, -c.joints, -c.geoms, -c.size))


def hand_subtree(
    mj_model, root_body: str | None, geometry: str, source: str
) -> tuple[int, np.ndarray]:
    """The hand's root body and which bodies belong to it.

    Parameters
    ----------
    mj_model : mujoco.MjModel
    root_body : str or None
        See `exactgrasp.hands.loading.load_model`.
    geometry : {"collision", "visual", "all"}
    source : str
        The model file, for messages.

    Returns
    -------
    root : int
        The root body's id (0, the world, for the whole model).
    in_tree : numpy.ndarray, shape (nbody,) bool
        Bodies of the hand: the root's subtree, less loose (free-jointed) bodies.
    """
    m = mj_model
    names = [m.body(b).name for b in range(m.nbody)]
    found = candidates(m, geometry) if root_body in (None, names[0]) else []
    if root_body is None:
        if len(found) > 1:
            raise ModelError(
                f"{source}: {len(found)} top-level bodies carry {geometry} geometry, so the "
                "model is a scene and which of them is the hand is not known; ",
                Fix("root_body", form="pass", shown=""),
                " the hand's root body. Candidates, the most hand-like first: "
                + "; ".join(c.describe() for c in found)
                + ". (Run `exactgrasp inspect` on the model to see its body tree.)",
            )
        root = 0
    elif root_body in names:
        root = names.index(root_body)
    else:
        raise ModelError(
            f"{source}: root_body {root_body!r} is not a body of the model; "
            f"bodies: {', '.join(names)}"
        )
    in_tree = np.zeros(m.nbody, dtype=bool)
    for b in range(m.nbody):  # parents have smaller ids than children in a compiled model
        in_tree[b] = b == root or (b > 0 and in_tree[m.body_parentid[b]])
    if root == 0:  # free joints sit on top-level bodies only: loose objects of a scene
        sole = found[0].body if len(found) == 1 and root_body is None else None
        loose = [
            int(m.jnt_bodyid[j])
            for j in range(m.njnt)
            if int(m.jnt_type[j]) == JOINT_FREE and int(m.jnt_bodyid[j]) != sole
        ]
        if loose:
            top = np.asarray(m.body_rootid)
            in_tree &= ~np.isin(top, loose)
            warn_once(
                f"{source}: bodies with a free joint are loose objects, not hand links; left "
                f"out: {', '.join(names[b] for b in loose)}"
            )
    return root, in_tree


def _range(m, j: int) -> str:
    kind = int(m.jnt_type[j])
    if not m.jnt_limited[j]:
        return "unlimited"
    lo, hi = (float(v) for v in m.jnt_range[j])
    if kind == JOINT_HINGE:
        return f"[{lo:.4g}, {hi:.4g}] rad ({math.degrees(lo):.4g} .. {math.degrees(hi):.4g} deg)"
    return f"[{lo:.4g}, {hi:.4g}] m"


def _geom_box(m, geoms: list[int]) -> np.ndarray:
    """Sides (3,) of the box around ``geoms`` in their body's frame (m)."""
    import mujoco  # here, not at the top: importing exactgrasp stays light

    corners = []
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    for g in geoms:
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, m.geom_quat[g])
        centre, half = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
        local = centre + signs * half
        corners.append(local @ R.reshape(3, 3).T + m.geom_pos[g])
    points = np.concatenate(corners)
    return np.ptp(points, axis=0)


def body_tree(mj_model, geometry: str = "collision") -> list[str]:
    """The model's body tree as text lines: joints, geoms and sites of every body.

    Parameters
    ----------
    mj_model : mujoco.MjModel
    geometry : {"collision", "visual", "all"}
        Which geoms count as hand geometry (counted apart from the others).

    Returns
    -------
    list of str
        One line per body (indented by depth), joint, coupling and candidate note.
    """
    m = mj_model
    children: dict[int, list[int]] = {}
    for b in range(1, m.nbody):
        children.setdefault(int(m.body_parentid[b]), []).append(b)
    lines: list[str] = []

    def visit(b: int, depth: int) -> None:
        pad = "  " * depth
        geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == b]
        solid = [g for g in geoms if hand_geom(m, g, geometry)]
        kinds = sorted({GEOM_KIND.get(int(m.geom_type[g]), "?") for g in solid})
        text = f"{pad}{m.body(b).name or f'body {b}'}"
        if solid:
            sides = " x ".join(f"{s:.3g}" for s in _geom_box(m, solid))
            text += f"  {len(solid)} {geometry} geom(s) ({', '.join(kinds)}), {sides} m"
        other = len(geoms) - len(solid)
        if other:
            text += f"  (+{other} other geom(s))"
        sites = [
            f"{m.site(s).name or s} at ({', '.join(f'{v:.3g}' for v in m.site_pos[s])})"
            for s in range(m.nsite)
            if m.site_bodyid[s] == b
        ]
        if sites:
            text += f"  sites: {', '.join(sites)}"
        lines.append(text)
        for j in range(m.njnt):
            if m.jnt_bodyid[j] != b:
                continue
            kind = int(m.jnt_type[j])
            entry = f"{pad}  - joint {m.joint(j).name or j!r}: {_JOINT_KIND[kind]}"
            if kind in (JOINT_HINGE, JOINT_SLIDE):
                axis = ", ".join(f"{v:.3g}" for v in m.jnt_axis[j])
                entry += f", axis ({axis}), {_range(m, j)}"
            lines.append(entry)
        for c in children.get(b, []):
            visit(c, depth + 1)

    visit(0, 0)
    for e in range(m.neq):
        if m.eq_type[e] == 2:  # joint equality: joint1 = poly(joint2)
            c = m.eq_data[e][:2]
            drv = m.joint(int(m.eq_obj2id[e])).name if m.eq_obj2id[e] >= 0 else "0"
            lines.append(
                f"coupling: {m.joint(int(m.eq_obj1id[e])).name} follows {drv} "
                f"(offset {c[0]:g}, ratio {c[1]:g})"
            )
    found = candidates(m, geometry)
    if len(found) > 1:
        lines.append("top-level bodies with geometry (a scene): pass root_body= one of:")
        lines += [f"  {c.describe()}" for c in found]
    elif found:
        lines.append(f"the hand: {found[0].describe()} (root_body not needed)")
    else:
        lines.append(f"no top-level body carries {geometry} geometry")
    return lines
