"""Articulated hand models (MJCF, URDF) through MuJoCo: joints, limits and posed link meshes.

MuJoCo compiles both formats, so one code path serves both. A `KinematicModel` keeps the
compiled model and every geom as a welded, closed mesh in the geom's own frame; posing the
hand is then one ``mj_kinematics`` call and a rigid transform per geom. Link meshes are
returned in the frame of the hand's root body (the URDF base link, or ``root_body=``), so
where the hand stands in a scene file does not matter. Build one with
`exactgrasp.hands.loading.load_model`.

mujoco is loaded on first use (a core dependency, but importing exactgrasp stays light).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from exactgrasp.errors import Fix, JointError, ModelError, warn_caller
from exactgrasp.hands.geoms import JOINT_SLIDE, collect_geoms
from exactgrasp.hands.joints import collect_joints
from exactgrasp.hands.palm import PalmSpec
from exactgrasp.hands.scene import hand_subtree

__all__ = ["KinematicModel"]


class KinematicModel:
    """A compiled articulated hand: user-facing joints, couplings and posable link meshes.

    Build one with `exactgrasp.hands.loading.load_model`. Attributes follow the library-wide
    contract: `name`, `joint_names` (independent joints in model order), `joint_limits`
    (radians, or metres for slide joints; ``(-inf, inf)`` when unlimited), `default_joints`
    (the model's reference pose clipped into the limits), `palm` (`PalmSpec` or None), plus
    `couplings` ``{dependent: (driver or None, ratio, offset)}`` and `link_names`.
    """

    #: Joints `exactgrasp.grasp.closing.close_fingers` closes by default (None: chosen by their
    #: axes, see there); set it on a model whose flexion joints the rule gets wrong.
    closing_joints: tuple[str, ...] | None = None
    #: ``{joint: +1 | -1}``: the sense in which `close_fingers` closes a joint by default
    #: (+1 towards its upper limit); joints not named are inferred (see there).
    closing_directions: dict[str, int] | None = None

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
        repair,
    ):
        import mujoco  # here, not at the top: importing exactgrasp stays light

        self._mujoco = mujoco
        self._m = mj_model
        self.name, self.source, self.geometry = name, source, geometry
        names = [mj_model.body(b).name for b in range(mj_model.nbody)]
        self._body_names = names
        self._root, in_tree = hand_subtree(mj_model, root_body, geometry, source)
        table = collect_joints(mj_model, in_tree, self._root, couplings, source)
        self._joint_ids, self._tols = table.joint_ids, table.tols
        self.couplings = table.couplings
        self.joint_names = table.joint_names
        self.joint_limits = table.joint_limits
        self.default_joints = table.default_joints
        #: What keeps the model from being a hand (each geom's `ModelError`), for
        #: `exactgrasp.hands.loading.load_model` to report together; empty once loaded.
        self.problems: list = []
        # (link name, geom id, V local, F) per geom
        self._geoms, self.link_names = collect_geoms(
            mj_model,
            in_tree,
            self._root,
            names,
            geometry,
            tessellation,
            source,
            repair=repair,
            problems=self.problems,
        )
        self.palm: PalmSpec | None = None
        #: What loaded but is likely wrong, each warned once (`ModelError` s, not raised).
        self.cautions: tuple[ModelError, ...] = ()

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
            Slack on the limits; default `exactgrasp.hands.joints.JOINT_LIMIT_TOL` (1e-3 rad)
            for hinges and 1e-5 m for slides. Values inside the slack are kept unchanged.

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
                    f"(tolerance {slack:g}); ",
                    Fix("on_limit", "clip", "pass"),
                    " to clip it",
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
                "slide" if m.jnt_type[j] == JOINT_SLIDE else "hinge",
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
