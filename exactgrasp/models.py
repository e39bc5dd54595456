"""Articulated hand models (MJCF, URDF) through MuJoCo: joints, limits and posed link meshes.

MuJoCo compiles both formats, so one code path serves both. A `KinematicModel` keeps the
compiled model and every geom as a welded, closed mesh in the geom's own frame; posing the
hand is then one ``mj_kinematics`` call and a rigid transform per geom. Link meshes are
returned in the frame of the hand's root body (the URDF base link, or ``root_body=``), so
where the hand stands in a scene file does not matter.
"""

from __future__ import annotations

import json
import math
import re
import sys
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from exactgrasp import primitives
from exactgrasp.errors import JointError, ModelError, require

__all__ = ["JOINT_LIMIT_TOL", "KinematicModel", "PalmSpec", "load_model"]

#: Default slack on joint limits, radians for hinges (metres for slides: 1e-5). Recorded
#: grasps sit a hair outside limits rounded in the model file (Barrett distal 0.837758 rad
#: against a URDF limit of 0.837), so 1e-3 rad (0.06 degree) accepts rounding but nothing a
#: person would call a different pose. Values inside the slack are kept as given, not clipped,
#: so that forward kinematics reproduces the record exactly.
JOINT_LIMIT_TOL = 1e-3
_SLIDE_LIMIT_TOL = 1e-5

_PLANE, _HFIELD, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX, _MESH = range(8)
_GEOM_KIND = {0: "plane", 1: "hfield", 2: "sphere", 3: "capsule", 4: "ellipsoid"}
_GEOM_KIND.update({5: "cylinder", 6: "box", 7: "mesh", 8: "sdf"})
_FREE, _BALL, _SLIDE, _HINGE = range(4)
_AXES = {"+x": 0, "x": 0, "+y": 1, "y": 1, "+z": 2, "z": 2, "-x": -1, "-y": -2, "-z": -3}
_PACKAGE_DIR = str(Path(__file__).resolve().parent)


def _warn(message: str) -> None:
    """Warn at the first caller outside exactgrasp, however deep inside the package we are."""
    frame, level = sys._getframe(1), 2
    while frame is not None and frame.f_code.co_filename.startswith(_PACKAGE_DIR):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, UserWarning, stacklevel=level)


@dataclass(frozen=True)
class PalmSpec:
    """A palm frame in hand (root body) coordinates.

    Attributes
    ----------
    origin : tuple of 3 float
        A point on the palm face (metres).
    normal : tuple of 3 float
        Unit vector out of the palm (the approach direction).
    up : tuple of 3 float
        Unit vector along the palm, perpendicular to ``normal`` (e.g. towards the thumb).
    depth : float
        Palm-to-closed-fingertip distance d (metres), > 0.
    """

    origin: tuple
    normal: tuple
    up: tuple
    depth: float

    def __post_init__(self):
        origin = np.asarray(self.origin, dtype=np.float64).reshape(-1)
        normal = np.asarray(self.normal, dtype=np.float64).reshape(-1)
        up = np.asarray(self.up, dtype=np.float64).reshape(-1)
        if origin.shape != (3,) or normal.shape != (3,) or up.shape != (3,):
            raise ModelError("palm origin, normal and up must each have 3 coordinates")
        if not (np.all(np.isfinite([*origin, *normal, *up])) and math.isfinite(self.depth)):
            raise ModelError("palm origin, normal, up and depth must be finite numbers")
        if np.linalg.norm(normal) == 0 or np.linalg.norm(up) == 0:
            raise ModelError("palm normal and up must be non-zero vectors")
        normal, up = normal / np.linalg.norm(normal), up / np.linalg.norm(up)
        if abs(normal @ up) > 1e-6:
            raise ModelError(
                f"palm up {up.tolist()} is not perpendicular to normal "
                f"{normal.tolist()} (dot = {normal @ up:.3g})"
            )
        if not self.depth > 0:
            raise ModelError(f"palm depth must be > 0 (metres), got {self.depth!r}")
        object.__setattr__(self, "origin", tuple(origin.tolist()))
        object.__setattr__(self, "normal", tuple(normal.tolist()))
        object.__setattr__(self, "up", tuple(up.tolist()))
        object.__setattr__(self, "depth", float(self.depth))


def _weld(V: np.ndarray, F: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Merge duplicate vertices, drop collapsed faces, check the shell is closed.

    MuJoCo keeps vertices split where normals differ and stores them in float32, so a closed
    mesh file comes out of a compiled model open: copies of one vertex are identical or a
    float32 rounding apart. Vertices within two float32 spacings of each other (7.5e-9 m for
    coordinates under 0.125 m) are merged; genuine features are far larger (the real Barrett
    palm has distinct vertices 3.4e-8 m apart, which a 1e-8-grid rounding would keep too).
    """
    V, inverse = np.unique(np.asarray(V, dtype=np.float64), axis=0, return_inverse=True)
    F = inverse.reshape(-1)[np.asarray(F, dtype=np.int64)]
    eps = 2.0 * float(np.spacing(np.float32(np.abs(V).max() if len(V) else 1.0)))
    pairs = cKDTree(V).query_pairs(eps, output_type="ndarray")
    if len(pairs):
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), (len(V),) * 2)
        _, label = connected_components(graph, directed=False)
        first = np.full(label.max() + 1, len(V))
        np.minimum.at(first, label, np.arange(len(V)))
        V, F = V[first], label[F]
    F = F[(F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 2] != F[:, 0])]
    if len(F) == 0:
        raise ModelError(f"{what} has no faces")
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = edges[:, 0] * len(V) + edges[:, 1]
    reverse = edges[:, 1] * len(V) + edges[:, 0]
    if len(np.unique(key)) != len(key) or not np.isin(reverse, key).all():
        raise ModelError(
            f"{what} is not a closed, consistently oriented surface even after merging "
            "duplicate vertices; repair the mesh file (e.g. trimesh.repair or pymeshfix) "
            "or use a primitive geom instead"
        )
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    if np.einsum("ij,ij->", a, np.cross(b, c)) < 0:
        _warn(f"{what} is inside-out (negative volume); its faces were flipped")
        F = F[:, ::-1].copy()
    return V, F


def _geom_mesh(mj_model, g: int, tessellation: int, what: str):
    """Closed mesh of geom ``g`` in the geom's own frame."""
    kind, size = int(mj_model.geom_type[g]), mj_model.geom_size[g]
    if kind == _MESH:
        k = int(mj_model.geom_dataid[g])
        va, vn = mj_model.mesh_vertadr[k], mj_model.mesh_vertnum[k]
        fa, fn = mj_model.mesh_faceadr[k], mj_model.mesh_facenum[k]
        return _weld(mj_model.mesh_vert[va : va + vn], mj_model.mesh_face[fa : fa + fn], what)
    if kind == _BOX:
        return primitives.box(size)
    if kind == _SPHERE:
        return primitives.sphere(size[0], tessellation)
    if kind == _CAPSULE:
        return primitives.capsule(size[0], size[1], tessellation)
    if kind == _CYLINDER:
        return primitives.cylinder(size[0], size[1], tessellation)
    return primitives.ellipsoid(size[:3], tessellation)


class KinematicModel:
    """A compiled articulated hand: user-facing joints, couplings and posable link meshes.

    Build one with `load_model`. Attributes follow the library-wide contract: `name`,
    `joint_names` (independent joints in model order), `joint_limits` (radians, or metres for
    slide joints; ``(-inf, inf)`` when unlimited), `default_joints` (the model's reference
    pose clipped into the limits), `palm` (`PalmSpec` or None), plus `couplings`
    ``{dependent: (driver or None, ratio, offset)}`` and `link_names`.
    """

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
        self._mujoco = require("mujoco", "articulated hand models", extra="models")
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
            _warn(
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
                _warn(
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
            _warn("joint values clipped to their limits: " + "; ".join(clipped))
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
            _warn(f"{self.source}: geoms left out of the hand: " + "; ".join(notes))
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
        data, rot, pos = self._kinematics(self.check_joints(joints))
        out = []
        for name, g, V, F in self._geoms:
            R = rot.T @ data.geom_xmat[g].reshape(3, 3)
            t = rot.T @ (data.geom_xpos[g] - pos)
            out.append((name, V @ R.T + t, F.copy()))
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


def _axis(value, R: np.ndarray, what: str) -> np.ndarray:
    """An axis given as "+z"/"-y"/... of frame ``R`` or as a vector in that frame."""
    if isinstance(value, str):
        key = value.strip().lower()
        if key not in _AXES:
            raise ModelError(
                f"palm {what} {value!r}: use one of +x, -x, +y, -y, +z, -z or a 3-vector"
            )
        i = _AXES[key]
        return R[:, i] if i >= 0 else -R[:, -i - 1]
    return R @ np.asarray(value, dtype=np.float64).reshape(3)


def _resolve_palm(model: KinematicModel, palm) -> PalmSpec | None:
    """Turn a `PalmSpec`, a dict (optionally naming a body or site) or None into a PalmSpec."""
    if palm is None or isinstance(palm, PalmSpec):
        return palm
    if not isinstance(palm, Mapping):
        raise ModelError(f"palm must be a PalmSpec or a dict, got {type(palm)}")
    unknown = set(palm) - {"body", "site", "origin", "normal", "up", "depth", "note"}
    missing = {"normal", "up", "depth"} - set(palm)
    if unknown or missing or ("body" in palm and "site" in palm):
        raise ModelError(
            f"palm dict {dict(palm)}: expected keys normal, up, depth, optional origin and "
            "one of body/site (axes and origin are then in that frame); "
            f"unknown {sorted(unknown)}, missing {sorted(missing)}"
        )
    R, p = np.eye(3), np.zeros(3)
    for kind in ("body", "site"):
        if kind in palm:  # evaluated at the default joints
            R, p = model.frame_in_hand(kind, palm[kind])
    origin = p + R @ np.asarray(palm.get("origin", (0.0, 0.0, 0.0)), dtype=np.float64)
    return PalmSpec(
        origin, _axis(palm["normal"], R, "normal"), _axis(palm["up"], R, "up"), palm["depth"]
    )


def _urdf_for_mujoco(path: Path, geometry: str) -> str:
    """The URDF text with the compiler settings this module relies on.

    Static links stay bodies (``fusestatic="false"``) so that every link keeps its name,
    visual geoms are kept unless only collision geometry is wanted, and the mesh directory is
    made absolute because the text is compiled from a string.
    """
    try:
        robot = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ModelError(f"{path}: not a readable URDF ({exc})") from None
    ext = robot.find("mujoco")
    if ext is None:
        ext = ET.SubElement(robot, "mujoco")
    compiler = ext.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(ext, "compiler")
    compiler.set("meshdir", str((path.parent / compiler.get("meshdir", ".")).resolve()))
    compiler.set("fusestatic", "false")
    compiler.set("discardvisual", "true" if geometry == "collision" else "false")
    return ET.tostring(robot, encoding="unicode")


def _compile(mujoco, source: str, *, path: Path | None = None, xml: str | None = None):
    try:
        if xml is not None:
            return mujoco.MjModel.from_xml_string(xml)
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        missing = re.search(r"[Ee]rror opening file '([^']+)'", str(exc))
        if missing:
            raise ModelError(
                f"{source}: mesh file {missing.group(1)!r} named by the model "
                "does not exist; check the file name and the compiler meshdir "
                f"(mujoco: {exc})"
            ) from None
        raise ModelError(f"{source}: mujoco cannot compile the model: {exc}") from None


def load_model(
    path,
    *,
    root_body: str | None = None,
    geometry: str = "collision",
    tessellation: int = 32,
    palm=None,
    couplings=None,
    xml: str | None = None,
) -> KinematicModel:
    """Compile an MJCF (.xml) or URDF (.urdf) hand model with MuJoCo.

    Parameters
    ----------
    path : str or Path
        The model file; for ``xml=`` a name used in messages (and ``.urdf`` or not).
    root_body : str, optional
        The hand's root body; only its subtree is the hand, and link meshes come out in its
        frame. Default: the whole model, in the world frame (= the URDF base link's frame).
    geometry : {"collision", "visual", "all"}
        Which geoms make up the hand. Visual geoms are those that collide with nothing
        (``contype = conaffinity = 0``, MuJoCo's convention and its URDF import's).
    tessellation : int
        Segments around curved primitive geoms (see `exactgrasp.primitives`).
    palm : PalmSpec, dict, False or None
        The palm frame: a `PalmSpec` in hand coordinates, or a dict ``{"body" | "site": name,
        "origin": xyz, "normal": "+z" | xyz, "up": "+y" | xyz, "depth": d}`` whose origin and
        axes are in that body's or site's frame (at the default joints), or in hand
        coordinates without body/site. None reads ``palm_frame.json`` beside the model file
        if there is one; False means no palm frame.
    couplings : dict, optional
        ``{dependent joint: (driver joint, ratio[, offset])}``: the dependent joint is set to
        ``offset + ratio * driver`` and is not a user-facing joint. Added to (and overriding)
        the model's own linear ``<equality><joint>`` constraints.
    xml : str, optional
        Model text to compile instead of reading ``path`` (for bundled MJCF models).

    Returns
    -------
    KinematicModel
    """
    mujoco = require("mujoco", "articulated hand models (MJCF/URDF)", extra="models")
    if geometry not in ("collision", "visual", "all"):
        raise ModelError(f"geometry must be 'collision', 'visual' or 'all', got {geometry!r}")
    if isinstance(tessellation, bool) or int(tessellation) != tessellation or tessellation < 4:
        raise ModelError(f"tessellation must be an integer >= 4, got {tessellation!r}")
    path = Path(path)
    source = str(path)
    is_urdf = path.suffix.lower() == ".urdf"
    if xml is None and not path.is_file():
        raise ModelError(f"hand model file {source!r} does not exist")
    if is_urdf:
        if xml is not None:
            raise ModelError("xml= takes MJCF text; load a URDF from its file")
        mj_model = _compile(mujoco, source, xml=_urdf_for_mujoco(path, geometry))
    else:
        mj_model = _compile(mujoco, source, path=path, xml=xml)
    name = bytes(mj_model.names).split(b"\0", 1)[0].decode() or path.stem
    model = KinematicModel(
        mj_model,
        name=name,
        source=source,
        root_body=root_body,
        geometry=geometry,
        tessellation=int(tessellation),
        couplings=couplings,
    )
    if palm is None and xml is None and (path.parent / "palm_frame.json").is_file():
        try:
            palm = json.loads((path.parent / "palm_frame.json").read_text())
        except (OSError, ValueError) as exc:
            raise ModelError(f"{path.parent / 'palm_frame.json'}: unreadable ({exc})") from None
    model.palm = _resolve_palm(model, palm or None)
    return model
