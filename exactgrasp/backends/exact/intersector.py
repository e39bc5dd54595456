"""`ExactIntersector`, the exact backend's array-level core: the true volume of hand ∩ moved
object, pose by pose, with a certified error bound.

The method (see ``docs/exact-backend.md``):

1. Once per grasp, the hand links and the object bodies are each merged into one solid with a
   manifold3d ``Mesh64`` union (overlaps counted once), and a cell grid and the kernel's tables
   are built over each (`grids`, `prepare`), all in local coordinates.
2. Per pose, the volume is a sum of local surface-integral terms (`_kernel.pose_volumes`): edges
   of either mesh lying inside the other, and pairs of crossing faces. Only faces near the
   other surface are ever tested; everything else is classified by its grid cell.
3. Every geometric decision is an orientation sign with a certified error bound; a pose where
   any sign is uncertain (an exact coincidence of the surfaces) takes the volume's limit along
   a small translation from certified volumes nearby (`extrapolate`), or is refused.
4. Where asked (`volume_moments`), the same pass also sums each link's surface moments, which
   give the volume's derivatives (`moments`, `moment_layout`, ``_moment_sums.pxd``).

Long because one class holds the build, the pose loop over threads and the fallback, each table
and counter documented where it is filled. Options follow `options.check_options`.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed
from typing import Any

import numpy as np

from exactgrasp.backends import defaults
from exactgrasp.backends._builds import fastest_build
from exactgrasp.backends.base import repeat_error, repeated_poses, resolve_jobs
from exactgrasp.backends.exact import moment_entries as entries_of
from exactgrasp.backends.exact.arranged import (
    ArrangedHand,
    arranged_moments,
    scene_rounding,
    shift_rounding,
)
from exactgrasp.backends.exact.culling import (
    bounding_sphere,
    bounds_apart,
    crossing_poses,
    culled_poses,
    shell_labels,
    shell_samples,
    worth_building,
)
from exactgrasp.backends.exact.extrapolate import extrapolated
from exactgrasp.backends.exact.grids import build_grid, cell_order, grid_cell, morton_order
from exactgrasp.backends.exact.intersection import POSE_SOURCES, Intersection, call_stats
from exactgrasp.backends.exact.moment_layout import empty_moment_tables, moment_layout
from exactgrasp.backends.exact.moments import face_sources, original_ids, shift_moments
from exactgrasp.backends.exact.options import ExactOptions, check_options
from exactgrasp.backends.exact.prepare import (
    bounds_centre,
    hand_tables,
    object_tables,
    prepare_mesh,
    shifted,
)
from exactgrasp.backends.exact.reference import Mesh, solids
from exactgrasp.backends.exact.tables import (
    ARRANGED,
    CULLED,
    DEGENERATE,
    N_STATS,
    OVERFLOW,
    STAT_CROSSING,
    STAT_PAIRS,
)
from exactgrasp.backends.exact.tolerances import CULL_GAP, LENGTH_FLOOR, TINY_FACE
from exactgrasp.geometry.bvh import MeshPair
from exactgrasp.geometry.manifold import mesh_arrays, union_solids

#: The exact kernel (``_kernel.pyx``) in the build this CPU runs fastest (`fastest_build`).
pose_volumes = fastest_build("exactgrasp.backends.exact._kernel").pose_volumes
#: Pieces per thread the distinct poses of a call are cut into (runs of neighbouring poses,
#: which read the same rows of the tables: interleaved sets ran 5-15 % slower; taken by
#: whichever thread is free): they balance the threads and pace the progress callback.
PIECES_PER_THREAD = 16
#: Fewest poses in a piece (a kernel call has a fixed cost of its own).
PIECE_POSES = 32
#: The moment tables of a call that wants volumes only.
EMPTY_MOMENTS = empty_moment_tables()


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
    n_jobs : int or None
        Threads over poses (the kernels release the GIL): None (default) every core, or what
        `backends.base.thread_limit` sets where a batch worker runs (read at each `volumes`
        call); -1 every core. Results do not depend on it.
    **tuning
        ``hand_cell`` / ``object_cell`` (grid cell edge, same units as the meshes; default
        1/48 of the mesh's largest extent, about 0.1 canonical units for the Barrett hand),
        ``capacity`` (edge crossings per pose before the pose is run again with a larger
        buffer, default 400000).
    options : ExactOptions, optional
        The options `options.check_options` already checked (an `ExactBackend`'s), used
        instead of ``broadphase``, ``n_jobs`` and ``tuning``, not checked again.
    faces : bool
        Moments per face instead of per link (`volume_moments`): one row per face of the
        hand's union, then one per face of the object's, each face of either union lying in
        the input face `face_sources` names (manifold3d face ids, `moments.face_sources`).

    Attributes
    ----------
    hand_volume, object_volume : float
        Volumes of the union of the links and of the object bodies (cubed canonical units).
    origin : numpy.ndarray, shape (3,)
        The local origin (centre of the hand's bounds) every table below is relative to.
    hand_solid, object_solid : manifold3d.Manifold
        The unions, in local coordinates (their areas, the broad phase, the moments' links).
    hand_mesh, object_mesh : tables.MeshTables
        The unions' meshes; the hand's vertices numbered cell by cell.
    hand_grid, object_grid : tables.CellGrid
    hand_tables : tables.HandTables
    object_tables : tables.ObjectTables
    shells : tuple
        (labels (n,) int64, count) of the hand's and of the object's connected shells.
    samples : tuple
        Indices of up to 8 vertices of each shell, hand's and object's (`culling.shell_samples`):
        what culling looks up once the surfaces are known apart.
    capacity : int
        Edge crossings recorded per pose and mesh before the pose is run again with a larger
        buffer (`extrapolate`).
    tiny : float
        Faces with ``|N|² <= tiny`` get ``D = 0``.
    gap : float
        Surfaces farther apart than this are certainly disjoint (whole-pose culling).
    hand_box : (numpy.ndarray (3,), numpy.ndarray (3,))
        Corners of the hand mesh's bounding box, local coordinates.
    object_sphere : (numpy.ndarray (3,), float)
        A sphere around the object mesh (`culling.bounding_sphere`): with the box, what the
        broad phase's first test (`culling.bounds_apart`) reads.
    cull : geometry.bvh.MeshPair or None
        The broad phase's BVHs: None until a `volumes` call has enough poses the kernel's own
        test leaves open (`culling.worth_building`), and always None without a broad phase.
        Culling never changes a result.
    areas : float
        Both unions' surface areas, summed (the bounds of `extrapolate` and of
        `gradients.boolean_volume_moments`). ``arranged``: the exact fallback's hand.
    face_sources : (numpy.ndarray (m, 2), numpy.ndarray (m_o, 2)) or None
        With ``faces``: the (link, input face) of each hand face in the kernel's order, and
        the (body, face) of each object face. ``moment_rows``: the moments' rows per pose.
        ``moment_tables``, ``vertex_moment_tables``: the kernel's, the second (``faces``; else
        None) with a marker per hand vertex (`moment_layout`).
    """

    def __init__(
        self,
        hand_links: list[Mesh],
        object_bodies: list[Mesh],
        broadphase: str | None = defaults.EXACT_BROADPHASE,
        n_jobs: int | None = defaults.EXACT_N_JOBS,
        *,
        options: ExactOptions | None = None,
        faces: bool = False,
        **tuning: Any,
    ):
        if options is None:
            options = check_options(broadphase, n_jobs, tuning, type(self).__name__)
        broadphase, tuning = options.broadphase, options.tuning
        self.n_jobs = options.n_jobs
        # Everything is in local coordinates about the centre of the hand's bounds, the unions
        # too (manifold3d's tolerance grows with the coordinates' magnitude), so that rounding
        # depends on the geometry's size, not on where it lies.
        self.origin = bounds_centre(hand_links)
        self.shift_error = max(
            shift_rounding(hand_links, self.origin), shift_rounding(object_bodies, self.origin)
        )
        # Each link its own manifold3d original (a union's faces say their link, `moments`);
        # with ``faces`` each triangle's face id is its index, which a union's faces keep.
        links = solids(shifted(hand_links, self.origin), "hand link", faces)
        links = links if faces else [s.as_original() for s in links]
        self.link_ids = original_ids(links)
        self.hand_solid = union_solids(links)
        bodies = solids(shifted(object_bodies, self.origin), "object body", faces)
        self.object_solid = union_solids(bodies)
        self.hand_volume = float(self.hand_solid.volume())
        self.object_volume = float(self.object_solid.volume())
        AV, AF = mesh_arrays(self.hand_solid)
        # The link of each face, in the order `cell_order` gives the faces.
        hand_src = face_sources(self.hand_solid, self.link_ids)[morton_order(AV[AF].mean(1))]
        BV, BF = mesh_arrays(self.object_solid)
        # Cells scale with each mesh (units-free); see defaults.EXACT_CELLS_PER_EXTENT.
        hand_cell = grid_cell(AV, tuning.get("hand_cell"), "hand_cell")
        object_cell = grid_cell(BV, tuning.get("object_cell"), "object_cell")
        # The hand's vertices numbered cell by cell: each "part" (grid cell holding vertices)
        # is then a range of vertices that the kernel can classify as a whole.
        AV, AF = cell_order(AV, AF, float(hand_cell))
        self.hand_grid = build_grid(AV, AF, float(hand_cell))
        self.object_grid = build_grid(BV, BF, float(object_cell))
        self.capacity = int(tuning.get("capacity", defaults.EXACT_CAPACITY))
        scale = max(np.abs(AV).max(), np.abs(BV).max(), LENGTH_FLOOR)
        #: The scene's size in local coordinates (the extrapolation's step is relative to it).
        self.size = float(scale)
        self.tiny = TINY_FACE * scale**4
        self.hand_mesh, self.hand_tables = hand_tables(
            prepare_mesh(AV, AF), self.hand_grid, self.tiny
        )
        self.object_mesh = prepare_mesh(BV, BF)
        object_src = face_sources(self.object_solid, original_ids(bodies)) if faces else None
        layout = moment_layout(
            self.hand_mesh, self.hand_tables, hand_src, len(self.link_ids), object_src,
            self.object_mesh,
        )  # fmt: skip
        self.face_sources, self.moment_rows, self.moment_tables, self.vertex_moment_tables = layout
        self.object_tables = object_tables(self.object_mesh)
        # Surfaces farther apart than this are certainly disjoint whatever the BVH's rounding.
        self.gap = CULL_GAP * scale
        self.feature = f"the exact backend's {broadphase} broad phase"
        # Poses that move the object's bounding sphere away from the hand's bounding box are
        # culled without the kernel or a BVH (`culling.bounds_apart`).
        self.hand_box = (self.hand_mesh.vertices.min(axis=0), self.hand_mesh.vertices.max(axis=0))
        self.object_sphere = bounding_sphere(self.object_mesh.vertices)
        # Built on first need (`broad_phase`): it costs more than it saves on a few poses.
        self.cull: MeshPair | None = None
        self._cull_lock = threading.Lock()
        # Connected shells (vertex -> shell) of hand and object, for the culling.
        self.shells = (
            shell_labels(self.hand_mesh.vertices, self.hand_mesh.edges),
            shell_labels(self.object_mesh.vertices, self.object_mesh.edges),
        )
        # Once the surfaces are known apart, a few vertices of each shell decide it.
        self.samples = (shell_samples(self.shells[0]), shell_samples(self.shells[1]))
        self.broadphase = broadphase
        self.tuning = {
            "hand_cell": self.hand_grid.cell,
            "object_cell": self.object_grid.cell,
            "capacity": self.capacity,
        }
        self.areas = float(self.hand_solid.surface_area() + self.object_solid.surface_area())
        self.arranged = ArrangedHand(self.hand_mesh.vertices, self.hand_mesh.faces)

    def broad_phase(self, poses: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
        """What the broad phase knows of poses (k, 4, 4; local coordinates) before the kernel.

        Returns
        -------
        apart : numpy.ndarray, shape (k,), bool, or None
            Poses that move the object's bounding sphere away from the hand's bounding box
            (`culling.bounds_apart`): volume exactly 0, culled. None without a broad phase.
        crossing : numpy.ndarray, shape (k,), bool, or None
            `culling.crossing_poses` of the other poses (True where ``apart``: decided), with
            the BVHs built; None when they are not built (too few open poses for them,
            `culling.worth_building`, and not built before) or without a broad phase.
        """
        if self.broadphase is None or not len(poses):
            return None, None
        apart = bounds_apart(poses, self.hand_box, self.object_sphere, self.gap)
        near = np.flatnonzero(~apart)
        triangles = len(self.hand_mesh.faces) + len(self.object_mesh.faces)
        if self.cull is None and not worth_building(len(near), triangles):
            return apart, None  # too few even if every pose were open: skip the test too
        crossing = np.ones(len(poses), bool)
        crossing[near] = crossing_poses(
            poses[near], self.hand_mesh, self.hand_grid, self.object_mesh, self.object_grid,
            self.shells,
        )  # fmt: skip
        if self.cull is None:
            if not worth_building(int(np.count_nonzero(~crossing)), triangles):
                return apart, None
            with self._cull_lock:
                if self.cull is None:
                    self.cull = MeshPair(
                        self.broadphase, self.hand_mesh.vertices, self.hand_mesh.faces,
                        self.object_mesh.vertices, self.object_mesh.faces, self.gap,
                        self.feature,
                    )  # fmt: skip
        return apart, crossing

    def _chunk(
        self,
        poses: np.ndarray,
        apart: np.ndarray | None = None,
        crossing: np.ndarray | None = None,
        with_moments: bool = False,
        tables=None,
        sums=None,
    ):
        """Volumes, bounds, codes, statistics and `moment_entries.MomentEntries` (none without
        ``with_moments``; by ``tables``, `moment_tables` where None) of poses (k, 4, 4) in
        local coordinates; ``apart``, ``crossing`` (k,) from `broad_phase` cull, None does not;
        ``sums`` (tables, out_a, out_b, rows (k,)): as `_kernel.pose_volumes`'s."""
        n = len(poses)
        links = self.moment_rows if with_moments else 0
        tables = self.moment_tables if tables is None else tables
        moments = entries_of.empty(n)
        out = np.zeros(n)
        bounds = np.zeros(n)
        codes = np.zeros(n, np.int64)
        stats = np.zeros((n, N_STATS), np.int64)
        todo = np.ones(n, bool)
        if apart is not None:
            codes[apart] = CULLED
            todo[apart] = False
        if crossing is not None and self.cull is not None:
            culled = culled_poses(
                poses, self.cull, self.hand_mesh, self.hand_grid, self.object_mesh,
                self.object_grid, self.shells, self.samples, crossing,
            )  # fmt: skip
            codes[culled] = CULLED
            todo[culled] = False
        idx = np.flatnonzero(todo)
        if len(idx):
            out[idx], bounds[idx], codes[idx], stats[idx], found = self._kernel(
                poses[idx], self.capacity, with_moments, tables,
                None if sums is None else (*sums[:3], sums[3][idx]),
            )  # fmt: skip
            moments = entries_of.placed(found, idx, n)

        def samples(p: np.ndarray, capacity: int):
            o, b, c, _, mo = self._kernel(p, capacity, with_moments, tables)
            return o, b, c, entries_of.dense(mo, links, tables)

        limits = {}
        for i in np.flatnonzero((codes == DEGENERATE) | (codes == OVERFLOW)):
            out[i], bounds[i], limits[i] = extrapolated(
                samples, poses[i], int(codes[i]), self.size, self.areas, self.capacity, links
            )
        # A volume read within its bound of zero (a sliver under the bound, or none): exact.
        for i in np.flatnonzero((codes != CULLED) & (out == 0.0) & (bounds > 0.0)):
            moved_by = scene_rounding(poses[i], self.shift_error, self.size, self.origin)
            out[i], bounds[i], found = self.arranged.volume(
                self.object_mesh.vertices, self.object_mesh.faces, poses[i], moved_by, self.areas
            )
            codes[i] = ARRANGED
            if links:
                limits[i] = arranged_moments(
                    found, len(self.hand_mesh.faces), self.moment_tables, links, poses[i]
                )
        return out, bounds, codes, stats, entries_of.appended(moments, limits)

    def _kernel(self, poses, capacity: int, with_moments: bool, tables=None, sums=None):
        """The kernel on poses (k, 4, 4) in local coordinates: volumes, bounds, codes,
        statistics and `moment_entries.MomentEntries` (none without ``with_moments``, nor
        with ``sums``; by ``tables`` and ``sums`` as `_chunk`'s)."""
        mom = self.moment_tables if tables is None else tables
        k = len(poses)
        o, b, c = np.zeros(k), np.zeros(k), np.zeros(k, np.int64)
        st, start = np.zeros((k, N_STATS), np.int64), np.zeros(k + 1, np.int64)
        rows, values = pose_volumes(
            np.ascontiguousarray(poses), self.hand_mesh, self.hand_tables, self.hand_grid,
            self.object_mesh, self.object_tables, self.object_grid, self.tiny, capacity,
            o, b, c, st, mom if with_moments else EMPTY_MOMENTS, start, sums,
        )  # fmt: skip
        return o, b, c, st, entries_of.from_kernel(start, rows, values)

    def volumes(
        self, poses: np.ndarray, progress: Callable[[int], Any] | None = None
    ) -> np.ndarray:
        """Exact intersection volume for each pose: `intersect`'s volumes alone.

        Returns
        -------
        numpy.ndarray, shape poses.shape[:-2], float64
            Volumes in cubed canonical units.
        """
        return self.intersect(poses, progress).volumes

    def intersect(
        self, poses: np.ndarray, progress: Callable[[int], Any] | None = None
    ) -> Intersection:
        """Exact intersection volume for each pose, with its bound, its source and counters.

        Parameters
        ----------
        poses : numpy.ndarray, shape (..., 4, 4), float64
            Rigid transforms of the object: vertex ``x`` moves to ``R @ x + t``, as
            `exactgrasp.backends.base.check_poses` returns them. Not checked again here: the
            public entries (`ExactBackend`'s methods, `exactgrasp.overlap`) check them once.
        progress : callable, optional
            Called in the calling thread with the number of poses finished since its last
            call, as each piece of the work ends (the counts add up to the number of poses).

        Returns
        -------
        Intersection
            ``volumes`` in cubed canonical units; ``stats`` holds ``poses``,
            ``poses_repeated`` (equal to an earlier pose to rounding, see `repeated_poses`:
            computed once), ``poses_culled`` (skipped by the broad phase), ``poses_limit``
            (an uncertain sign or a full buffer: the limit of `extrapolate`), ``parts``
            (hand grid cells), ``threads`` (threads run),
            ``parts_culled`` / ``parts_inside`` / ``parts_clipped`` (summed over poses:
            cells away from the object's surface and outside / inside it, cells it crosses),
            ``pairs_tested`` / ``pairs_crossing`` (face pairs) and ``seconds``;
            ``pose_sources`` (same shape as the volumes) says where each volume came from:
            ``"kernel"``, ``"culled"`` (exactly 0, see ``docs/exact-backend.md``) or
            ``"limit"`` (an exact coincidence the kernel's signs cannot certify, or a full
            crossing buffer: the limit along a small translation of certified kernel volumes,
            `extrapolate`); ``volume_bounds`` (same shape) bounds each volume's error:
            ``|volume - true volume| <= bound``, certified for the kernel's and the limit's
            poses, 0 for culled ones. A pose none of these can certify raises
            `UncertainPoseError`.
        """
        return self._run(poses, progress, False)[0]

    def volume_moments(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Volumes as `volumes`, and per link ``(∫ n dA, ∫ x × n dA)`` of its boundary inside
        the moved object, in the input frame: shapes ``poses.shape[:-2]`` and
        ``poses.shape[:-2] + (L, 6)`` (L links, in input order; zero where the volume reads
        0). The derivatives they give are in `moments`. With ``faces``, one row per face
        (`face_sources`), an object face's in the object's own frame (before the pose)."""
        result, entries = self._run(poses, None, True)
        moments = entries_of.dense(entries, self.moment_rows, self.moment_tables)
        flat = moments.reshape(-1, 6)  # rows with F = 0 need no shift
        live = np.flatnonzero(flat[:, :3].any(axis=1))
        flat[live] = shift_moments(flat[live], self.origin)
        return result.volumes, moments.reshape(*poses.shape[:-2], -1, 6)

    def moment_entries(self, poses: np.ndarray, tables=None, sums: tuple | None = None):
        """Volumes as `volumes` (k,) of poses (k, 4, 4), and the moments as
        `moment_entries.MomentEntries` of the k poses, in local coordinates (about `origin`,
        the object moved by ``x -> R x + (R c + t - c)``, ``c`` the origin), by ``tables``
        (`moment_tables` where None, or `vertex_moment_tables`). With ``sums``
        (`face_gradients.VertexTables` of ``tables``, out_a (k, n_a, 3), out_b (k, n_b, 3)):
        summed onto the vertices into out_a and out_b instead, every row written (entries
        are left only for the poses summed apart, `moment_entries.finish_sums`)."""
        result, entries = self._run(poses, None, True, tables, sums)
        return result.volumes, entries

    def _run(self, poses, progress, with_moments, tables=None, sums=None):
        """`intersect`'s result, and the `moment_entries.MomentEntries` of the poses, flat
        (local coordinates; none without ``with_moments``; by ``tables``, as `_chunk`);
        ``sums`` (tables, out_a, out_b): summed onto the vertices there, every row written."""
        t0 = time.perf_counter()
        # The same motions about the local origin c: x -> R x + (R c + t - c); repeats are
        # found there, so that their tolerance scales with the local geometry.
        every = np.array(poses.reshape(-1, 4, 4))
        every[:, :3, 3] += every[:, :3, :3] @ self.origin - self.origin
        rep = repeated_poses(every)
        uniq, back = np.unique(rep, return_inverse=True)
        flat = np.ascontiguousarray(every[uniq])
        n = len(flat)
        apart, crossing = self.broad_phase(flat)
        jobs = max(1, min(resolve_jobs(self.n_jobs), n))
        # One piece without threads or progress; else runs of neighbouring poses.
        pieces = 1
        if jobs > 1 or progress is not None:
            pieces = max(jobs, min(jobs * PIECES_PER_THREAD, n // PIECE_POSES))
        parts = np.array_split(np.arange(n), pieces)
        weight = np.bincount(back.reshape(-1), minlength=n)
        out = np.empty(n)
        bounds = np.empty(n)
        codes = np.empty(n, np.int64)
        stats = np.empty((n, N_STATS), np.int64)
        pieces = []

        def run(ix: np.ndarray):
            return self._chunk(
                flat[ix],
                None if apart is None else apart[ix],
                None if crossing is None else crossing[ix],
                with_moments,
                tables,
                None if sums is None else (*sums, uniq[ix]),
            )

        def store(ix: np.ndarray, result: tuple) -> None:
            out[ix], bounds[ix], codes[ix], stats[ix], entries = result
            pieces.append((ix, entries))
            if progress is not None:
                progress(int(weight[ix].sum()))

        if jobs == 1:
            for ix in parts:
                store(ix, run(ix))
        else:
            with ThreadPoolExecutor(jobs) as ex:
                futures = {ex.submit(run, ix): k for k, ix in enumerate(parts)}
                for future in as_completed(futures):
                    store(parts[futures[future]], future.result())
        pairs = stats[:, [STAT_PAIRS, STAT_CROSSING]].sum(0)
        entries = entries_of.concatenated(pieces, n)
        if sums is not None:
            entries_of.finish_sums(sums, entries, codes, uniq, back.reshape(-1))
        out, bounds, codes, stats = out[back], bounds[back], codes[back], stats[back]
        bounds += repeat_error(every, flat[back], self.areas, self.size)
        stats_out = call_stats(len(every), n, codes, stats, pairs, self.hand_tables, jobs, t0)
        shape = poses.shape[:-2]
        sources = POSE_SOURCES[codes].reshape(shape)
        result = Intersection(out.reshape(shape), bounds.reshape(shape), sources, stats_out)
        return result, entries_of.taken(entries, back.reshape(-1))
