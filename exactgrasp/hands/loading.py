"""Compiling hand models with MuJoCo: URDF rewriting, mesh welding, palm frames, `load_model`.

The compile side of `exactgrasp.hands.model` (split off to keep each module to one idea): turn an
MJCF or URDF file into a `exactgrasp.hands.model.KinematicModel`, with every geom a welded, closed
mesh and the palm frame resolved into hand coordinates.
"""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from exactgrasp.errors import MeshError, ModelError, require, warn_caller
from exactgrasp.geometry import primitives
from exactgrasp.geometry.shells import resolve_shells

if TYPE_CHECKING:
    from exactgrasp.hands.model import KinematicModel

__all__ = ["PalmSpec", "load_model"]

_PLANE, _HFIELD, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX, _MESH = range(8)
_GEOM_KIND = {0: "plane", 1: "hfield", 2: "sphere", 3: "capsule", 4: "ellipsoid"}
_GEOM_KIND.update({5: "cylinder", 6: "box", 7: "mesh", 8: "sdf"})
_FREE, _BALL, _SLIDE, _HINGE = range(4)
_AXES = {"+x": 0, "x": 0, "+y": 1, "y": 1, "+z": 2, "z": 2, "-x": -1, "-y": -2, "-z": -3}


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
    """Merge duplicate vertices, drop collapsed faces, check the mesh is closed, and resolve
    its shells (`exactgrasp.geometry.shells.resolve_shells`: overlapping shells merged with a
    warning, a self-crossing shell refused with a `ModelError`).

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
    try:
        # Once per mesh asset, at compile time: posing moves links rigidly, so a resolved
        # link stays resolved in every joint configuration.
        V, F, _ = resolve_shells(V, F, what, orientation="flip", warn=warn_caller)
    except MeshError as exc:
        raise ModelError(str(exc)) from None
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    if np.einsum("ij,ij->", a, np.cross(b, c)) < 0:
        warn_caller(f"{what} is inside-out (negative volume); its faces were flipped")
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
        Segments around curved primitive geoms (see `exactgrasp.geometry.primitives`).
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
    from exactgrasp.hands.model import KinematicModel

    mujoco = require("mujoco", "articulated hand models (MJCF/URDF)", extra="all")
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
