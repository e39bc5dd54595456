"""Geoms of a compiled MuJoCo model as closed meshes: type codes, welding, `collect_geoms`.

With ``repair=True`` a mesh geom that is not a closed solid is repaired as
`exactgrasp.geometry.solid.Solid` repairs a mesh (``Solid(repair=True)``).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from exactgrasp.cache import DiskCache, code_digest
from exactgrasp.errors import Fix, MeshError, ModelError, recording_warnings, warn_once
from exactgrasp.geometry import primitives
from exactgrasp.geometry.shells import resolve_shells
from exactgrasp.geometry.solid import Solid
from exactgrasp.geometry.topology import bounding_faces
from exactgrasp.version import __version__

__all__ = [
    "GEOM_BOX",
    "GEOM_CAPSULE",
    "GEOM_CYLINDER",
    "GEOM_ELLIPSOID",
    "GEOM_HFIELD",
    "GEOM_KIND",
    "GEOM_MESH",
    "GEOM_PLANE",
    "GEOM_SPHERE",
    "JOINT_BALL",
    "JOINT_FREE",
    "JOINT_HINGE",
    "JOINT_SLIDE",
    "collect_geoms",
    "geom_mesh",
    "repair_mesh",
    "weld_mesh",
]

#: MuJoCo's ``mjtGeom`` codes.
(
    GEOM_PLANE,
    GEOM_HFIELD,
    GEOM_SPHERE,
    GEOM_CAPSULE,
    GEOM_ELLIPSOID,
    GEOM_CYLINDER,
    GEOM_BOX,
    GEOM_MESH,
) = range(8)
#: Geom type names by code, for messages.
GEOM_KIND = {0: "plane", 1: "hfield", 2: "sphere", 3: "capsule", 4: "ellipsoid"}
GEOM_KIND.update({5: "cylinder", 6: "box", 7: "mesh", 8: "sdf"})
#: MuJoCo's ``mjtJoint`` codes.
JOINT_FREE, JOINT_BALL, JOINT_SLIDE, JOINT_HINGE = range(4)


#: Welded, resolved link meshes on disk, keyed on the arrays MuJoCo read from the mesh file and
#: on the package version and the sources of the code that welds and resolves them (the
#: geometry room's sources, `exactgrasp.cache.code_digest`, and this module).
WELDED = DiskCache("solids", version=lambda: f"{__version__}/{code_digest(__file__)}")


def weld_mesh(
    V: np.ndarray,
    F: np.ndarray,
    what: str,
    repairs: list[str] | None = None,
    resolved: list[str] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Merge duplicate vertices, drop collapsed and repeated faces, check the mesh bounds a
    solid, and resolve it (`exactgrasp.geometry.shells.resolve_shells`: overlapping shells,
    edges of four faces and self-crossing shells resolved into the solid of winding number
    >= 1, with a warning).

    MuJoCo keeps vertices split where normals differ and stores them in float32, so a closed
    mesh file comes out of a compiled model open: copies of one vertex are identical or a
    float32 rounding apart. Vertices within two float32 spacings of each other (7.5e-9 m for
    coordinates under 0.125 m) are merged; genuine features are far larger (the real Barrett
    palm has distinct vertices 3.4e-8 m apart, which a 1e-8-grid rounding would keep too).

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3)
        Vertices (m).
    F : numpy.ndarray, shape (m, 3)
        Triangles.
    what : str
        The mesh, for messages.
    repairs : list of str, optional
        Given: a mesh still open after welding is repaired (`repair_mesh`) and a line saying
        what changed is appended. None: it is refused.
    resolved : list of str, optional
        Given: what resolving the mesh into its solid changed is appended here (for one
        warning per model). None: it is warned about at once.

    Returns
    -------
    (numpy.ndarray (n', 3) float64, numpy.ndarray (m', 3) int64)
        The welded, outward-oriented closed mesh.

    Notes
    -----
    The result, with what was repaired, resolved and warned, is kept in a disk cache
    (`exactgrasp.cache.DiskCache`, ``EXACTGRASP_CACHE``) keyed on the arrays, ``what`` and
    whether repairs are allowed: loading the same hand again, in any process, replays it.
    """
    V = np.asarray(V)
    F = np.asarray(F)
    key = WELDED.key([V, F, what, str(repairs is not None), str(resolved is not None)])

    def build():
        notes: dict[str, list[str]] = {"repairs": [], "resolved": [], "warnings": []}
        with recording_warnings() as caught:
            W, G = _weld(
                V,
                F,
                what,
                notes["repairs"] if repairs is not None else None,
                notes["resolved"] if resolved is not None else None,
            )
        notes["warnings"] = [str(w.message) for w in caught]
        return {"vertices": W, "faces": G}, notes

    arrays, notes = WELDED.get(key, build)
    if repairs is not None:
        repairs.extend(notes["repairs"])
    if resolved is not None:
        resolved.extend(notes["resolved"])
    for message in notes["warnings"]:
        warn_once(message)
    return arrays["vertices"], arrays["faces"]


def _weld(V, F, what, repairs, resolved):
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
    F, _, _, defects = bounding_faces(V, F)
    if not defects.is_cycle:
        if repairs is not None:
            return repair_mesh(V, F, what, repairs, resolved)
        raise ModelError(
            f"{what} is not a closed surface, even after merging duplicate vertices "
            f"({defects.describe()}); ",
            Fix("repair", True, "pass"),
            " (to load_model, Hand.from_mjcf or Hand.from_urdf) to close it as "
            "Solid(repair=True) does, repair the mesh file, or use a primitive geom instead",
        )
    try:
        # Once per mesh asset, at compile time: posing moves links rigidly, so a resolved
        # link stays resolved in every joint configuration.
        V, F, _ = resolve_shells(
            V,
            F,
            what,
            orientation="flip",
            warn=warn_once if resolved is None else resolved.append,
        )
    except MeshError as exc:
        raise ModelError(*exc.parts) from exc
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    if np.einsum("ij,ij->", a, np.cross(b, c)) < 0:
        warn_once(f"{what} is inside-out (negative volume); its faces were flipped")
        F = F[:, ::-1].copy()
    return V, F


def repair_mesh(
    V: np.ndarray,
    F: np.ndarray,
    what: str,
    repairs: list[str],
    resolved: list[str] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Close an open mesh geom as ``Solid(repair=True)`` does; say what changed in ``repairs``.

    Parameters
    ----------
    V : numpy.ndarray, shape (n, 3)
        Welded vertices (m).
    F : numpy.ndarray, shape (m, 3)
        Triangles.
    what : str
        The geom, for messages.
    repairs : list of str
        One line is appended: the repairs done and the volume before and after (m^3).
    resolved : list of str, optional
        What resolving the repaired mesh into its solid changed, appended here (for one
        warning per model); None: warned about at once.

    Returns
    -------
    (numpy.ndarray (n', 3) float64, numpy.ndarray (m', 3) int64)
        The repaired closed mesh, its shells resolved as for any solid.
    """
    with recording_warnings() as caught:
        try:
            solid = Solid(V, F, name=what, repair=True, check_scale=False)
        except MeshError as exc:
            raise ModelError(*exc.parts, " (with ", Fix("repair", True), ")") from exc
    for w in caught:  # the repair itself is reported once, below; shell notes pass on
        if not str(w.message).startswith(f"{what}: repaired"):
            (warn_once if resolved is None else resolved.append)(str(w.message))
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    before = float(np.einsum("ij,ij->", a, np.cross(b, c))) / 6.0
    actions = list((solid.repair_report or {}).get("actions", []))
    added = len(solid.faces) - len(F)
    if added > 0 and not any("hole" in x or "pymeshfix" in x for x in actions):
        actions.append("filled holes")  # trimesh's split closes small holes unasked
    repairs.append(
        f"{what}: {', '.join(actions) or 're-oriented'} ({len(F)} -> {len(solid.faces)} "
        f"faces); volume {before:.6g} -> {solid.volume:.6g} m^3"
    )
    return np.array(solid.vertices), np.array(solid.faces)


def geom_mesh(
    mj_model,
    g: int,
    tessellation: int,
    what: str,
    repairs: list[str] | None = None,
    resolved: list[str] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Closed mesh ``(V (n, 3) m, F (m, 3))`` of geom ``g`` in the geom's own frame.

    ``repairs`` and ``resolved`` as in `weld_mesh` (mesh geoms only; primitives are closed).
    """
    kind, size = int(mj_model.geom_type[g]), mj_model.geom_size[g]
    if kind == GEOM_MESH:
        k = int(mj_model.geom_dataid[g])
        va, vn = mj_model.mesh_vertadr[k], mj_model.mesh_vertnum[k]
        fa, fn = mj_model.mesh_faceadr[k], mj_model.mesh_facenum[k]
        V, F = mj_model.mesh_vert[va : va + vn], mj_model.mesh_face[fa : fa + fn]
        return weld_mesh(V, F, what, repairs, resolved)
    if kind == GEOM_BOX:
        return primitives.box(size)
    if kind == GEOM_SPHERE:
        return primitives.sphere(size[0], tessellation)
    if kind == GEOM_CAPSULE:
        return primitives.capsule(size[0], size[1], tessellation)
    if kind == GEOM_CYLINDER:
        return primitives.cylinder(size[0], size[1], tessellation)
    return primitives.ellipsoid(size[:3], tessellation)


def collect_geoms(
    mj_model,
    in_tree: np.ndarray,
    root: int,
    body_names: list[str],
    geometry: str,
    tessellation: int,
    source: str,
    *,
    repair: bool,
    problems: list,
) -> tuple[list[tuple[str, int, np.ndarray, np.ndarray]], tuple[str, ...]]:
    """The hand's geoms as closed meshes in their own frames.

    Parameters
    ----------
    mj_model, in_tree, root
        The compiled model, the bodies of the hand's subtree (nbody,) bool and its root body,
        as `exactgrasp.hands.joints.collect_joints` takes them.
    body_names : list of str
        Name of every body, by id.
    geometry : {"collision", "visual", "all"}
        Which geoms make up the hand (see `exactgrasp.hands.loading.load_model`).
    tessellation : int
        Segments around curved primitives.
    source : str
        The model file, for messages.
    repair : bool
        Repair mesh geoms that are not closed (`repair_mesh`), with one warning listing
        them; only the geoms kept (those of the hand's subtree) are checked at all.
    problems : list
        The `ModelError` of each geom that cannot be a closed mesh is appended here (and the
        geom left out), for one report of the whole model.

    Returns
    -------
    geoms : list of (str, int, numpy.ndarray (n, 3), numpy.ndarray (m, 3))
        ``(link name, geom id, vertices in the geom frame (m), faces)``; a body with one geom
        gives one link named after the body, one with several ``body/geom`` links.
    link_names : tuple of str
        The link names, in ``geoms`` order.
    """
    kept = _kept_geoms(mj_model, in_tree, root, body_names, geometry, source)
    per_body: dict[int, list[int]] = {}
    m = mj_model
    for g in kept:
        per_body.setdefault(int(m.geom_bodyid[g]), []).append(g)
    geoms = []
    repairs: list[str] | None = [] if repair else None
    resolved: list[str] = []
    welded: dict = {}  # one weld per mesh asset, however many geoms use it (None: failed)
    for b, gs in per_body.items():
        for g in gs:
            body = body_names[b]
            name = body if len(gs) == 1 else f"{body}/{m.geom(g).name or g}"
            what = f"{source}: mesh geom {m.geom(g).name or g!r} of body {body!r}"
            mesh = m.geom_type[g] == GEOM_MESH
            key = ("mesh", int(m.geom_dataid[g])) if mesh else ("geom", g)
            if key not in welded:
                try:
                    welded[key] = geom_mesh(m, g, tessellation, what, repairs, resolved)
                except ModelError as exc:  # every geom's problem goes into one report
                    problems.append(exc)
                    welded[key] = None
            if welded[key] is not None:
                geoms.append((name, g, *welded[key]))
    if resolved:
        warn_once(
            f"{source}: resolved mesh geoms into the solids they bound: "
            + " | ".join(line.removeprefix(f"{source}: ") for line in resolved)
        )
    if repairs:
        warn_once(
            f"{source}: repaired {len(repairs)} mesh geom(s) (repair=True): "
            + "; ".join(line.removeprefix(f"{source}: ") for line in repairs)
            + " (the 'before' volume of an open mesh is only nominal)"
        )
    return geoms, tuple(entry[0] for entry in geoms)


def _kept_geoms(m, in_tree, root: int, body_names, geometry: str, source: str) -> list[int]:
    """The geoms of the hand (of the chosen kind, in the subtree, solid); what is left out is
    warned about, and no geom at all is a `ModelError` saying what to do."""
    kept, outside, not_solid, other = [], [], [], 0
    for g in range(m.ngeom):
        b, kind = int(m.geom_bodyid[g]), int(m.geom_type[g])
        label = f"{m.geom(g).name or f'geom {g}'} ({GEOM_KIND.get(kind, kind)} in {body_names[b]})"
        visual = m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0
        if geometry != "all" and visual != (geometry == "visual"):
            other += 1
        elif not in_tree[b]:
            outside.append(label)
        elif kind in (GEOM_PLANE, GEOM_HFIELD) or kind > GEOM_MESH:
            not_solid.append(label)
        else:
            kept.append(g)
    notes = []
    if outside:
        more = f" and {len(outside) - 6} more" if len(outside) > 6 else ""
        notes.append(f"outside root body {body_names[root]!r}: {', '.join(outside[:6])}{more}")
    if not_solid:  # planes are infinite; height fields and SDFs are terrain or implicit
        notes.append(f"not closed solids: {', '.join(not_solid)}")
    if notes:
        warn_once(f"{source}: geoms left out of the hand: " + "; ".join(notes))
    if not kept:
        if other:
            hint: tuple = (
                f"; {other} geom(s) of the other kind exist: try ",
                Fix("geometry", "all"),
            )
        elif root or outside:
            hint = (
                "; ",
                Fix("root_body", form="pass", shown=""),
                " naming the body whose subtree holds the hand's geoms",
            )
        else:
            hint = (
                "; the model has no solid geom (box, sphere, capsule, cylinder, ellipsoid or "
                "mesh): add the hand's geoms to the model file",
            )
        raise ModelError(
            f"{source}: no {geometry} geometry in the hand's subtree (root {body_names[root]!r})",
            *hint,
        )
    return kept
