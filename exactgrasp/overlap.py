"""Exact penetration volume of two closed meshes in one call: `intersection_volume`.

Two meshes in any of the usual forms (trimesh meshes, `Solid`s, (vertices, faces) pairs, mesh
files) go through the same intake as every `Solid` (units, repair, shells), then through the
exact backend's `ExactIntersector` (certified error bounds, manifold3d boolean where a sign
cannot be certified). A posed `Hand` takes part as the union of its posed links, and a `Grasp`
as its hand and its object at the grasp's pose, in the hand's coordinates (metres). See
``docs/penetration-volume.md``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from exactgrasp.backends.base import check_poses
from exactgrasp.backends.exact import ExactBackend
from exactgrasp.backends.exact.gradients import object_twist, volume_moments
from exactgrasp.backends.registry import as_backend
from exactgrasp.backends.voxel import VoxelBackend
from exactgrasp.errors import BackendError, Fix, MeshError
from exactgrasp.geometry.intake import REPAIR, UNITS, unit_scale
from exactgrasp.geometry.solid import Solid
from exactgrasp.grasp.grasp import Grasp
from exactgrasp.hands.hand import Hand

__all__ = ["Overlap", "as_solid", "intersection", "intersection_gradient", "intersection_volume"]

#: What `as_solid` takes, for messages.
ACCEPTED = (
    "a trimesh.Trimesh, an exactgrasp.Solid, a (vertices (n, 3), faces (m, 3)) pair, or the "
    "path of a mesh file (STL, OBJ, PLY, OFF, GLB)"
)
UNIT_NAMES = sorted(set(UNITS) - {"in"})
#: What `intersection` takes besides `as_solid`'s forms, for messages.
ACCEPTED_MORE = "an exactgrasp.Hand (its posed links' union)"


def as_solid(
    mesh: Any,
    name: str = "mesh",
    *,
    units: str = "m",
    repair: bool = REPAIR,
    check_scale: bool = True,
) -> Solid:
    """One closed mesh, in any accepted form, as a validated `Solid` (metres).

    Parameters
    ----------
    mesh : trimesh.Trimesh, Solid, (vertices, faces) or path-like
        A `Solid` is returned as it is (already validated, already in metres: ``units`` and
        ``repair`` do not apply to it). Vertices (n, 3) in ``units``, faces (m, 3) integer
        indices, counter-clockwise seen from outside. A path is read with `Solid.from_file`.
    name : str
        What the caller calls the mesh; every message starts with it.
    units : {"m", "cm", "mm", "inch"}
        Unit of the mesh's coordinates.
    repair : bool
        Let trimesh and pymeshfix close and orient the mesh, with a warning (see `Solid`).
    check_scale : bool
        Refuse a solid longer than 5 m (millimetres read as metres); see `Solid`.

    Returns
    -------
    Solid

    Raises
    ------
    MeshError
        For a form that is not accepted, or a mesh that bounds no solid (open, inconsistently
        oriented, faces that all cancel, flat, non-finite); the message names ``name``.
    """
    if isinstance(mesh, Solid):
        return mesh
    unit_scale(units)
    options = {"units": units, "repair": repair, "check_scale": check_scale}
    if isinstance(mesh, trimesh.Trimesh):
        return Solid.from_trimesh(mesh, name=name, **options)
    if isinstance(mesh, trimesh.Scene):
        raise MeshError(
            f"{name}: got a trimesh.Scene ({len(mesh.geometry)} geometries); pass one mesh "
            "(scene.to_mesh() joins them) or the file's path."
        )
    if isinstance(mesh, str | os.PathLike):
        try:
            return Solid.from_file(mesh, **options)
        except MeshError as exc:
            raise exc.prefixed(f"{name}: ") from exc
    if isinstance(mesh, tuple | list) and len(mesh) == 2:
        vertices, faces = _arrays(mesh, name)
        return Solid(vertices, faces, name=name, **options)
    raise MeshError(f"{name}: got {type(mesh).__name__}; pass {ACCEPTED}.")


def _operand(mesh: Any, name: str, **options: Any) -> list[tuple[np.ndarray, np.ndarray]]:
    """``mesh`` as the (vertices, faces) pairs, metres, whose union is the solid: a `Hand`'s
    posed links (hand coordinates, as `Hand.link_arrays`), else `as_solid`'s one solid."""
    if isinstance(mesh, Hand):
        return mesh.link_arrays()
    if isinstance(mesh, Grasp):
        raise MeshError(
            f"{name}: got a Grasp, which holds both meshes; pass it alone as a "
            "(intersection_volume(grasp, poses=...)), or its hand and object as a and b."
        )
    pair = isinstance(mesh, tuple | list) and len(mesh) == 2
    if not pair and not isinstance(
        mesh, Solid | trimesh.Trimesh | trimesh.Scene | str | os.PathLike
    ):
        raise MeshError(f"{name}: got {type(mesh).__name__}; pass {ACCEPTED}, or {ACCEPTED_MORE}.")
    solid = as_solid(mesh, name, **options)
    return [(solid.vertices, solid.faces)]


def _operands(a: Any, b: Any, units: tuple[str, str], **options: Any) -> tuple[list, list]:
    """The meshes of ``a`` (fixed) and ``b`` (moving), each a list of (vertices, faces) whose
    union is the solid: a `Grasp` in ``a`` gives its hand and its object at the grasp's pose."""
    if isinstance(a, Grasp):
        if b is not None:
            raise MeshError(
                f"b: got {type(b).__name__} beside a Grasp, which holds both meshes; pass the "
                "grasp alone (intersection_volume(grasp, poses=...)), or a Hand as a and the "
                "object as b."
            )
        R, t = a.object_pose[:3, :3], a.object_pose[:3, 3]
        return a.hand.link_arrays(), [(a.object.vertices @ R.T + t, a.object.faces)]
    if b is None:
        raise MeshError(
            f"b: missing; pass the mesh that moves ({ACCEPTED}, or {ACCEPTED_MORE}), or pass a "
            "Grasp alone as a."
        )
    return (
        _operand(a, "a", units=units[0], **options),
        _operand(b, "b", units=units[1], **options),
    )


def _arrays(pair: tuple | list, name: str) -> tuple[np.ndarray, np.ndarray]:
    """A (vertices, faces) pair as arrays, or a `MeshError` naming ``name``."""
    try:
        vertices = np.asarray(pair[0], dtype=np.float64)
        faces = np.asarray(pair[1])
        if faces.dtype == object:
            raise ValueError("faces are not a regular (m, 3) array")
    except (TypeError, ValueError) as exc:
        raise MeshError(
            f"{name}: a (vertices, faces) pair must hold numeric arrays ({exc}); pass {ACCEPTED}."
        ) from exc
    return vertices, faces


def _units_pair(units: Any) -> tuple[str, str]:
    """``units`` as (units of a, units of b), or a `MeshError` naming the argument."""
    pair = (units, units) if isinstance(units, str) else units
    if (
        not isinstance(pair, tuple | list)
        or len(pair) != 2
        or not all(isinstance(u, str) and u in UNITS for u in pair)
    ):
        raise MeshError(
            Fix("units", units),
            f"; use one of {UNIT_NAMES} for both meshes, or a pair "
            "(units of a, units of b) such as ('m', 'mm').",
        )
    return pair[0], pair[1]


def _exact_backend(backend: Any) -> ExactBackend:
    """``backend`` as an `ExactBackend` (a name means the library defaults), or a
    `BackendError` saying why another one does not apply."""
    if isinstance(backend, VoxelBackend) or backend == "voxel":
        raise BackendError(
            "backend='voxel' is not offered by intersection_volume: the voxel backend is the "
            "paper's estimator of a hand in its palm frame (grids sized to the hand's canonical "
            "units, surface weights of the paper), which two arbitrary meshes do not have; use "
            "backend='exact' (the default) or backend=ExactBackend(...)."
        )
    if backend != "exact" and not isinstance(backend, ExactBackend):
        raise BackendError(
            f"backend={backend!r}; intersection_volume computes with backend='exact' or "
            "backend=ExactBackend(...) only."
        )
    return as_backend(backend)


@dataclass(frozen=True)
class Overlap:
    """What `intersection` found: the volumes of a ∩ moved b and their certified bounds.

    Attributes
    ----------
    volumes : float or numpy.ndarray
        m^3: a float for a single pose, else an array of shape ``poses.shape[:-2]``.
    bounds : float or numpy.ndarray
        Alike in shape: ``|volume - true volume| <= bound`` (m^3).
    """

    volumes: Any
    bounds: Any


#: The keyword options of `intersection` that `intersection_gradient` takes too.
_OPTIONS = {"units", "repair", "check_scale"}


def _setup(a, b, poses, backend, *, units="m", repair=REPAIR, check_scale=True):
    """The checked inputs of `intersection_volume` and `intersection_gradient`: (whether one
    pose was given, the poses (..., 4, 4), the intersector or None for no poses)."""
    backend = _exact_backend(backend)
    units_a, units_b = _units_pair(units)
    if not isinstance(repair, bool | np.bool_):
        raise MeshError(f"repair must be True or False, got {repair!r}.")
    single = poses is None
    arr = check_poses(np.eye(4) if single else poses, name="poses")
    single = single or arr.ndim == 2
    A, B = _operands(a, b, (units_a, units_b), repair=bool(repair), check_scale=check_scale)
    if arr.size == 0:
        return single, arr, None
    return single, arr, backend.intersector_of(A, B)


def intersection_volume(
    a: Any, b: Any = None, poses: Any = None, backend: str | ExactBackend = "exact", **options: Any
) -> Any:
    """Exact volume of ``a`` ∩ ``b`` (moved rigidly by each pose), in m^3: `intersection`'s
    volumes alone.

    Parameters
    ----------
    a, b, poses, backend
        As `intersection`.
    **options
        `intersection`'s keyword options (``units``, ``repair``, ``check_scale``).

    Returns
    -------
    float or numpy.ndarray
        m^3: a float when ``poses`` is None or one (4, 4) pose, else an array of shape
        ``poses.shape[:-2]``.
    """
    return intersection(a, b, poses, backend, **options).volumes


def intersection(
    a: Any,
    b: Any = None,
    poses: Any = None,
    backend: str | ExactBackend = "exact",
    *,
    units: str | tuple[str, str] = "m",
    repair: bool = REPAIR,
    check_scale: bool = True,
) -> Overlap:
    """Exact volume of ``a`` ∩ ``b`` (moved rigidly by each pose), in m^3, with its bound.

    Both meshes are read as `Solid`s (metres; any closed surface read as the solid of winding
    number >= 1 it bounds, with a warning when it had to be resolved; open surfaces refused)
    and intersected with the exact backend's `ExactIntersector`: every volume lies within its
    certified bound of the true volume, and agrees with manifold3d's double-precision boolean
    to that bound plus the boolean's own rounding (see ``docs/exact-backend.md``). Disjoint or
    touching meshes give exactly 0.

    Parameters
    ----------
    a, b : trimesh.Trimesh, Solid, (vertices, faces), path-like or Hand
        Closed meshes (see `as_solid`). ``b`` is the one that moves. A `Hand` is the union of
        its posed links in its own coordinates (metres), as the descriptor takes it. ``a``
        may also be a `Grasp`, with ``b`` None: its hand, and its object at the grasp's pose
        (``object_pose``) in the hand's coordinates, the object the one that moves.
    poses : array_like, shape (4, 4) or (..., 4, 4), optional
        Rigid motions of ``b`` in ``a``'s frame: a vertex ``x`` of ``b`` (metres, after the
        unit conversion; for a `Grasp`, the object already at its pose) moves to
        ``R @ x + t``, ``t`` in metres. None: ``b`` as given (a `Grasp` as it is).
    backend : "exact" or ExactBackend
        Only the exact backend applies to two arbitrary meshes; ``"voxel"`` is refused. The
        name means its library defaults (`exactgrasp.backends.defaults`); an instance sets
        the broad phase and the threads, e.g. ``ExactBackend(broadphase=None, n_jobs=1)``.
        The volumes do not depend on either.
    units : {"m", "cm", "mm", "inch"} or (str, str)
        Unit of the meshes' coordinates: one for both, or (units of a, units of b). Not
        applied to `Solid`, `Hand` or `Grasp` inputs (already in metres).
    repair : bool
        Let trimesh and pymeshfix close and orient both meshes, with a warning.
    check_scale : bool
        Refuse a mesh longer than 5 m after the unit conversion (see `Solid`).
    Returns
    -------
    Overlap
        ``volumes`` in m^3: a float when ``poses`` is None or one (4, 4) pose, else an array
        of shape ``poses.shape[:-2]``; ``bounds``, alike in shape:
        ``|volume - true volume| <= bound``.

    Raises
    ------
    MeshError
        A mesh in a form not accepted or not a closed solid (the message names ``a`` or
        ``b``), a missing ``b``, a ``b`` beside a `Grasp`, or unknown ``units``.
    BackendError
        A pose that is not a rigid motion (the message names ``poses`` and its index), a
        ``backend`` other than the exact one.
    """
    options = {"units": units, "repair": repair, "check_scale": check_scale}
    single, arr, intersector = _setup(a, b, poses, backend, **options)
    if intersector is None:
        empty = np.zeros(arr.shape[:-2])
        return Overlap(empty, empty.copy())
    result = intersector.intersect(arr)
    volumes, bounds = result.volumes, result.volume_bounds
    if single:
        volumes, bounds = float(volumes), float(bounds)
    return Overlap(volumes, bounds)


def intersection_gradient(
    a: Any, b: Any = None, poses: Any = None, backend: str | ExactBackend = "exact", **options: Any
) -> np.ndarray:
    """Derivative of the exact volume of ``a`` ∩ ``b`` by a rigid motion of ``b``.

    For each pose, ``d/dε volume(a ∩ exp(ε ξ̂) · pose · b)`` at ε = 0, as the vector ``g``
    with ``g · ξ`` that rate for every twist ``ξ = (vx, vy, vz, ωx, ωy, ωz)``: a spatial
    twist in ``a``'s coordinates (metres), applied on the left of the pose, moving a point
    ``x`` at ``v + ω × x``. It is ``(∫ n dA, ∫ x × n dA)`` over the part of ``b``'s moved
    boundary inside ``a`` (``n`` its outward normal): ``-g[:3]`` is the direction along which
    translating ``b`` sheds volume fastest. Exact to the rounding of the surfaces it is
    integrated over (see ``docs/exact-backend.md``, "Derivatives").

    A pose whose volume reads 0 (apart, touching, or an overlap below the volume's certified
    bound) has gradient 0. At contact the derivative is one-sided: pushing in raises the
    volume, pulling out leaves it 0; the 0 reported is the outward one.

    Parameters
    ----------
    a, b, poses, backend
        As for `intersection`.
    **options
        `intersection`'s keyword options (``units``, ``repair``, ``check_scale``).

    Returns
    -------
    numpy.ndarray
        Shape (6,) when ``poses`` is None or one (4, 4) pose, else ``poses.shape[:-2] + (6,)``:
        m^2 per metre of ``v`` (first three), m^3 per radian of ``ω`` (last three).

    Raises
    ------
    MeshError, BackendError
        As for `intersection_volume`.
    """
    unknown = sorted(set(options) - _OPTIONS)
    if unknown:
        raise TypeError(
            f"intersection_gradient() got unexpected keyword arguments {unknown}; its options "
            f"are intersection's: {', '.join(sorted(_OPTIONS))}."
        )
    single, arr, intersector = _setup(a, b, poses, backend, **options)
    if intersector is None:
        return np.zeros((*arr.shape[:-2], 6))
    _, links = volume_moments(intersector, arr)
    twist = object_twist(links)
    return twist.reshape(6) if single else twist
