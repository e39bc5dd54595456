"""Closed solids: validated triangle meshes in metres.

Every mesh that enters the library goes through `Solid`, which refuses anything that is not a
closed, consistently oriented surface of positive volume, with a message that names the input,
the defect and the fix.
"""

from __future__ import annotations

import hashlib
import os
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from exactgrasp.errors import Fix, MeshError, warn_once
from exactgrasp.geometry.intake import (
    MAX_PLAUSIBLE_SIZE_M,
    ORIENTATIONS,
    REPAIR,
    UNITS,
    load_points,
    load_trimesh,
    unit_scale,
)
from exactgrasp.geometry.shells import resolve_shells
from exactgrasp.geometry.topology import EdgeDefects, bounding_faces

__all__ = ["MAX_PLAUSIBLE_SIZE_M", "ORIENTATIONS", "UNITS", "Solid", "load_points", "unit_scale"]


class Solid:
    """A closed, consistently oriented triangle mesh of positive volume, in metres.

    Any closed surface is read as the solid it bounds, the points of winding number >= 1:
    disjoint bodies and cavities are kept as they are; overlapping or redundant shells,
    edges shared by four or more faces, repeated faces and shells that cross themselves are
    resolved into that solid with one warning (see `exactgrasp.geometry.shells` and
    ``docs/solids.md``).

    Parameters
    ----------
    vertices : array_like, shape (n, 3)
        Coordinates in ``units``.
    faces : array_like, shape (m, 3), int
        Triangles as vertex indices, counter-clockwise seen from outside.
    units : {"m", "cm", "mm", "inch"}
        Unit of ``vertices``; stored vertices are in metres.
    name : str, optional
        Shown in messages (a file path for `from_file`).
    repair : bool
        For open or inconsistently oriented surfaces: fix what trimesh and pymeshfix can
        (merge vertices, fix winding, fill holes) and warn with the volume before and after.
        A mesh still not closed afterwards is refused. A closed surface is never repaired:
        it is resolved into the solid it bounds whatever this option.
    orientation : {"flip", "refuse"}
        What to do with an inside-out mesh (negative volume), or with an inside-out shell
        that lies inside no other shell: flip it with a warning, or refuse it.
    surface_samples : path or array_like, shape (k, 3), optional
        Points on the surface (e.g. the authors' ``*_P.ply``) in ``units``; used by the voxel
        estimator instead of its own sampling.
    check_scale : bool
        Refuse a solid longer than 5 m (after the unit conversion), the usual sign of
        millimetres read as metres.

    Attributes
    ----------
    vertices : numpy.ndarray, shape (n, 3), float64, metres (read-only)
    faces : numpy.ndarray, shape (m, 3), int64 (read-only)
    surface_samples : numpy.ndarray, shape (k, 3), metres, or None
    repair_report : dict or None
        ``{"volume_before", "volume_after", "actions"}`` when ``repair`` changed the mesh.
    shell_report : dict or None
        How the mesh's closed shells relate and what was done about it (see
        `exactgrasp.geometry.shells.resolve_shells`): ``n_shells``, per-shell ``shells``
        (vertex and face counts, signed volume, role: outer, cavity, island, merged, redundant,
        flipped), ``crossing_pairs``, ``touching_pairs``, ``actions`` (empty when the mesh
        was kept as is), ``volume_before``, ``volume_after`` (m^3). A rigid copy
        (`transformed`) keeps its original's report.
    """

    def __init__(
        self,
        vertices: Any,
        faces: Any,
        *,
        units: str = "m",
        name: str | None = None,
        repair: bool = REPAIR,
        orientation: str = "flip",
        surface_samples: Any = None,
        check_scale: bool = True,
    ):
        self.name = name or "<array mesh>"
        #: How to re-read this solid from a file (set by `from_file`), else None.
        self.source: dict[str, Any] | None = None
        if orientation not in ORIENTATIONS:
            raise MeshError(f"orientation={orientation!r}; use one of {ORIENTATIONS}.")
        scale = unit_scale(units)
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces)
        self._check_arrays(vertices, faces)
        mesh = trimesh.Trimesh(vertices * scale, faces.astype(np.int64), process=False)
        # Exact duplicates only: STL stores every triangle's corners separately.
        mesh.merge_vertices(merge_tex=True, merge_norm=True, digits_vertex=None)
        self.repair_report: dict[str, Any] | None = None
        defects = bounding_faces(mesh.vertices, mesh.faces)[3]
        # A closed surface bounds a solid as it is, however messy: repair is for open or
        # inconsistently oriented surfaces only.
        if repair and not defects.is_cycle:
            mesh = self._repair(mesh)
            defects = bounding_faces(mesh.vertices, mesh.faces)[3]
        self._check_closed(defects)
        # Before the orientation check: one inside-out shell among several is not an
        # inside-out mesh, and overlapping shells make the signed volume meaningless.
        V, F, self.shell_report = resolve_shells(
            mesh.vertices, mesh.faces, self.name, orientation=orientation
        )
        if V is not mesh.vertices:
            mesh = trimesh.Trimesh(V, F, process=False)
        mesh = self._check_orientation(mesh, orientation)
        if check_scale:
            self._check_size(mesh, units)
        self.vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
        self.faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
        self.vertices.flags.writeable = False
        self.faces.flags.writeable = False
        self.surface_samples = (
            None
            if surface_samples is None
            else load_points(surface_samples, units, name=f"{self.name} surface_samples")
        )

    # -- construction -------------------------------------------------------------------------

    @classmethod
    def from_file(cls, path: str | os.PathLike, units: str = "m", **kwargs: Any) -> Solid:
        """Read any mesh file trimesh reads (STL, OBJ, PLY, OFF, GLB, ...).

        Parameters
        ----------
        path : path-like
        units : {"m", "cm", "mm", "inch"}
            Unit the file is written in (the authors' objects are in ``"mm"``).
        **kwargs
            `Solid` keyword arguments (``repair``, ``orientation``, ``surface_samples``).

        Returns
        -------
        Solid
        """
        path = Path(path)
        mesh = load_trimesh(path)
        solid = cls(mesh.vertices, mesh.faces, units=units, name=str(path), **kwargs)
        samples = kwargs.get("surface_samples")
        solid.source = {
            "path": str(path.resolve()),
            "units": units,
            "repair": bool(kwargs.get("repair", REPAIR)),
            "surface_samples": str(Path(samples).resolve())
            if isinstance(samples, str | os.PathLike)
            else None,
        }
        return solid

    @classmethod
    def from_trimesh(cls, mesh: trimesh.Trimesh, units: str = "m", **kwargs: Any) -> Solid:
        """Wrap a `trimesh.Trimesh` (copied; validated like any other input)."""
        kwargs.setdefault("name", getattr(mesh, "metadata", {}).get("file_name"))
        return cls(mesh.vertices, mesh.faces, units=units, **kwargs)

    @classmethod
    def _trusted(cls, vertices: np.ndarray, faces: np.ndarray, name: str, samples=None) -> Solid:
        """Build without validation: for rigid copies of an already validated solid."""
        solid = cls.__new__(cls)
        solid.name = name
        solid.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        solid.faces = np.ascontiguousarray(faces, dtype=np.int64)
        solid.vertices.flags.writeable = False
        solid.faces.flags.writeable = False
        solid.surface_samples = samples
        solid.repair_report = None
        solid.shell_report = None
        solid.source = None
        return solid

    # -- validation ---------------------------------------------------------------------------

    def _check_arrays(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise MeshError(f"{self.name}: vertices must have shape (n, 3), got {vertices.shape}.")
        if faces.size == 0 or len(vertices) == 0:
            raise MeshError(
                f"{self.name}: the mesh is empty ({len(vertices)} vertices, {len(faces)} faces); "
                "a solid needs a closed triangle surface. Check that the file holds a mesh, "
                "not only points."
            )
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise MeshError(
                f"{self.name}: faces must have shape (m, 3) (triangles), got {faces.shape}; "
                "triangulate polygons first (trimesh does this on load)."
            )
        if not np.issubdtype(faces.dtype, np.integer):
            raise MeshError(f"{self.name}: faces must be integer indices, got {faces.dtype}.")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise MeshError(
                f"{self.name}: faces index vertices outside 0..{len(vertices) - 1}; "
                "the face array does not belong to this vertex array."
            )
        bad = ~np.all(np.isfinite(vertices), axis=1)
        if bad.any():
            raise MeshError(
                f"{self.name}: {int(bad.sum())} vertices have NaN or infinite coordinates "
                f"(first at index {int(np.argmax(bad))}); fix or remove them in the source mesh."
            )

    def _check_closed(self, defects: EdgeDefects) -> None:
        if defects.open:
            raise MeshError(
                f"{self.name}: not a closed surface ({defects.describe()}), so it has no "
                "inside and no volume; ",
                Fix("repair", True, "pass"),
                " to let trimesh and pymeshfix close it, or fix the mesh in a modeller.",
            )
        if defects.misoriented:
            raise MeshError(
                f"{self.name}: triangles are not consistently oriented ({defects.describe()}); ",
                Fix("repair", True, "pass"),
                " to fix the winding.",
            )

    def _check_orientation(self, mesh: trimesh.Trimesh, orientation: str) -> trimesh.Trimesh:
        volume = float(mesh.volume)
        if volume > 0:
            return mesh
        if volume == 0 or orientation == "refuse":
            raise MeshError(
                f"{self.name}: signed volume is {volume:.6g} m^3 (inside-out or flat); "
                "reverse the triangle winding, or pass orientation='flip' to let exactgrasp "
                "do it."
            )
        warn_once(
            f"{self.name}: the mesh is inside-out (signed volume {volume:.6g} m^3); "
            "its triangles were flipped."
        )
        return trimesh.Trimesh(mesh.vertices, mesh.faces[:, ::-1], process=False)

    def _check_size(self, mesh: trimesh.Trimesh, units: str) -> None:
        size = float(np.ptp(mesh.vertices, axis=0).max())
        if size > MAX_PLAUSIBLE_SIZE_M:
            raise MeshError(
                f"{self.name}: {size:.4g} m long in ",
                Fix("units", units, "is"),
                ", too large for a grasped object or a hand; if the file is in millimetres ",
                Fix("units", "mm", "pass"),
                " (or 'cm', 'inch')",
                Fix(
                    "check_scale", False, "pass", before=", or ", after=" if this size is intended"
                ),
                ".",
            )

    def _repair(self, mesh: trimesh.Trimesh) -> trimesh.Trimesh:
        actions: list[str] = []
        volume_before = float(mesh.volume)
        mesh = mesh.copy()
        mesh.merge_vertices()
        mesh.update_faces(mesh.nondegenerate_faces())
        mesh.update_faces(mesh.unique_faces())
        mesh.remove_unreferenced_vertices()
        # Body by body: a whole-mesh pymeshfix keeps only the largest component, which would
        # silently drop, e.g., one of the two halves of the authors' FoodClip.
        # trimesh's split would fill holes itself, unreported.
        bodies = mesh.split(only_watertight=False, repair=False)
        if len(bodies) == 0:
            bodies = [mesh]
        repaired = [self._repair_body(body, actions) for body in bodies]
        mesh = trimesh.util.concatenate(repaired) if len(repaired) > 1 else repaired[0]
        if mesh.volume < 0:
            mesh.invert()
            actions.append("flipped inside-out surface")
        if not mesh.is_watertight or not mesh.is_winding_consistent:
            raise MeshError(
                f"{self.name}: ",
                Fix("repair", True),
                f" could not close the surface (after: {actions}); fix the mesh in a modeller "
                "(e.g. MeshLab, Blender's 3D-print toolbox).",
            )
        actions = list(dict.fromkeys(actions))
        if actions:
            volume_after = float(mesh.volume)
            self.repair_report = {
                "volume_before": volume_before,
                "volume_after": volume_after,
                "actions": actions,
            }
            warn_once(
                f"{self.name}: repaired ({', '.join(actions)}); volume {volume_before:.6g} -> "
                f"{volume_after:.6g} m^3 (the 'before' value of an open mesh is only nominal)."
            )
        return mesh

    def _repair_body(self, body: trimesh.Trimesh, actions: list[str]) -> trimesh.Trimesh:
        if not body.is_winding_consistent:
            trimesh.repair.fix_winding(body)
            actions.append("fixed winding")
        if not body.is_watertight:
            trimesh.repair.fill_holes(body)
            actions.append("filled holes (trimesh)")
        if not body.is_watertight:
            from exactgrasp.errors import require

            pymeshfix = require("pymeshfix", f"repairing {self.name}", extra="repair")
            fixer = pymeshfix.MeshFix(np.asarray(body.vertices), np.asarray(body.faces))
            fixer.repair(joincomp=False, remove_smallest_components=False)
            body = trimesh.Trimesh(fixer.points, fixer.faces, process=True)
            actions.append("closed with pymeshfix")
        if body.volume < 0:
            body.invert()
        return body

    # -- derived quantities -------------------------------------------------------------------

    @cached_property
    def volume(self) -> float:
        """Enclosed volume, m^3."""
        return float(trimesh.Trimesh(self.vertices, self.faces, process=False).volume)

    @cached_property
    def area(self) -> float:
        """Surface area, m^2."""
        return float(trimesh.Trimesh(self.vertices, self.faces, process=False).area)

    @cached_property
    def centroid(self) -> np.ndarray:
        """Centre of the enclosed volume (uniform density), shape (3,), metres."""
        return np.asarray(
            trimesh.Trimesh(self.vertices, self.faces, process=False).center_mass,
            dtype=np.float64,
        )

    @property
    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds, shape (2, 3), metres."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def extent(self) -> float:
        """Longest side of the axis-aligned bounding box, metres."""
        return float(np.ptp(self.vertices, axis=0).max())

    @cached_property
    def hash(self) -> str:
        """SHA-256 of the vertex and face arrays (hex), for caching and provenance."""
        digest = hashlib.sha256()
        digest.update(self.vertices.tobytes())
        digest.update(self.faces.tobytes())
        if self.surface_samples is not None:
            digest.update(np.ascontiguousarray(self.surface_samples).tobytes())
        return digest.hexdigest()

    def to_trimesh(self) -> trimesh.Trimesh:
        """A `trimesh.Trimesh` copy (metres)."""
        return trimesh.Trimesh(self.vertices.copy(), self.faces.copy(), process=False)

    def transformed(self, matrix: np.ndarray, name: str | None = None) -> Solid:
        """A copy moved by a rigid or uniformly scaled 4x4 transform.

        Parameters
        ----------
        matrix : numpy.ndarray, shape (4, 4)
            Rotation (possibly times a positive uniform scale) and translation.

        Returns
        -------
        Solid
            Vertices ``matrix @ [x, 1]``; surface samples moved alike.
        """
        matrix = np.asarray(matrix, dtype=np.float64)
        vertices = self.vertices @ matrix[:3, :3].T + matrix[:3, 3]
        samples = self.surface_samples
        if samples is not None:
            samples = samples @ matrix[:3, :3].T + matrix[:3, 3]
        moved = Solid._trusted(vertices, self.faces, name or self.name, samples)
        moved.shell_report = getattr(self, "shell_report", None)
        return moved

    def __repr__(self) -> str:
        return (
            f"Solid({self.name!r}, {len(self.vertices)} vertices, {len(self.faces)} faces, "
            f"volume={self.volume:.6g} m^3)"
        )
