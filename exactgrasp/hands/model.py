"""Articulated hand models (MJCF, URDF) through MuJoCo: joints, limits and posed link meshes.

MuJoCo compiles both formats, so one code path serves both. A `KinematicModel` keeps the
compiled model and every geom as a welded, closed mesh in the geom's own frame; posing the
hand is then one ``mj_kinematics`` call and a rigid transform per geom. Link meshes are
returned in the frame of the hand's root body (the URDF base link, or ``root_body=``), so
where the hand stands in a scene file does not matter.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from exactgrasp.errors import JointError, ModelError, require, warn_caller
from exactgrasp.hands.loading import (
    _GEOM_KIND,
    _HFIELD,
    _HINGE,
    _MESH,
    _PLANE,
    _SLIDE,
    PalmSpec,
    _geom_mesh,
    load_model,
)

__all__ = ["JOINT_LIMIT_TOL", "KinematicModel", "PalmSpec", "load_model"]


#: Default slack on joint limits, radians for hinges (metres for slides: 1e-5). Recorded
#: grasps sit a hair outside limits rounded in the model file (Barrett distal 0.837758 rad
#: against a URDF limit of 0.837), so 1e-3 rad (0.06 degree) accepts rounding but nothing a
#: person would call a different pose. Values inside the slack are kept as given, not clipped,
#: so that forward kinematics reproduces the record exactly.
JOINT_LIMIT_TOL = 1e-3
_SLIDE_LIMIT_TOL = 1e-5


class KinematicModel:
    """A compiled articulated hand: user-facing joints, couplings and posable link meshes.

    Build one with `load_model`. Attributes follow the library-wide contract: `name`,
    `joint_names` (independent joints in model order), `joint_limits` (radians, or metres for
    slide joints; ``(-inf, inf)`` when unlimited), `default_joints` (the model's reference
    pose clipped into the limits), `palm` (`PalmSpec` or None), plus `couplings`
    ``{dependent: (driver or None, ratio, offset)}`` and `link_names`.
    """

    #: Joints `exactgrasp.grasp.closing.close_fingers` closes by default (None: chosen by their
    #: axes, see there); set it on a model whose flexion joints the rule gets wrong.
    closing_joints: tuple[str, ...] | None = None

    def __init__(
        self,
        mj_model,
        *,
        name,
        source,
        root_body,
        geometry,
        tessellation,
        couplings,
    ):
        self._mujoco = require("mujoco", "articulated hand models", extra="all")
        self._m = mj_model
        self.name, self.source, self.geometry = name, source, geometry
        nb = mj_model.nbody
        names = [mj_model.body(b).name for b in range(nb)]
        self._body_names = names
        if root_body is None:
            self._root = 0
        elif root_body in names:
            self._root = names.index(root_body)
        else:
            raise ModelError(
                f"{source}: root_body {root_body!r} is not a body of the model; "
                f"bodies: {', '.join(names)}"
            )
        in_tree = np.zeros(nb, dtype=bool)
        for b in range(nb):  # parents have smaller ids than children in a compiled model
            in_tree[b] = b == self._root or (b > 0 and in_tree[mj_model.body_parentid[b]])
        self._collect_joints(in_tree, couplings)
        self._collect_geoms(in_tree, geometry, tessellation)
        self.palm: PalmSpec | None = None

    # -- joints ---------------------------------------------------------------------------
    def _collect_joints(self, in_tree, couplings):
        m = self._m
        hinge_slide, held = [], []
        for j in range(m.njnt):
            b = int(m.jnt_bodyid[j])
            # Joints of the root body place it in the scene; meshes are in its frame anyway.
            if not in_tree[b] or (b == self._root and self._root != 0):
                continue
            (hinge_slide if m.jnt_type[j] in (_HINGE, _SLIDE) else held).append(j)
        if held:
            warn_caller(
                f"{self.source}: free/ball joints {[m.joint(j).name for j in held]} "
                "are held at their initial pose (only hinge and slide joints are "
                "exposed)"
            )
        self._joint_ids = {m.joint(j).name: j for j in hinge_slide}
        eq = {}
        for e in range(m.neq):  # MJCF <equality><joint>: joint1 = poly(joint2)
            if m.eq_type[e] != 2 or not m.eq_active0[e]:
                continue
            dep, drv, coef = int(m.eq_obj1id[e]), int(m.eq_obj2id[e]), m.eq_data[e][:5]
            if np.any(coef[2:] != 0):
                warn_caller(
                    f"{self.source}: non-linear joint equality on "
                    f"{m.joint(dep).name} ignored (joint left independent)"
                )
                continue
            eq[m.joint(dep).name] = (
                m.joint(drv).name if drv >= 0 else None,
                float(coef[1]),
                float(coef[0]),
            )
        for dep, spec in (couplings or {}).items():
            if isinstance(spec, str) or len(spec) not in (2, 3):
                raise ModelError(
                    f"coupling of {dep!r}: expected (driver, ratio) or "
                    f"(driver, ratio, offset), got {spec!r}"
                )
            eq[dep] = (spec[0], float(spec[1]), float(spec[2]) if len(spec) == 3 else 0.0)
        for dep, (driver, _, _) in eq.items():
            for joint in (dep, driver):
                if joint is not None and joint not in self._joint_ids:
                    raise ModelError(
                        f"{self.source}: coupling {dep!r} <- {driver!r} names "
                        f"{joint!r}, not a hinge/slide joint of the hand"
                    )
            if driver in eq:
                raise ModelError(
                    f"{self.source}: coupling driver {driver!r} is itself "
                    "coupled; chains of couplings are not supported"
                )
        self.couplings = eq
        self.joint_names = tuple(n for n in self._joint_ids if n not in eq)
        self.joint_limits = {}
        for n in self.joint_names:
            j = self._joint_ids[n]
            lo, hi = m.jnt_range[j] if m.jnt_limited[j] else (-math.inf, math.inf)
            self.joint_limits[n] = (float(lo), float(hi))
        self._tols = {
            n: _SLIDE_LIMIT_TOL if m.jnt_type[j] == _SLIDE else JOINT_LIMIT_TOL
            for n, j in self._joint_ids.items()
        }
        self.default_joints = {
            n: float(np.clip(m.qpos0[m.jnt_qposadr[self._joint_ids[n]]], *self.joint_limits[n]))
            for n in self.joint_names
        }

    def check_joints(
        self, joints: Mapping | None = None, on_limit: str = "error", tol: float | None = None
    ) -> dict[str, float]:
        """Validate joint values and complete them with the defaults.

        Parameters
        ----------
        joints : mapping of str to float, optional
            Values of some or all of `joint_names` (radians or metres). A coupled
            (dependent) joint may be given too if it agrees with its driver within ``tol``.
        on_limit : {"error", "clip"}
            What to do with a value beyond a limit by more than ``tol``: raise `JointError`,
            or clip it to the limit with a warning.
        tol : float, optional
            Slack on the limits; default `JOINT_LIMIT_TOL` (1e-3 rad) for hinges and 1e-5 m
            for slides. Values inside the slack are kept unchanged.

        Returns
        -------
        dict of str to float
            One value per name in `joint_names`, in that order.
        """
        if on_limit not in ("error", "clip"):
            raise JointError(f"on_limit must be 'error' or 'clip', got {on_limit!r}")
        joints = {} if joints is None else joints
        if not isinstance(joints, Mapping):
            raise JointError(f"joints must be a dict {{name: value}}, got {type(joints)}")
        unknown = [k for k in joints if k not in self.joint_names and k not in self.couplings]
        if unknown:
            raise JointError(
                f"unknown joint name(s) {unknown} for hand {self.name!r}; valid "
                f"names: {', '.join(self.joint_names)}"
            )
        values = {}
        for k, v in joints.items():
            try:
                values[k] = float(v)
            except (TypeError, ValueError):
                raise JointError(f"joint {k!r}: value {v!r} is not a number") from None
            if not math.isfinite(values[k]):
                raise JointError(f"joint {k!r}: value {v!r} is not finite")
        out = {n: values.get(n, self.default_joints[n]) for n in self.joint_names}
        clipped = []
        for n, v in out.items():
            lo, hi = self.joint_limits[n]
            slack = self._tols[n] if tol is None else tol
            if lo - slack <= v <= hi + slack:
                continue
            if on_limit == "error":
                raise JointError(
                    f"joint {n!r} = {v!r} is outside its limits [{lo}, {hi}] "
                    f"(tolerance {slack:g}); pass on_limit='clip' to clip it"
                )
            out[n] = min(max(v, lo), hi)
            clipped.append(f"{n}: {v!r} -> {out[n]!r}")
        if clipped:
            warn_caller("joint values clipped to their limits: " + "; ".join(clipped))
        full = self.all_joint_values(out)
        for dep in self.couplings:
            slack = self._tols[dep] if tol is None else tol
            if dep in values and abs(values[dep] - full[dep]) > slack:
                driver, ratio, offset = self.couplings[dep]
                raise JointError(
                    f"joint {dep!r} = {values[dep]!r} contradicts its coupling "
                    f"{dep} = {offset:g} + {ratio:g} * {driver} = {full[dep]!r}; "
                    f"set {driver!r} only"
                )
        return out

    def all_joint_values(self, joints: Mapping[str, float]) -> dict[str, float]:
        """Every hinge/slide joint of the hand, coupled ones computed from their drivers.

        ``joints`` must hold every name in `joint_names` (as `check_joints` returns).
        """
        full = {n: float(joints[n]) for n in self.joint_names}
        for dep, (driver, ratio, offset) in self.couplings.items():
            full[dep] = offset + ratio * (full[driver] if driver is not None else 0.0)
        return full

    # -- geometry -------------------------------------------------------------------------
    def _collect_geoms(self, in_tree, geometry, tessellation):
        m = self._m
        kept, outside, not_solid, other = [], [], [], 0
        for g in range(m.ngeom):
            b, kind = int(m.geom_bodyid[g]), int(m.geom_type[g])
            label = (
                f"{m.geom(g).name or f'geom {g}'} "
                f"({_GEOM_KIND.get(kind, kind)} in {self._body_names[b]})"
            )
            visual = m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0
            if geometry != "all" and visual != (geometry == "visual"):
                other += 1
            elif not in_tree[b]:
                outside.append(label)
            elif kind in (_PLANE, _HFIELD) or kind > _MESH:
                not_solid.append(label)
            else:
                kept.append(g)
        notes = []
        if outside:
            more = f" and {len(outside) - 6} more" if len(outside) > 6 else ""
            notes.append(
                f"outside root body {self._body_names[self._root]!r}: "
                f"{', '.join(outside[:6])}{more}"
            )
        if not_solid:  # planes are infinite; height fields and SDFs are terrain or implicit
            notes.append(f"not closed solids: {', '.join(not_solid)}")
        if notes:
            warn_caller(f"{self.source}: geoms left out of the hand: " + "; ".join(notes))
        if not kept:
            hint = (
                f"; {other} geom(s) of the other kind exist: try geometry='all'" if other else ""
            )
            raise ModelError(
                f"{self.source}: no {geometry} geometry in the hand's subtree "
                f"(root {self._body_names[self._root]!r}){hint}"
            )
        per_body = {}
        for g in kept:
            per_body.setdefault(int(m.geom_bodyid[g]), []).append(g)
        self._geoms = []  # (link name, geom id, V local, F)
        welded = {}  # one weld per mesh asset, however many geoms use it
        for b, gs in per_body.items():
            for g in gs:
                body = self._body_names[b]
                name = body if len(gs) == 1 else f"{body}/{m.geom(g).name or g}"
                what = f"{self.source}: mesh geom {m.geom(g).name or g!r} of body {body!r}"
                key = int(m.geom_dataid[g]) if m.geom_type[g] == _MESH else None
                if key is None or key not in welded:
                    V, F = _geom_mesh(m, g, tessellation, what)
                    if key is not None:
                        welded[key] = V, F
                V, F = welded[key] if key is not None else (V, F)
                self._geoms.append((name, g, V, F))
        self.link_names = tuple(entry[0] for entry in self._geoms)

    def _kinematics(self, joints: Mapping[str, float]):
        mj, m = self._mujoco, self._m
        data = mj.MjData(m)  # a fresh one per call keeps the model safe to share
        for n, v in self.all_joint_values(joints).items():
            data.qpos[m.jnt_qposadr[self._joint_ids[n]]] = v
        mj.mj_kinematics(m, data)
        rot = data.xmat[self._root].reshape(3, 3)
        return data, rot, data.xpos[self._root]

    def link_meshes(self, joints: Mapping[str, float] | None = None):
        """Posed, closed link meshes in the hand (root body) frame.

        Parameters
        ----------
        joints : mapping of str to float, optional
            Joint values (validated with `check_joints`, on_limit="error").

        Returns
        -------
        list of (str, ndarray (n, 3) float64, ndarray (m, 3) int64)
            ``(link name, vertices in metres, faces)`` per geom, outward-oriented and welded.
            A body with one geom gives one entry named after the body; a body with several
            gives one entry per geom named ``body/geom`` (geoms of one body may overlap).
        """
        poses = self.link_poses(joints)
        return [
            (name, V @ T[:3, :3].T + T[:3, 3], F.copy())
            for (name, _, V, F), T in zip(self._geoms, poses, strict=True)
        ]

    # -- what finger closing needs (exactgrasp.grasp.closing) -----------------------------------
    def link_local_meshes(self) -> list[tuple[str, np.ndarray, np.ndarray]]:
        """Link meshes in their own frames, to be placed by `link_poses`.

        Returns
        -------
        list of (str, ndarray (n, 3) float64, ndarray (m, 3) int64)
            ``(link name, vertices in metres, faces)`` in `link_names` order; the arrays are
            the model's own (read-only by convention), so collision structures built on them
            can be kept for the model's lifetime.
        """
        return [(name, V, F) for name, _, V, F in self._geoms]

    def link_poses(self, joints: Mapping[str, float] | None = None) -> np.ndarray:
        """Pose of every link frame in the hand frame.

        Parameters
        ----------
        joints : mapping of str to float, optional
            Joint values (validated with `check_joints`).

        Returns
        -------
        numpy.ndarray, shape (n_links, 4, 4)
            ``x_hand = poses[i] @ [x_link, 1]`` for the vertices of `link_local_meshes` ``[i]``.
        """
        data, rot, pos = self._kinematics(self.check_joints(joints))
        poses = np.tile(np.eye(4), (len(self._geoms), 1, 1))
        for i, (_, g, _, _) in enumerate(self._geoms):
            poses[i, :3, :3] = rot.T @ data.geom_xmat[g].reshape(3, 3)
            poses[i, :3, 3] = rot.T @ (data.geom_xpos[g] - pos)
        return poses

    def joint_frames(self, joints: Mapping[str, float] | None = None) -> dict[str, tuple]:
        """Kind, anchor and axis of every hinge/slide joint (coupled ones too), hand frame.

        Parameters
        ----------
        joints : mapping of str to float, optional
            The configuration at which to evaluate them (validated with `check_joints`).

        Returns
        -------
        dict of str to (str, ndarray (3,), ndarray (3,))
            ``{joint: ("hinge" | "slide", anchor point (m), unit axis)}``; a positive joint
            value turns right-handedly about (or slides along) the axis.
        """
        data, rot, pos = self._kinematics(self.check_joints(joints))
        m = self._m
        return {
            name: (
                "slide" if m.jnt_type[j] == _SLIDE else "hinge",
                rot.T @ (data.xanchor[j] - pos),
                rot.T @ data.xaxis[j],
            )
            for name, j in self._joint_ids.items()
        }

    def joint_links(self) -> dict[str, tuple[int, ...]]:
        """Which links each hinge/slide joint (coupled ones too) moves.

        Returns
        -------
        dict of str to tuple of int
            ``{joint: indices into link_names}`` of the links in the subtree of the joint's
            body. A coupled joint's driver moves its dependents' links as well, but only
            through the dependent joint, so they are not listed under the driver.
        """
        m = self._m
        out = {}
        for name, j in self._joint_ids.items():
            top, moved = int(m.jnt_bodyid[j]), []
            for i, (_, g, _, _) in enumerate(self._geoms):
                b = int(m.geom_bodyid[g])
                while b > top:  # parents have smaller ids, so climbing stops at or above top
                    b = int(m.body_parentid[b])
                if b == top:
                    moved.append(i)
            out[name] = tuple(moved)
        return out

    def frame_in_hand(self, kind: str, name: str, joints=None):
        """Pose ``(R (3, 3), p (3,))`` of a body or site in the hand frame at ``joints``."""
        mj = self._mujoco
        data, rot, pos = self._kinematics(self.check_joints(joints))
        obj = {"body": mj.mjtObj.mjOBJ_BODY, "site": mj.mjtObj.mjOBJ_SITE}[kind]
        i = mj.mj_name2id(self._m, obj, name)
        if i < 0:
            raise ModelError(f"{self.source}: palm {kind} {name!r} does not exist")
        xpos, xmat = (data.xpos, data.xmat) if kind == "body" else (data.site_xpos, data.site_xmat)
        return rot.T @ xmat[i].reshape(3, 3), rot.T @ (xpos[i] - pos)

    def __repr__(self):
        return (
            f"KinematicModel({self.name!r}, joints={len(self.joint_names)}, "
            f"links={len(self.link_names)}, geometry={self.geometry!r})"
        )
