"""The "exact" backend: the true volume of hand ∩ moved object, pose by pose.

`ExactIntersector` is the array-level core (no dependency on the rest of the library);
`ExactBackend` wraps it as a `Backend`. The method (see ``docs/exact-backend.md``):

1. Once per grasp, the hand links and the object bodies are each merged into one solid with a
   manifold3d ``Mesh64`` union (overlaps counted once), and a cell grid is built over each.
2. Per pose, the volume is a sum of local surface-integral terms (`_exact_kernels`): edges of
   either mesh lying inside the other, and pairs of crossing faces. Only faces near the other
   surface are ever tested; everything else is classified by its grid cell.
3. Every geometric decision is an orientation sign with a certified error bound; a pose where
   any sign is uncertain is recomputed with a plain manifold3d boolean. Volumes therefore agree
   with the plain boolean to rounding (about 1e-14 relative, see `agrees`).
"""

from __future__ import annotations

import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any

import numpy as np

from exactgrasp.backends.base import Backend, check_poses
from exactgrasp.backends.exact import pose as kp
from exactgrasp.backends.exact.kernels import winding_number
from exactgrasp.backends.exact.tables import (
    build_grid,
    cell_order,
    face_conditioning,
    face_d_coefs,
    hand_tables,
    mesh_arrays,
    part_sums,
    prepare_mesh,
    to_manifold,
    union,
    vertex_cells,
)
from exactgrasp.errors import BackendError, require

if TYPE_CHECKING:
    from exactgrasp.grasp import Grasp

BROADPHASES = ("coal", "fcl", None)
#: Relative agreement demanded of every volume (see `agrees`).
RTOL = 1e-9
#: Volumes below FLOOR times the hand volume are compared in absolute terms (see `agrees`).
FLOOR = 1e-6

Mesh = tuple[np.ndarray, np.ndarray]


def agrees(a: np.ndarray, b: np.ndarray, hand_volume: float, rtol: float = RTOL) -> np.ndarray:
    """Whether volumes `a` agree with reference volumes `b` "to `rtol` relative".

    ``|a - b| <= rtol * max(|b|, FLOOR * hand_volume)`` with ``FLOOR = 1e-6``: a volume is
    compared relative to itself, except that volumes under a millionth of the hand's are
    compared relative to that millionth (a relative difference of a volume that is, say,
    1e-20 of the hand carries no information; the floor keeps the test meaningful down to
    about 1e-15 of the hand volume in absolute terms).

    Parameters
    ----------
    a, b : numpy.ndarray
        Volumes to compare, same shape (cubed canonical units).
    hand_volume : float
        Volume of the hand (the union of its links).
    rtol : float
        Relative tolerance.

    Returns
    -------
    numpy.ndarray of bool, same shape.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.abs(a - b) <= rtol * np.maximum(np.abs(b), FLOOR * hand_volume)


#: Largest grid a cell option may ask for (cells per grid): about 1.6 GB of tables.
MAX_GRID_CELLS = 200_000_000


def _check_options(broadphase: Any, n_jobs: Any, tuning: dict[str, Any]) -> dict[str, Any]:
    """Validate the exact backend's options; returns the tuning options as plain numbers.

    Raises `BackendError` naming the option and what is allowed.
    """
    if broadphase not in BROADPHASES:
        raise BackendError(f"unknown broadphase {broadphase!r}; use one of 'coal', 'fcl' or None.")
    if isinstance(n_jobs, bool) or not (
        n_jobs == -1 or (isinstance(n_jobs, int | np.integer) and n_jobs >= 1)
    ):
        raise BackendError(f"n_jobs must be a positive integer or -1, got {n_jobs!r}.")
    unknown = set(tuning) - {"hand_cell", "object_cell", "capacity"}
    if unknown:
        raise BackendError(
            f"unknown tuning options {sorted(unknown)}; use hand_cell, object_cell or capacity."
        )
    out: dict[str, Any] = {}
    for key in ("hand_cell", "object_cell"):
        value = tuning.get(key)
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(
            value, int | float | np.integer | np.floating
        ):
            raise BackendError(
                f"{key} must be a positive length (same units as the meshes) or None for the "
                f"default (1/48 of the mesh's extent), got {value!r}."
            )
        if not (np.isfinite(value) and value > 0):
            raise BackendError(
                f"{key} must be a positive, finite length (same units as the meshes) or None "
                f"for the default (1/48 of the mesh's extent), got {value!r}."
            )
        out[key] = float(value)
    if "capacity" in tuning:
        value = tuning["capacity"]
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise BackendError(
                f"capacity must be a positive integer (edge crossings recorded per pose before "
                f"the pose falls back to a boolean; default 400000), got {value!r}."
            )
        out["capacity"] = int(value)
    return out


def _grid_cell(vertices: np.ndarray, cell: float | None, key: str) -> float:
    """The grid cell edge for a mesh: ``cell`` if given (checked against `MAX_GRID_CELLS`),
    else 1/48 of the mesh's largest extent."""
    extent = np.ptp(vertices, axis=0)
    if cell is None:
        return float(extent.max() / 48)
    cells = float(np.prod(np.ceil(extent / cell) + 3))
    if cells > MAX_GRID_CELLS:
        raise BackendError(
            f"{key}={cell:g} lays {cells:.3g} grid cells over a mesh of extent "
            f"{extent.max():.4g}, more than {MAX_GRID_CELLS:,}; use a {key} of at least "
            f"{extent.max() / (MAX_GRID_CELLS ** (1 / 3) - 3):.3g}, or None for the default."
        )
    return float(cell)


def _bounds_centre(meshes: list[Mesh]) -> np.ndarray:
    """Centre of the bounding box of all vertices of the meshes, shape (3,)."""
    if not meshes:
        raise BackendError("no hand link meshes given; pass at least one (V, F) pair.")
    lo = np.min([np.min(V, axis=0) for V, _ in meshes], axis=0)
    hi = np.max([np.max(V, axis=0) for V, _ in meshes], axis=0)
    return 0.5 * (lo + hi)


def _shifted(meshes: list[Mesh], origin: np.ndarray) -> list[Mesh]:
    """The meshes with ``origin`` subtracted from their vertices (new arrays)."""
    return [(np.asarray(V, dtype=np.float64) - origin, F) for V, F in meshes]


def _solids(meshes: list[Mesh], what: str) -> list:
    if not meshes:
        raise BackendError(f"no {what} meshes given; pass at least one (V, F) pair.")
    return [to_manifold(V, F, f"{what} {i}") for i, (V, F) in enumerate(meshes)]


def plain_volumes(hand_links: list[Mesh], object_bodies: list[Mesh], poses) -> np.ndarray:
    """Reference: one manifold3d boolean of (union of links) ∩ (moved object) per pose.

    Parameters
    ----------
    hand_links, object_bodies : list of (V (n, 3) float64, F (m, 3) int)
        Closed, outward-oriented meshes in the canonical frame.
    poses : numpy.ndarray, shape (..., 4, 4)
        Rigid transforms of the object (``x -> R @ x + t``).

    Returns
    -------
    numpy.ndarray, shape poses.shape[:-2]
        Intersection volumes in cubed canonical units.
    """
    poses = check_poses(poses)
    hand = union(_solids(hand_links, "hand link"))
    obj = union(_solids(object_bodies, "object body"))
    flat = poses.reshape(-1, 4, 4)
    out = np.array([(hand ^ obj.transform(p[:3, :])).volume() for p in flat])
    return out.reshape(poses.shape[:-2])


def _face_runs(V: np.ndarray, F: np.ndarray, size: int) -> np.ndarray:
    """Bounding spheres of the runs of `size` consecutive faces (the last run may be
    shorter): shape (runs, 4), centre and radius; the radius is widened by 1e-12 of the
    mesh's scale to cover rounding."""
    runs = -(-len(F) // size)
    pad = np.concatenate([F, np.repeat(F[-1:], runs * size - len(F), axis=0)])
    T = V[pad].reshape(runs, size * 3, 3)
    centre = 0.5 * (T.max(1) + T.min(1))
    radius = np.linalg.norm(T - centre[:, None], axis=2).max(1)
    radius += 1e-12 * max(1.0, float(np.abs(V).max()))
    return np.ascontiguousarray(np.column_stack([centre, radius]))


def _vertex_components(V: np.ndarray, E: np.ndarray) -> tuple[np.ndarray, int]:
    """Connected component of each vertex of a mesh with edges E (e, 2): (labels, count)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(V)
    graph = coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    return labels.astype(np.int64), int(count)


class _PoseCull:
    """Whole-pose test with a BVH library: is the moved object's surface far from the hand's?"""

    def __init__(self, library: str, AV, AF, BV, BF, gap: float):
        self.library = library
        self.gap = gap
        if library == "coal":
            coal = require("coal", "the exact backend's coal broad phase", "coal", "exact")
            self._lib = coal
            self._a = self._coal_model(coal, AV, AF)
            self._b = self._coal_model(coal, BV, BF)
        else:
            fcl = require("fcl", "the exact backend's fcl broad phase", "python-fcl", "exact")
            self._lib = fcl
            self._a = fcl.CollisionObject(self._fcl_model(fcl, AV, AF), fcl.Transform())
            self._b = fcl.CollisionObject(self._fcl_model(fcl, BV, BF), fcl.Transform())
            self._lock = threading.Lock()

    @staticmethod
    def _coal_model(coal, V, F):
        model = coal.BVHModelOBBRSS()
        model.beginModel(len(F), len(V))
        model.addVertices(np.ascontiguousarray(V))
        model.addTriangles(np.ascontiguousarray(F, dtype=np.int64))
        model.endModel()
        return model

    @staticmethod
    def _fcl_model(fcl, V, F):
        model = fcl.BVHModel()
        model.beginModel(len(V), len(F))
        model.addSubModel(np.ascontiguousarray(V), np.ascontiguousarray(F, dtype=np.int64))
        model.endModel()
        return model

    def far(self, pose: np.ndarray) -> bool:
        """True when the surfaces are certainly more than `gap` apart (no boolean needed)."""
        if self.library == "coal":
            coal = self._lib
            req = coal.CollisionRequest()
            res = coal.CollisionResult()
            tf = coal.Transform3s(pose[:3, :3].copy(), pose[:3, 3].copy())
            if coal.collide(self._a, coal.Transform3s(), self._b, tf, req, res) > 0:
                return False
            dreq = coal.DistanceRequest()
            dres = coal.DistanceResult()
            return coal.distance(self._a, coal.Transform3s(), self._b, tf, dreq, dres) > self.gap
        fcl = self._lib
        with self._lock:  # fcl collision objects carry their transform: not thread-safe
            self._b.setTransform(fcl.Transform(pose[:3, :3].copy(), pose[:3, 3].copy()))
            if fcl.collide(self._a, self._b, fcl.CollisionRequest(), fcl.CollisionResult()) > 0:
                return False
            return fcl.distance(self._a, self._b, fcl.DistanceRequest(), fcl.DistanceResult()) > (
                self.gap
            )


def _shells_outside(
    X: np.ndarray, shells: tuple[np.ndarray, int], grid: tuple, V: np.ndarray, F: np.ndarray
) -> bool:
    """Whether every shell of a mesh lies outside another closed mesh, their surfaces apart.

    Parameters
    ----------
    X : numpy.ndarray, shape (n, 3)
        The mesh's vertices in the other mesh's frame.
    shells : (numpy.ndarray (n,) int64, int)
        Shell of each vertex and the number of shells (`_vertex_components`).
    grid : tuple
        The other mesh's cell grid (`build_grid`).
    V, F : numpy.ndarray
        The other mesh, for a winding number where no vertex of a shell has a known status.
    """
    lo, h, n, status = grid[:4]
    ijk = np.floor((X - lo) * (1.0 / h)).astype(np.int64)
    off = np.any((ijk < 0) | (ijk >= n), axis=1)
    i, j, k = np.clip(ijk, 0, n - 1).T
    st = np.where(off, 0, status[(i * n[1] + j) * n[2] + k])
    label, count = shells
    if np.any(st == 1):
        return False
    known = np.zeros(count, bool)
    known[label[st == 0]] = True
    for shell in np.flatnonzero(~known):
        x = np.ascontiguousarray(X[np.argmax(label == shell)])
        if round(winding_number(x, V, F)) & 1:
            return False
    return True


#: The boolean fallback's error bound, in manifold3d tolerances times the surfaces' areas.
BOOLEAN_SLACK = 4.0
#: Its volumes below this many tolerances times the areas are rounding (8 units in the last
#: place of coordinates whose magnitude is 1e12 tolerances) and read 0.
BOOLEAN_ROUNDING = 8 * 2.0**-53 * 1e12
#: What `ExactIntersector.pose_sources` says, indexed by the kernel's result code.
POSE_SOURCES = np.empty(4, dtype="<U7")
POSE_SOURCES[[kp.OK, kp.CULLED, kp.DEGENERATE, kp.OVERFLOW]] = (
    "kernel",
    "culled",
    "boolean",
    "boolean",
)


class ExactIntersector:
    """Exact volumes of a fixed hand ∩ a rigidly moved object.

    Parameters
    ----------
    hand_links : list of (V (n, 3) float64, F (m, 3) int)
        Closed, outward-oriented link shells in the canonical frame; they may overlap.
    object_bodies : list of (V, F)
        One or more closed bodies, already placed at the grasp pose (canonical frame).
    broadphase : {"coal", "fcl", None}
        Library used to skip whole poses whose surfaces are apart (volume from a point test,
        no surface work). None tests every pose in full. Results do not depend on it.
    n_jobs : int
        Threads over poses (the kernels release the GIL); -1 uses every core. Results do not
        depend on it.
    **tuning
        ``hand_cell`` / ``object_cell`` (grid cell edge, same units as the meshes; default
        1/48 of the mesh's largest extent, about 0.1 canonical units for the Barrett hand),
        ``capacity`` (edge crossings per pose before falling back to a boolean, default 400000).

    Attributes
    ----------
    hand_volume : float
        Volume of the union of the links (cubed canonical units).
    object_volume : float
        Volume of the union of the object bodies.
    stats : dict
        Counters of the last `volumes` call (see `volumes`).
    """

    def __init__(
        self,
        hand_links: list[Mesh],
        object_bodies: list[Mesh],
        broadphase: str | None = "coal",
        n_jobs: int = 1,
        **tuning: Any,
    ):
        tuning = _check_options(broadphase, n_jobs, tuning)
        self.n_jobs = (os.cpu_count() or 1) if n_jobs == -1 else int(n_jobs)
        # Everything is in local coordinates about the centre of the hand's bounds, the unions
        # too (manifold3d's tolerance grows with the coordinates' magnitude), so that rounding
        # depends on the geometry's size, not on where it lies.
        self._origin = _bounds_centre(hand_links)
        self.hand_solid = union(_solids(_shifted(hand_links, self._origin), "hand link"))
        self.object_solid = union(_solids(_shifted(object_bodies, self._origin), "object body"))
        self.hand_volume = float(self.hand_solid.volume())
        self.object_volume = float(self.object_solid.volume())
        AV, AF = mesh_arrays(self.hand_solid)
        BV, BF = mesh_arrays(self.object_solid)
        # Cells scale with each mesh (units-free); 1/48 of the extent measured best on the
        # Barrett hand (0.1 canonical units).
        hand_cell = _grid_cell(AV, tuning.get("hand_cell"), "hand_cell")
        object_cell = _grid_cell(BV, tuning.get("object_cell"), "object_cell")
        # The hand's vertices numbered cell by cell: each "part" (grid cell holding vertices)
        # is then a range of vertices that the kernel can classify as a whole.
        AV, AF = cell_order(AV, AF, float(hand_cell))
        self._A = prepare_mesh(AV, AF)
        self._B = prepare_mesh(BV, BF)
        self._agrid = build_grid(AV, AF, float(hand_cell))
        self._bgrid = build_grid(BV, BF, float(object_cell))
        self._bchunks = _face_runs(BV, BF, kp.CHUNK)
        self._cap = int(tuning.get("capacity", 400_000))
        scale = max(np.abs(AV).max(), np.abs(BV).max(), 1e-300)
        self._tiny = 1e-30 * scale**4
        E, ET = self._A[2], self._A[3]
        AD, AN, AP, AW, WL = hand_tables(AV, AF, E, ET, self._tiny)
        T = AV[AF]
        ABB = np.ascontiguousarray(np.hstack([T.min(1), T.max(1)]))
        # Object faces: what each one's rounded D can cost (rigid motions keep it).
        BN = np.cross(BV[BF[:, 1]] - BV[BF[:, 0]], BV[BF[:, 2]] - BV[BF[:, 0]])
        self._bdc = np.ascontiguousarray(face_d_coefs(*face_conditioning(BV, BF, BN)))
        # The bounding boxes again in the order of the grid's cell lists, so that the search
        # reads them sequentially, each clipped to its cell (grown by the kernel's margin):
        # a crossing in that cell lies in the clipped box.
        CBB = self._cell_boxes(ABB)
        reps = self._cell_reps(AV)
        epart, wsum, split = self._part_edges(reps, (AW, WL))
        self._X = (
            AD, AN, ABB, AP, reps, AW, CBB, self._next_listed(),
            self._cell_patches(AV, AF, AN, ABB), epart, wsum, split,
        )  # fmt: skip
        # Surfaces farther apart than this are certainly disjoint whatever the BVH's rounding.
        self._gap = 1e-7 * scale
        self._cull = (
            None if broadphase is None else _PoseCull(broadphase, AV, AF, BV, BF, self._gap)
        )
        # Connected shells (vertex -> shell) of hand and object, for `kp.surfaces_cross`.
        self._shells = (
            _vertex_components(self._A[0], self._A[2]),
            _vertex_components(self._B[0], self._B[2]),
        )
        self.broadphase = broadphase
        self.tuning = {
            "hand_cell": self._agrid[1],
            "object_cell": self._bgrid[1],
            "capacity": self._cap,
        }
        self.stats: dict[str, Any] = {}
        self.pose_sources: np.ndarray = np.empty(0, dtype="<U7")
        self.volume_bounds: np.ndarray = np.empty(0)
        self._areas = float(self.hand_solid.surface_area() + self.object_solid.surface_area())

    def _cell_reps(self, AV: np.ndarray) -> np.ndarray:
        """The hand grid cells holding a vertex (the "parts") and the first vertex in each:
        shape (parts + 1, 2), columns (flat cell index, vertex index), in cell order; the
        vertices being numbered cell by cell, part k holds vertices ``reps[k, 1]`` to
        ``reps[k + 1, 1] - 1``. The last row is (-1, number of vertices)."""
        cells, first = np.unique(vertex_cells(AV, self._agrid[1]), return_index=True)
        if np.any(np.diff(first) <= 0):
            raise AssertionError("hand vertices are not numbered cell by cell")
        return np.ascontiguousarray(
            np.stack([np.append(cells, -1), np.append(first, len(AV))], axis=1).astype(np.int64)
        )

    def _part_edges(self, reps: np.ndarray, AW: tuple) -> tuple:
        """The hand's edges by part (see `kp._edge_sum`; ``AW`` the weights and their
        extended-precision values from `hand_tables`): the part of each edge (e,), -1 where
        its ends lie in two parts; the summed weight of each part's own edges and its error
        bound (parts, 2, `part_sums`); and,
        the hand's vertex adjacency being reordered here so that each vertex lists its edges
        to other parts first, where those end (vertices,)."""
        V, E, adj_start, adj_vert, adj_edge = (self._A[k] for k in (0, 2, 6, 7, 8))
        nparts = len(reps) - 1
        part = np.searchsorted(reps[:-1, 1], np.arange(len(V)), side="right") - 1
        same = part[E[:, 0]] == part[E[:, 1]]
        epart = np.where(same, part[E[:, 0]], -1).astype(np.int64)
        wsum = part_sums(epart, *AW, nparts)
        owner = np.repeat(np.arange(len(V)), np.diff(adj_start))
        order = np.lexsort((same[adj_edge], owner))
        self._A = (
            *self._A[:7],
            np.ascontiguousarray(adj_vert[order]),
            np.ascontiguousarray(adj_edge[order]),
        )
        split = adj_start[:-1] + np.bincount(owner[~same[adj_edge]], minlength=len(V))
        return epart, wsum, split.astype(np.int64)

    def _next_listed(self) -> np.ndarray:
        """Per axis d and hand grid cell: the index along d of the first cell at or after it,
        in its line of cells along d, that lists any face (the line's length if none)."""
        n, cs = self._agrid[2], self._agrid[4]
        listed = (cs[1:] > cs[:-1]).reshape(tuple(n))
        out = np.empty((3, listed.size), np.int64)
        for d in range(3):
            shape = [1, 1, 1]
            shape[d] = n[d]
            index = np.where(listed, np.arange(n[d]).reshape(shape), n[d])
            first = np.flip(np.minimum.accumulate(np.flip(index, d), axis=d), d)
            out[d] = first.reshape(-1)
        return out

    def _cell_corners(self) -> np.ndarray:
        """Lower corner of every hand grid cell, shape (cells, 3)."""
        lo, h, n = self._agrid[0], self._agrid[1], self._agrid[2]
        return lo + np.stack(np.unravel_index(np.arange(np.prod(n)), tuple(n)), axis=1) * h

    def _clip_to_cells(self, boxes: np.ndarray, corner: np.ndarray) -> None:
        """Clip boxes (k, 6: min xyz, max xyz) in place to the hand grid cells whose lower
        corners are ``corner`` (k, 3), grown by the kernel's margin (1e-9 of a cell)."""
        h = self._agrid[1]
        boxes[:, :3] = np.maximum(boxes[:, :3], corner - 1e-9 * h)
        boxes[:, 3:] = np.minimum(boxes[:, 3:], corner + h + 1e-9 * h)

    def _cell_boxes(self, ABB: np.ndarray) -> np.ndarray:
        """The hand faces' bounding boxes (m, 6) in the order of the grid's cell lists, each
        clipped to its cell grown by the kernel's margin: shape (listed, 6)."""
        cs, ct = self._agrid[4], self._agrid[5]
        out = np.ascontiguousarray(ABB[ct])
        self._clip_to_cells(out, np.repeat(self._cell_corners(), np.diff(cs), axis=0))
        return out

    def _cell_patches(self, AV, AF, AN, ABB) -> np.ndarray:
        """Per hand grid cell, bounds of the faces it lists, shape (cells, 11): a unit axis (the
        faces' area-weighted mean normal), the faces' extent along it (widened by 1e-9 of a cell
        each way) and their common bounding box clipped to the cell (min xyz, max xyz); see
        `_object_faces`."""
        h, cs, ct = self._agrid[1], self._agrid[4], self._agrid[5]
        ncell = len(cs) - 1
        cell = np.repeat(np.arange(ncell), np.diff(cs))
        axis = np.zeros((ncell, 3))
        np.add.at(axis, cell, AN[ct])
        norm = np.linalg.norm(axis, axis=1)
        good = norm > 1e-12 * max(1.0, norm.max())
        axis[good] /= norm[good, None]
        axis[~good] = (1.0, 0.0, 0.0)
        proj = np.einsum("qkj,qj->qk", AV[AF[ct]], axis[cell])
        out = np.zeros((ncell, 11))
        out[:, :3] = axis
        out[:, 3], out[:, 4] = np.inf, -np.inf
        np.minimum.at(out[:, 3], cell, proj.min(1))
        np.maximum.at(out[:, 4], cell, proj.max(1))
        out[:, 3] -= 1e-9 * h
        out[:, 4] += 1e-9 * h
        out[:, 5:8], out[:, 8:] = np.inf, -np.inf
        for k in range(3):
            np.minimum.at(out[:, 5 + k], cell, ABB[ct, k])
            np.maximum.at(out[:, 8 + k], cell, ABB[ct, 3 + k])
        # Clipped to the cell (grown by the kernel's margin): the part of the faces that the
        # cell holds lies in this box, which the search tests each object face against.
        self._clip_to_cells(out[:, 5:], self._cell_corners())
        return out

    def _shells_outside(self, pose: np.ndarray) -> bool:
        """For a pose whose surfaces are apart: whether every shell of each mesh lies outside
        the other (the volume is then 0, whatever the shells' nesting).

        Surfaces apart, each shell lies wholly inside or wholly outside the other mesh, so one
        vertex of known status decides it; a shell with none gets a winding number."""
        R, t = pose[:3, :3], pose[:3, 3]
        moved_object = self._B[0] @ R.T + t
        hand_in_object = (self._A[0] - t) @ R
        return _shells_outside(
            moved_object, self._shells[1], self._agrid, self._A[0], self._A[1]
        ) and _shells_outside(hand_in_object, self._shells[0], self._bgrid, self._B[0], self._B[1])

    def _chunk(self, poses: np.ndarray):
        n = len(poses)
        out = np.zeros(n)
        bounds = np.zeros(n)
        codes = np.zeros(n, np.int64)
        stats = np.zeros((n, kp.N_STATS), np.int64)
        todo = np.ones(n, bool)
        if self._cull is not None:
            # The BVH query costs more than the kernel where the surfaces plainly cross; ask
            # it only about the other poses.
            crossing = kp.surfaces_cross(
                poses, self._A[0], *self._shells[0], self._agrid, self._B[0], *self._shells[1],
                self._bgrid,
            )  # fmt: skip
            # Only poses whose volume is exactly 0 are culled: a shell inside the other mesh is
            # left to the kernel, so culling cannot change a single bit of any result.
            for i in np.flatnonzero(~crossing):
                p = poses[i]
                if self._cull.far(p) and self._shells_outside(p):
                    codes[i] = kp.CULLED
                    todo[i] = False
        idx = np.flatnonzero(todo)
        if len(idx):
            o = np.zeros(len(idx))
            b = np.zeros(len(idx))
            c = np.zeros(len(idx), np.int64)
            st = np.zeros((len(idx), kp.N_STATS), np.int64)
            kp.pose_volumes(
                np.ascontiguousarray(poses[idx]),
                self._A,
                self._X,
                self._agrid,
                self._B,
                self._bchunks,
                self._bgrid,
                self._bdc,
                self._tiny,
                self._cap,
                o,
                b,
                c,
                st,
            )
            out[idx], bounds[idx], codes[idx], stats[idx] = o, b, c, st
        for i in np.flatnonzero((codes == kp.DEGENERATE) | (codes == kp.OVERFLOW)):
            out[i], bounds[i] = self._boolean(poses[i])
        return out, bounds, codes, stats

    def _boolean(self, pose: np.ndarray) -> tuple[float, float]:
        """The fallback: manifold3d's volume of hand ∩ moved object, and its error bound.

        manifold3d merges what lies within its tolerance (1e-12 of the coordinates'
        magnitude), which moves the surfaces by up to that much: the bound is
        `BOOLEAN_SLACK` times the tolerance times both surfaces' areas. A volume below the
        rounding of coordinates of that magnitude over those areas (`BOOLEAN_ROUNDING`) is 0:
        touching faces can leave such crumbs, and slight overlaps a tiny negative volume.
        """
        moved = self.object_solid.transform(pose[:3, :])
        volume = (self.hand_solid ^ moved).volume()
        tolerance = max(self.hand_solid.get_tolerance(), moved.get_tolerance())
        bound = BOOLEAN_SLACK * tolerance * self._areas
        crumbs = BOOLEAN_ROUNDING * tolerance * self._areas
        return (0.0 if volume <= crumbs else float(volume)), bound

    def volumes(self, poses: np.ndarray) -> np.ndarray:
        """Exact intersection volume for each pose.

        Parameters
        ----------
        poses : numpy.ndarray, shape (..., 4, 4)
            Rigid transforms of the object: vertex ``x`` moves to ``R @ x + t``.

        Returns
        -------
        numpy.ndarray, shape poses.shape[:-2], float64
            Volumes in cubed canonical units. Afterwards `stats` holds ``poses``,
            ``poses_repeated`` (equal to an earlier pose to rounding, see `repeated_poses`:
            computed once), ``poses_culled`` (skipped by the broad phase), ``poses_boolean``
            (recomputed with a manifold3d boolean: uncertain sign or overflow), ``parts``
            (hand grid cells),
            ``parts_culled`` / ``parts_inside`` / ``parts_clipped`` (summed over poses:
            cells away from the object's surface and outside / inside it, cells it crosses),
            ``pairs_tested`` / ``pairs_crossing`` (face pairs) and ``seconds``; and
            `pose_sources` (same shape as the result) says where each volume came from:
            ``"kernel"``, ``"culled"`` (exactly 0, see ``docs/exact-backend.md``) or
            ``"boolean"`` (the manifold3d fallback: an exact coincidence the kernel's signs
            cannot certify, or a full crossing buffer); `volume_bounds` (same shape) bounds
            each volume's error: ``|volume - true volume| <= bound``, certified for the
            kernel's poses, 0 for culled ones, manifold3d's tolerance times both areas for
            the boolean's.
        """
        poses = check_poses(poses)
        t0 = time.perf_counter()
        # The same motions about the local origin c: x -> R x + (R c + t - c); repeats are
        # found there, so that their tolerance scales with the local geometry.
        every = np.array(poses.reshape(-1, 4, 4))
        every[:, :3, 3] += every[:, :3, :3] @ self._origin - self._origin
        rep = repeated_poses(every)
        uniq, back = np.unique(rep, return_inverse=True)
        flat = np.ascontiguousarray(every[uniq])
        n = len(flat)
        jobs = max(1, min(self.n_jobs, n))
        if jobs == 1:
            out, bounds, codes, stats = self._chunk(flat)
        else:
            # Interleaved chunks balance poses of different cost across threads.
            parts = [np.arange(k, n, jobs) for k in range(jobs)]
            with ThreadPoolExecutor(jobs) as ex:
                res = list(ex.map(lambda ix: self._chunk(flat[ix]), parts))
            out = np.empty(n)
            bounds = np.empty(n)
            codes = np.empty(n, np.int64)
            stats = np.empty((n, kp.N_STATS), np.int64)
            for ix, (o, b, c, s) in zip(parts, res, strict=True):
                out[ix], bounds[ix], codes[ix], stats[ix] = o, b, c, s
        pairs = stats[:, [kp.STAT_PAIRS, kp.STAT_CROSSING]].sum(0)
        out, bounds, codes, stats = out[back], bounds[back], codes[back], stats[back]
        tot = stats.sum(0)
        self.stats = {
            "poses": len(every),
            "poses_repeated": len(every) - n,
            "poses_culled": int((codes == kp.CULLED).sum()),
            "poses_boolean": int(((codes == kp.DEGENERATE) | (codes == kp.OVERFLOW)).sum()),
            "parts": len(self._X[4]) - 1,
            "parts_culled": int(tot[kp.STAT_CELLS_OUTSIDE]),
            "parts_inside": int(tot[kp.STAT_CELLS_INSIDE]),
            "parts_clipped": int(tot[kp.STAT_CELLS_TOUCHED]),
            "pairs_tested": int(pairs[0]),
            "pairs_crossing": int(pairs[1]),
            "seconds": time.perf_counter() - t0,
        }
        self.pose_sources = POSE_SOURCES[codes].reshape(poses.shape[:-2])
        self.volume_bounds = bounds.reshape(poses.shape[:-2])
        return out.reshape(poses.shape[:-2])


#: Poses whose matrices differ by at most this many units in the last place of their largest
#: entry are one pose (see `repeated_poses`).
SAME_POSE_ULPS = 16


def repeated_poses(poses: np.ndarray) -> np.ndarray:
    """For each pose, the index of the first pose equal to it to rounding.

    Two poses are equal to rounding when no entry of their matrices differs by more than
    `SAME_POSE_ULPS` units in the last place of the larger one's largest entry (about 4e-15
    for a rotation and a translation of length up to 1). Moving the object's vertices with
    either pose rounds them by more than the two poses differ, so their exact volumes differ by
    no more than the rounding the kernel already makes. Such repeats are common: a rotation
    by ``a`` about ``w`` is a rotation by ``-a`` about ``-w``, and the balanced preset's four
    axes include both poles, so 1,080 of its 4,266 poses repeat another one to rounding.

    Parameters
    ----------
    poses : numpy.ndarray, shape (n, 4, 4)

    Returns
    -------
    numpy.ndarray, shape (n,), int64
        ``rep[i] <= i``; ``rep[i] == i`` for the first pose of each group.
    """
    n = len(poses)
    rows = poses[:, :3, :].reshape(n, 12)
    # Group on a grid far coarser than the tolerance, then keep only true neighbours: a pair
    # split by a grid line is merely computed twice.
    _, first, inv = np.unique(
        np.round(rows * 2.0**36), axis=0, return_index=True, return_inverse=True
    )
    rep = first[inv.reshape(-1)]
    scale = np.maximum(np.abs(rows).max(1), np.abs(rows[rep]).max(1))
    tol = SAME_POSE_ULPS * np.spacing(np.maximum(scale, 1.0))
    same = np.abs(rows - rows[rep]).max(1) <= tol
    return np.where(same, rep, np.arange(n)).astype(np.int64)


class ExactBackend(Backend):
    """Exact hand ∩ moved object volumes (manifold3d unions + certified surface integrals).

    Parameters
    ----------
    broadphase : {"coal", "fcl", None}
        Library that skips whole poses whose surfaces are apart; None tests every pose in
        full. The volumes do not depend on it.
    n_jobs : int
        Threads over poses (-1: all cores). The volumes do not depend on it.
    **tuning
        Passed to `ExactIntersector` (``hand_cell``, ``object_cell``, ``capacity``).
    """

    name = "exact"
    #: Built intersectors kept per grasp geometry (least recently used dropped first).
    cache_size = 4

    def __init__(self, broadphase: str | None = "coal", n_jobs: int = 1, **tuning: Any):
        tuning = _check_options(broadphase, n_jobs, tuning)
        if broadphase == "coal":
            require("coal", "the exact backend's coal broad phase", "coal", "exact")
        elif broadphase == "fcl":
            require("fcl", "the exact backend's fcl broad phase", "python-fcl", "exact")
        self.broadphase = broadphase
        self.n_jobs = int(n_jobs)
        self.tuning = dict(tuning)
        self._cache: dict[str, ExactIntersector] = {}

    @property
    def params(self) -> dict[str, Any]:
        """Parameters (the volumes depend on none of them; recorded for provenance)."""
        return {"broadphase": self.broadphase, "n_jobs": self.n_jobs, **self.tuning}

    def intersector(self, grasp: Grasp) -> ExactIntersector:
        """The `ExactIntersector` of a grasp, built once per `grasp.geometry_key`."""
        key = grasp.geometry_key
        hit = self._cache.pop(key, None)
        if hit is None:
            hit = ExactIntersector(
                grasp.canonical_hand_links(),
                grasp.canonical_object_bodies(),
                broadphase=self.broadphase,
                n_jobs=self.n_jobs,
                **self.tuning,
            )
        self._cache[key] = hit
        while len(self._cache) > self.cache_size:
            self._cache.pop(next(iter(self._cache)))
        return hit

    def volumes(self, grasp: Grasp, poses: np.ndarray) -> np.ndarray:
        """Exact volume of hand ∩ moved object per pose, in cubed canonical units."""
        return self.intersector(grasp).volumes(check_poses(poses))
