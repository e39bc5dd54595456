"""Loading hand models: `load_model` (MJCF or URDF through MuJoCo) and the model cache.

`load_model` compiles a file into an `exactgrasp.hands.model.KinematicModel` with every geom a
welded, closed mesh and the palm frame resolved into hand coordinates; `load_model_cached`
keeps the last compiled models while their files are unchanged.

Mesh URIs (``package://``, ``model://``) are resolved before MuJoCo reads the file
(`exactgrasp.hands.packages`).
"""

from __future__ import annotations

import json
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from exactgrasp.cache import LRUCache
from exactgrasp.errors import Fix, ModelError, warn_caller
from exactgrasp.geometry.files import file_identity
from exactgrasp.geometry.intake import REPAIR
from exactgrasp.hands.angles import angle_problem, check_angle, written_angle
from exactgrasp.hands.frame import HandFrame
from exactgrasp.hands.model import KinematicModel
from exactgrasp.hands.packages import PackageResolver, package_env, rewrite_spec, rewrite_urdf
from exactgrasp.hands.palm import PALM_FILE, PalmSpec, palm_from_file, resolve_palm

__all__ = [
    "MODEL_CACHE_SIZE",
    "PalmSpec",
    "compile_model",
    "compile_source",
    "jsonable",
    "load_model",
    "load_model_cached",
    "urdf_for_mujoco",
]

#: Compiled file models kept by `load_model_cached`: reading many grasps of one hand (34
#: cereal-box grasps, a batch) compiles its URDF once, not once per grasp.
MODEL_CACHE_SIZE = 8
_MODELS = LRUCache(MODEL_CACHE_SIZE)
#: Where else ``angle`` is set, for warnings (which no front end re-spells).
ELSEWHERE = ' (in a grasp file: "hand_options": {"angle": ...}; on the command line: --angle)'


def urdf_for_mujoco(path: Path, geometry: str, resolver: PackageResolver | None = None) -> str:
    """The URDF text with the compiler settings this module relies on.

    Static links stay bodies (``fusestatic="false"``) so that every link keeps its name,
    visual geoms are kept unless only collision geometry is wanted, the mesh directory is
    made absolute because the text is compiled from a string, and ``package://`` /
    ``model://`` / ``file://`` mesh names are replaced by the files ``resolver`` finds
    (`exactgrasp.hands.packages`), since MuJoCo reads none of them.
    """
    try:
        robot = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ModelError(f"{path}: not a readable URDF ({exc})") from None
    resolver = resolver or PackageResolver(path)
    rewritten = rewrite_urdf(robot, resolver, keep_visual=geometry != "collision")
    ext = robot.find("mujoco")
    if ext is None:
        ext = ET.SubElement(robot, "mujoco")
    compiler = ext.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(ext, "compiler")
    compiler.set("meshdir", str((path.parent / compiler.get("meshdir", ".")).resolve()))
    compiler.set("fusestatic", "false")
    compiler.set("discardvisual", "true" if geometry == "collision" else "false")
    if rewritten:  # the resolved names are absolute paths: they must reach MuJoCo whole
        compiler.set("strippath", "false")
    return ET.tostring(robot, encoding="unicode")


def compile_model(mujoco, source: str, *, path: Path | None = None, xml: str | None = None):
    """``mujoco.MjModel`` from a file or from text, with compile errors as `ModelError`.

    Parameters
    ----------
    mujoco : module
    source : str
        The model file, for messages.
    path : pathlib.Path, optional
        The file to compile (when ``xml`` is None).
    xml : str, optional
        Model text to compile instead.

    Returns
    -------
    mujoco.MjModel
    """
    if xml is not None:
        return _compiled(source, lambda: mujoco.MjModel.from_xml_string(xml))
    return _compiled(source, lambda: mujoco.MjModel.from_xml_path(str(path)))


def _compiled(source: str, build):
    try:
        return build()
    except ValueError as exc:
        missing = re.search(r"[Ee]rror opening file '([^']+)'", str(exc))
        if missing:
            raise ModelError(
                f"{source}: mesh file {missing.group(1)!r} named by the model "
                "does not exist; check the file name and the compiler meshdir "
                f"(mujoco: {exc})"
            ) from None
        raise ModelError(f"{source}: mujoco cannot compile the model: {exc}") from None


def compile_source(
    path,
    *,
    geometry: str = "collision",
    package_dirs=None,
    xml: str | None = None,
    angle: str | None = None,
    cautions: list[ModelError] | None = None,
):
    """Compile an MJCF or URDF file (or MJCF text) with its mesh URIs resolved.

    Parameters
    ----------
    path : str or Path
        The model file; for ``xml=`` a name used in messages.
    geometry : {"collision", "visual", "all"}
        For a URDF: whether its ``<visual>`` meshes are compiled too.
    package_dirs : mapping or sequence of paths, optional
        See `exactgrasp.hands.packages.PackageResolver`.
    xml : str, optional
        MJCF text to compile instead of reading ``path``.
    angle : {"degree", "radian"}, optional
        The unit of an MJCF file's angles, replacing its ``<compiler angle>`` (a URDF's are
        radians). None: as the file says (MuJoCo's default: degree).
    cautions : list, optional
        Given: a `ModelError` is appended, not raised, for what compiles but is likely wrong
        (`exactgrasp.hands.angles.angle_problem`).

    Returns
    -------
    mujoco.MjModel
    """
    import mujoco  # here, not at the top: importing exactgrasp stays light

    angle = check_angle(angle)
    path = Path(path)
    source = str(path)
    if xml is None and not path.is_file():
        where = "" if path.is_absolute() else f" (a relative path is resolved from {Path.cwd()})"
        raise ModelError(f"hand model file {source!r} does not exist; check the path{where}")
    resolver = PackageResolver(path, package_dirs, source)
    if path.suffix.lower() == ".urdf":
        if xml is not None:
            raise ModelError("xml= takes MJCF text; load a URDF from its file")
        if angle == "degree":
            raise ModelError(
                f"{source}: a URDF's angles are radians; ",
                Fix("angle", "degree"),
                " applies to MJCF files only: leave angle=None",
            )
        return compile_model(mujoco, source, xml=urdf_for_mujoco(path, geometry, resolver))
    # MjSpec parses without reading assets, so URI file names can be replaced first.
    spec = _compiled(
        source,
        lambda: (
            mujoco.MjSpec.from_string(xml)
            if xml is not None
            else mujoco.MjSpec.from_file(str(path))
        ),
    )
    if cautions is not None and angle is None:
        problem = angle_problem(source, spec, written_angle(path, xml))
        cautions.extend([problem] if problem is not None else [])
    if angle is not None:
        spec.compiler.degree = angle == "degree"
    if rewrite_spec(spec, resolver) or angle is not None:
        return _compiled(source, spec.compile)
    return compile_model(mujoco, source, path=path, xml=xml)


def load_model(
    path,
    *,
    root_body: str | None = None,
    geometry: str = "collision",
    tessellation: int = 32,
    palm=None,
    couplings=None,
    package_dirs=None,
    repair: bool = REPAIR,
    angle: str | None = None,
    xml: str | None = None,
) -> KinematicModel:
    """Compile an MJCF (.xml) or URDF (.urdf) hand model with MuJoCo.

    Parameters
    ----------
    path : str or Path
        The model file; for ``xml=`` a name used in messages (and ``.urdf`` or not).
    root_body : str, optional
        The hand's root body; only its subtree is the hand, and link meshes come out in its
        frame. Default: the whole model, in the world frame (= the URDF base link's frame);
        a model with several top-level bodies carrying geometry (a scene) is refused with
        the candidates listed (see `exactgrasp.hands.scene`).
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
    package_dirs : dict or list of paths, optional
        Where ``package://NAME/...`` and ``model://NAME/...`` mesh names are found:
        ``{NAME: folder}``, or folders that are or hold packages. Searched before
        ``ROS_PACKAGE_PATH`` and the model file's folder and its parents (see
        `exactgrasp.hands.packages`).
    repair : bool
        Repair mesh geoms of the hand that are not closed solids (as ``Solid(repair=True)``:
        merge vertices, fix winding, fill holes), with one warning listing each repaired
        geom with its volume before and after. Only geoms of the hand's subtree are checked.
    angle : {"degree", "radian"}, optional
        The unit of an MJCF file's angles (joint ranges and references, ``euler`` and
        ``axisangle`` orientations), replacing its ``<compiler angle>``. None (default): as
        the file says, else MuJoCo's default, degree, with a warning when the file says
        nothing and every hinge range would fit within +-2 pi as radians (see
        `exactgrasp.hands.angles`). A URDF's angles are radians.
    xml : str, optional
        Model text to compile instead of reading ``path`` (for bundled MJCF models).

    Returns
    -------
    KinematicModel
    """
    _check_options(geometry, tessellation, repair)
    path = Path(path)
    cautions: list[ModelError] = []
    mj_model = compile_source(
        path, geometry=geometry, package_dirs=package_dirs, xml=xml, angle=angle, cautions=cautions
    )
    model = KinematicModel(
        mj_model,
        name=bytes(mj_model.names).split(b"\0", 1)[0].decode() or path.stem,
        source=str(path),
        root_body=root_body,
        geometry=geometry,
        tessellation=int(tessellation),
        couplings=couplings,
        repair=repair,
    )
    return _with_palm(model, path, None if xml is not None else palm_from_file, palm, cautions)


def _with_palm(model: KinematicModel, path: Path, read, palm, cautions) -> KinematicModel:
    """``model`` with its palm frame (``palm``, else ``read(path)`` when given), or one
    `ModelError` reporting every problem found while loading it, ``cautions`` among them."""
    problems = model.problems
    try:
        if palm is None and read is not None:
            palm = read(path)
        model.palm = resolve_palm(model, palm or None)
    except ModelError as exc:  # reported with the geoms' problems
        problems.append(exc)
    if problems:
        raise ModelError.report(str(path), [*problems, *cautions])
    model.cautions = tuple(cautions)
    for caution in cautions:
        warn_caller(f"{caution}{ELSEWHERE}")
    return model


def _check_options(geometry, tessellation, repair) -> None:
    if geometry not in ("collision", "visual", "all"):
        raise ModelError(f"geometry must be 'collision', 'visual' or 'all', got {geometry!r}")
    if isinstance(tessellation, bool) or int(tessellation) != tessellation or tessellation < 4:
        raise ModelError(f"tessellation must be an integer >= 4, got {tessellation!r}")
    if not isinstance(repair, bool):
        raise ModelError(f"repair must be True or False, got {repair!r}")


def jsonable(options: dict[str, Any]) -> dict[str, Any]:
    """`load_model` options as JSON values (`PalmSpec` and other dataclasses, frames: dicts,
    paths: strings)."""
    return {key: _jsonable(value) for key, value in options.items()}


def _jsonable(value: Any) -> Any:
    if hasattr(value, "__dataclass_fields__"):
        return {k: getattr(value, k) for k in value.__dataclass_fields__}
    if isinstance(value, HandFrame):
        return value.to_dict()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


def load_model_cached(path: Path, options: dict[str, Any]) -> KinematicModel:
    """`load_model` ``(path, **options)``, memoised while the file (and its palm_frame.json)
    is unchanged.

    Models are shared read-only: a Hand never changes its model.

    Parameters
    ----------
    path : pathlib.Path
        The MJCF or URDF file.
    options : dict
        `load_model` keyword arguments.

    Returns
    -------
    KinematicModel
    """
    key = (
        file_identity(path),
        file_identity(path.parent / PALM_FILE),
        json.dumps(jsonable(options), sort_keys=True, default=repr),
        tuple(sorted(package_env().items())),  # where package:// names resolve to
    )
    return _MODELS.get(key, lambda: load_model(path, **options))
