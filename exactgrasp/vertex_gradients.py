"""The exact volume of two meshes' intersection and its derivative by every vertex of both:
`intersection_volume_gradients` and its result, `VertexGradients`.

The derivatives are surface integrals over each face's part inside the other solid
(`backends.exact.face_gradients`), exact to the rounding of those surfaces. A mesh the intake
changed (`geometry.solid.Solid`) gets them with respect to its input vertices where the
change keeps every vertex an input vertex (`input_corners`), and is refused otherwise; see
``docs/penetration-volume.md``, "Derivatives by every vertex".
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from exactgrasp.backends.base import check_poses
from exactgrasp.backends.exact import ExactBackend
from exactgrasp.backends.exact.face_gradients import vertex_gradients, vertex_tables
from exactgrasp.errors import MeshError
from exactgrasp.geometry.intake import REPAIR, load_trimesh, unit_scale
from exactgrasp.geometry.solid import Solid
from exactgrasp.grasp.grasp import Grasp
from exactgrasp.hands.hand import Hand
from exactgrasp.overlap import ACCEPTED, ACCEPTED_MORE, _arrays, _exact_backend, _units_pair

__all__ = ["VertexGradients", "input_corners", "intersection_volume_gradients"]

#: Bytes of moments one batch of poses may list at most (poses are run in batches below it).
BATCH_BYTES = 2**27


@dataclass(frozen=True)
class VertexGradients:
    """The exact volume of ``a`` ∩ moved ``b`` and its derivative by every vertex of both.

    Attributes
    ----------
    volumes : float or numpy.ndarray
        m^3: a float for one pose (or none), else shape ``poses.shape[:-2]``.
    grad_a : numpy.ndarray, shape (n_a, 3) or poses.shape[:-2] + (n_a, 3)
        ``dV/dx`` for each vertex ``x`` of ``a`` as given (metres; m^3 per metre of vertex
        motion, whatever ``units`` the mesh was in), in ``a``'s coordinates.
    grad_b : numpy.ndarray, shape (n_b, 3) or poses.shape[:-2] + (n_b, 3)
        The same for ``b``'s vertices, in ``b``'s own coordinates (before the pose): moving
        vertex ``x`` of ``b`` by ``δ`` changes the volume at ``grad_b · δ``.
    """

    volumes: Any
    grad_a: np.ndarray
    grad_b: np.ndarray


def input_corners(vertices: np.ndarray, faces: np.ndarray, solid: Solid, name: str) -> np.ndarray:
    """The input vertex at each corner of the solid's faces, where the intake changed the mesh.

    A face of the solid that has the corners (as points) of an input face takes that face's
    vertices; a face the intake added (a repair's cap, a face re-paired around a four-face
    edge) takes the input vertex at each of its corners, which must be the only input vertex
    there. The intake kept the surface a function of the input vertices exactly where every
    corner is an input vertex: then the volume's derivative by an input vertex is the sum of
    its corners' (copies of a split vertex add up).

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3)
        The input vertices, in metres (as the intake scaled them).
    faces : numpy.ndarray, shape (m, 3)
    solid : Solid
        What the intake made of them.
    name : str
        The mesh, in messages.

    Returns
    -------
    numpy.ndarray, shape (solid m, 3) int64
        Input vertex indices.

    Raises
    ------
    MeshError
        Where a corner of the solid is no input vertex (a crossing cut, overlapping shells
        merged, a six-face edge cut at its midpoint, a hole closed with new vertices), or
        stands where several input vertices do and no input face says which.
    """
    Vo, Fo = solid.vertices, solid.faces
    _, ids = np.unique(np.vstack([vertices, Vo]), axis=0, return_inverse=True)
    ids = ids.reshape(-1)
    vin, vout = ids[: len(vertices)], ids[len(vertices) :]
    fin, fout = vin[faces], vout[Fo]
    table = {}
    for g in range(len(faces) - 1, -1, -1):
        table[tuple(sorted(fin[g]))] = g
    owners = np.bincount(vin, minlength=ids.max() + 1)
    only = np.full(ids.max() + 1, -1, np.int64)
    only[vin] = np.arange(len(vertices))
    out = np.empty(Fo.shape, np.int64)
    for f in range(len(Fo)):
        g = table.get(tuple(sorted(fout[f])))
        for j in range(3):
            c = fout[f, j]
            if g is not None:
                out[f, j] = faces[g, int(np.argmax(fin[g] == c))]
            elif owners[c] == 1:
                out[f, j] = only[c]
            else:
                _refuse_corner(name, Vo[Fo[f, j]], int(owners[c]), solid)
    return out


def _refuse_corner(name: str, point: np.ndarray, owners: int, solid: Solid) -> None:
    """The `MeshError` for a corner of the solid no single input vertex stands at."""
    where = "(" + ", ".join(f"{x:.6g}" for x in point) + ")"
    if owners:
        raise MeshError(
            f"{name}: {owners} input vertices stand at {where}, and a face the intake added "
            "uses that point, so which of them it follows is not defined; merge duplicate "
            "vertices (trimesh's merge_vertices) before asking for vertex gradients."
        )
    what = []
    if solid.repair_report:
        what.append(f"repair ({', '.join(solid.repair_report['actions'])})")
    if solid.shell_report is not None:
        what.append("the resolution of its shells (crossings cut, shells merged)")
    raise MeshError(
        f"{name}: the intake made a mesh with a vertex at {where} that is no input vertex "
        f"(by {' and '.join(what) or 'the intake'}), so the volume's derivative by the input "
        "vertices does not pass through it; pass a closed 2-manifold that does not cross "
        "itself (close holes with faces on the mesh's own vertices, or a fan to a vertex you "
        "add), pass overlapping shells as the links of an exactgrasp.Hand (whose union the "
        "gradients follow), or pass the exactgrasp.Solid itself for derivatives by its "
        "vertices."
    )


def _side(mesh: Any, name: str, units: str, repair: bool, check_scale: bool):
    """``mesh`` as (the (V, F) pairs, metres, whose union is the solid; per pair, the user's
    vertex each face corner's derivative goes to (m_i, 3), numbered over all pairs)."""
    if isinstance(mesh, Hand | Solid):
        pairs = mesh.link_arrays() if isinstance(mesh, Hand) else [(mesh.vertices, mesh.faces)]
        return pairs, _targets(pairs)
    if isinstance(mesh, str | os.PathLike):
        mesh = load_trimesh(Path(mesh))
    if isinstance(mesh, trimesh.Trimesh):
        vertices, faces = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces)
    elif isinstance(mesh, tuple | list) and len(mesh) == 2:
        vertices, faces = _arrays(mesh, name)
    else:
        raise MeshError(f"{name}: got {type(mesh).__name__}; pass {ACCEPTED}, or {ACCEPTED_MORE}.")
    options = {"units": units, "repair": repair, "check_scale": check_scale}
    solid = Solid(vertices, faces, name=name, **options)
    scaled = vertices * unit_scale(units)
    pairs = [(solid.vertices, solid.faces)]
    if np.array_equal(solid.faces, faces) and np.array_equal(solid.vertices, scaled):
        return pairs, ([solid.faces], len(vertices))
    corners = input_corners(scaled, np.asarray(faces, np.int64), solid, name)
    return pairs, ([corners], len(vertices))


def _targets(pairs: list) -> tuple[list[np.ndarray], int]:
    """Each pair's faces numbered over all pairs' vertices, and the vertices' count."""
    offsets = np.cumsum([0] + [len(V) for V, _ in pairs])
    return [F + o for (_, F), o in zip(pairs, offsets[:-1], strict=True)], int(offsets[-1])


def intersection_volume_gradients(
    a: Any,
    b: Any = None,
    poses: Any = None,
    backend: str | ExactBackend = "exact",
    *,
    units: str | tuple[str, str] = "m",
    repair: bool = REPAIR,
    check_scale: bool = True,
) -> VertexGradients:
    """Exact volume of ``a`` ∩ ``b`` (moved rigidly by each pose) and its derivative by
    every vertex of both meshes.

    ``dV/dx_i = Σ_f (∫_{f ∩ other} φ_i dA) n_f`` over the faces ``f`` around vertex ``i``
    (``φ_i`` the face's barycentric weight of ``i``, ``n_f`` its unit outward normal): the
    surfaces' parts inside the other solid, exact to their rounding (see
    ``docs/penetration-volume.md``). A pose whose volume reads 0 has zero derivatives.

    Parameters
    ----------
    a, b, poses, backend, units, repair, check_scale
        As `exactgrasp.intersection`. A `Hand`'s vertices are its posed links' vertices in
        link order (`Hand.link_arrays`), a `Grasp` (as ``a``, ``b`` None) gives its hand's
        and its object's own vertices (`Solid.vertices`, before the grasp pose).

    Returns
    -------
    VertexGradients
        ``volumes`` (m^3), ``grad_a`` (..., n_a, 3) and ``grad_b`` (..., n_b, 3) in m^3 per
        metre, each mesh in its own coordinates; a float and (n, 3) arrays for one pose.

    Raises
    ------
    MeshError
        As `exactgrasp.intersection`, and for a mesh the intake changed in a way the
        derivatives by its input vertices cannot follow (`input_corners`; the message says
        what to pass instead).
    BackendError
        As `exactgrasp.intersection`.
    """
    backend = _exact_backend(backend)
    units_a, units_b = _units_pair(units)
    if not isinstance(repair, bool | np.bool_):
        raise MeshError(f"repair must be True or False, got {repair!r}.")
    single = poses is None
    arr = check_poses(np.eye(4) if single else poses, name="poses")
    single = single or arr.ndim == 2
    turn = None
    if isinstance(a, Grasp):
        if b is not None:
            raise MeshError(f"b: got {type(b).__name__} beside a Grasp; pass the grasp alone.")
        turn, t = a.object_pose[:3, :3], a.object_pose[:3, 3]
        A = a.hand.link_arrays()
        B = [(a.object.vertices @ turn.T + t, a.object.faces)]
        to_a, to_b = _targets(A), _targets(B)
    elif b is None:
        raise MeshError(f"b: missing; pass the mesh that moves ({ACCEPTED}).")
    else:
        options = {"repair": bool(repair), "check_scale": check_scale}
        A, to_a = _side(a, "a", units_a, **options)
        B, to_b = _side(b, "b", units_b, **options)
    # A grasp's object: by its own vertices, before the grasp pose (``turn``).
    volumes, ga, gb = _gradients(backend, (A, to_a), (B, to_b), arr.reshape(-1, 4, 4), turn)
    shape = arr.shape[:-2]
    volumes = volumes.reshape(shape)
    ga, gb = ga.reshape(*shape, ga.shape[-2], 3), gb.reshape(*shape, gb.shape[-2], 3)
    if single:
        return VertexGradients(float(volumes), ga, gb)
    return VertexGradients(volumes, ga, gb)


def _gradients(backend: ExactBackend, A: tuple, B: tuple, poses: np.ndarray, turn):
    """Volumes (k,) and the derivatives by the user's vertices of either side (k, n, 3);
    ``A`` and ``B`` are `_side`'s (pairs, (corner targets, n)), ``turn`` (3, 3) or None the
    rotation ``B``'s vertices were placed by (its derivatives are by them before it)."""
    k = len(poses)
    volumes = np.zeros(k)
    # Every pose's rows are written by `vertex_gradients` (zeroed there, pose by pose).
    outs = (np.empty((k, A[1][1], 3)), np.empty((k, B[1][1], 3)))
    if k == 0:
        return volumes, *outs
    intersector = backend.intersector_of(A[0], B[0], faces=True)
    tables = vertex_tables(intersector, (A[0], A[1][0]), (B[0], B[1][0]), turn)
    # Each pose lists at most every row once (`moment_entries`): batches bound the entries.
    batch = max(1, BATCH_BYTES // (56 * intersector.moment_rows))
    for start in range(0, k, batch):
        at = slice(start, min(start + batch, k))
        volumes[at] = vertex_gradients(intersector, tables, poses[at], outs[0][at], outs[1][at])
    return volumes, *outs
