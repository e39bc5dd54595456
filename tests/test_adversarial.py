"""Adversarial property tests of the exact backend (`ExactIntersector`).

The exact backend promises the true volume of hand ∩ moved object for every pose. These tests
feed it inputs it was not designed around and compare with references that share none of its
code:

* exact rational arithmetic (`fractions.Fraction`) for solids made of axis-aligned boxes moved
  by signed permutations: the moved vertices are then computed without any rounding beyond the
  translation's, and the reference is the true volume of exactly the meshes the backend sees
  (manifold3d reads boxes overlapping by 1e-14 as disjoint, so it cannot judge such poses);
* manifold3d booleans on the resolved solids (each shell its own `Manifold`, outward shells
  united, cavities subtracted) for curved and non-convex solids;
* `scipy.spatial.HalfspaceIntersection` for convex pairs.

The generators (`SCENES`) are plain functions of a numpy generator; hypothesis draws their
seeds. ``benchmarks/fuzz_exact.py`` runs the same generators on many more cases.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass, field, replace
from fractions import Fraction

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection
from scipy.spatial.transform import Rotation

from exactgrasp.backends.exact import ExactIntersector, Intersection, plain_error

# ---------------------------------------------------------------------------------------------
# Meshes
# ---------------------------------------------------------------------------------------------

Mesh = tuple[np.ndarray, np.ndarray]


def signed_volume(V: np.ndarray, F: np.ndarray) -> float:
    T = V[F]
    return float(np.einsum("ij,ij->i", T[:, 0], np.cross(T[:, 1], T[:, 2])).sum() / 6.0)


def outward(V: np.ndarray, F: np.ndarray) -> Mesh:
    """The mesh with its faces flipped if its signed volume is negative."""
    F = np.asarray(F, np.int64)
    return (np.asarray(V, float), F if signed_volume(V, F) > 0 else F[:, ::-1].copy())


def box_mesh(lo, hi, n: int = 1) -> Mesh:
    """Closed, outward box with every face split into an n x n grid of quads."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    index: dict[tuple[int, int, int], int] = {}
    points = []
    faces = []

    def vid(i, j, k):
        key = (i, j, k)
        if key not in index:
            index[key] = len(points)
            # Exact end points: lo and hi themselves, not lo + (hi - lo) * 1.
            c = [
                lo[d] if q == 0 else hi[d] if q == n else lo[d] + (hi[d] - lo[d]) * q / n
                for d, q in enumerate(key)
            ]
            points.append(c)
        return index[key]

    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (0, n):
            for a in range(n):
                for b in range(n):
                    quad = []
                    for da, db in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        key = [0, 0, 0]
                        key[axis], key[u], key[v] = side, a + da, b + db
                        quad.append(vid(*key))
                    tri = [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
                    if side == 0:
                        tri = [t[::-1] for t in tri]
                    faces.extend(tri)
    return outward(np.array(points), np.array(faces))


def prism_mesh(poly: np.ndarray, z0: float, z1: float) -> Mesh:
    """A polygon (k, 2), star-shaped about its first vertex, extruded from z0 to z1; the caps
    are fans from the first vertex."""
    k = len(poly)
    V = np.vstack(
        [np.column_stack([poly, np.full(k, z0)]), np.column_stack([poly, np.full(k, z1)])]
    )
    F = []
    for i in range(1, k - 1):
        F.append([0, i + 1, i])
        F.append([k, k + i, k + i + 1])
    for i in range(k):
        j = (i + 1) % k
        F.append([i, j, k + j])
        F.append([i, k + j, k + i])
    return outward(V, np.array(F))


def icosphere(subdivisions: int) -> Mesh:
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.asarray(s.vertices, float), np.asarray(s.faces, np.int64)


def star_mesh(rng, centre, radius, subdivisions=1, rmin=0.55) -> Mesh:
    """Star-shaped polyhedron: an icosphere with every vertex at its own random radius."""
    V, F = icosphere(subdivisions)
    r = radius * rng.uniform(rmin, 1.0, len(V))
    return outward(V * r[:, None] + centre, F)


def sphere_mesh(centre, radius, subdivisions=2) -> Mesh:
    V, F = icosphere(subdivisions)
    return V * radius + np.asarray(centre, float), F


def tube_mesh(rng, centre, major=0.8, minor=0.25, sweep=None, rings=16, sides=10) -> Mesh:
    """A bent tube: a section of a torus swept by `sweep` radians, with flat caps."""
    sweep = rng.uniform(0.6, 1.6) * np.pi if sweep is None else sweep
    R = Rotation.random(random_state=rng).as_matrix()
    a = np.linspace(0.0, sweep, rings + 1)
    b = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    A, B = np.meshgrid(a, b, indexing="ij")
    x = (major + minor * np.cos(B)) * np.cos(A)
    y = (major + minor * np.cos(B)) * np.sin(A)
    z = minor * np.sin(B)
    V = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    caps = np.array([[major, 0.0, 0.0], [major * np.cos(sweep), major * np.sin(sweep), 0.0]])
    V = np.vstack([V, caps])
    c0, c1 = len(V) - 2, len(V) - 1
    F = []
    for i in range(rings):
        for j in range(sides):
            p, q = i * sides + j, i * sides + (j + 1) % sides
            F.append([p, p + sides, q + sides])
            F.append([p, q + sides, q])
    for j in range(sides):
        F.append([c0, j, (j + 1) % sides])
        F.append([c1, rings * sides + (j + 1) % sides, rings * sides + j])
    V, F = outward(V, np.array(F))
    return V @ R.T + centre, F


def manifold_union_mesh(solids) -> Mesh:
    import manifold3d as m3

    u = m3.Manifold.batch_boolean(solids, m3.OpType.Add)
    mesh = u.to_mesh64()
    return (
        np.asarray(mesh.vert_properties, float)[:, :3].copy(),
        np.asarray(mesh.tri_verts, np.int64).copy(),
    )


def rotated_boxes_mesh(rng, centre, k=3) -> Mesh:
    """A non-convex solid: the manifold3d union of `k` rotated, chained, overlapping boxes."""
    import manifold3d as m3

    solids = []
    at = np.asarray(centre, float)
    for _ in range(k):
        size = rng.uniform(0.25, 0.9, 3)
        M = np.eye(4)
        M[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        M[:3, 3] = at
        solids.append(m3.Manifold.cube(size, center=True).transform(M[:3, :]))
        at = at + rng.normal(size=3) * 0.25
    return manifold_union_mesh(solids)


def sliver(mesh: Mesh, rng, eps: float, off_plane: float = 0.0) -> Mesh:
    """The mesh with one face split in three about a new vertex `eps` (relative to the edge's
    length) from one of its edges: the face (a, b, m) is a sliver. The new vertex is moved
    `off_plane` (same units) along the face's normal (0: the geometry is unchanged)."""
    V, F = mesh
    t = int(rng.integers(len(F)))
    a, b, c = F[t]
    pa, pb, pc = V[a], V[b], V[c]
    n = np.cross(pb - pa, pc - pa)
    n /= np.linalg.norm(n)
    foot = pa + rng.uniform(0.2, 0.8) * (pb - pa)
    towards = pc - foot
    m = foot + eps * towards * np.linalg.norm(pb - pa) / np.linalg.norm(towards) + off_plane * n
    k = len(V)
    F2 = np.vstack([np.delete(F, t, axis=0), [[a, b, k], [b, c, k], [c, a, k]]])
    return np.vstack([V, m]), F2


# ---------------------------------------------------------------------------------------------
# Shapes and scenes
# ---------------------------------------------------------------------------------------------


@dataclass
class Shell:
    V: np.ndarray
    F: np.ndarray  # outward
    op: str = "add"  # "add": united; "sub": a cavity (carried reversed in the mesh)


@dataclass
class Shape:
    """A solid as shells combined in order (``add`` unites, ``sub`` cuts a cavity).

    ``boxes`` (sign, lo, hi): axis-aligned boxes whose signed indicator functions sum to the
    solid's (for the rational reference); None for other solids. ``resolve``: the shells
    overlap, so the mesh goes through `exactgrasp.Solid` first. ``cores`` / ``bounds``: per
    component a ball (centre, radius) inside the solid and one around it."""

    name: str
    shells: list[Shell]
    boxes: list | None = None
    resolve: bool = False
    cores: list = field(default_factory=list)
    bounds: list = field(default_factory=list)

    def mesh(self) -> Mesh:
        Vs, Fs, k = [], [], 0
        for s in self.shells:
            Vs.append(s.V)
            Fs.append((s.F if s.op == "add" else s.F[:, ::-1]) + k)
            k += len(s.V)
        return np.vstack(Vs), np.vstack(Fs)

    def library_mesh(self) -> Mesh:
        V, F = self.mesh()
        if not self.resolve:
            return V, F
        from exactgrasp import Solid

        with warnings.catch_warnings():  # the intake warns when it merges shells
            warnings.simplefilter("ignore", UserWarning)
            solid = Solid(V, F, name=self.name, check_scale=False)
        return np.array(solid.vertices), np.array(solid.faces)

    def manifold(self):
        import manifold3d as m3

        out = None
        for s in self.shells:
            m = m3.Manifold(
                m3.Mesh64(
                    vert_properties=np.ascontiguousarray(s.V, float),
                    tri_verts=np.ascontiguousarray(s.F, np.uint64),
                )
            )
            if s.op == "add":
                out = m if out is None else out + m
            else:
                out = out - m
        return out

    def moved(self, scale: float, offset) -> Shape:
        """x -> x * scale + offset (vertices and boxes rounded alike)."""
        offset = np.asarray(offset, float)

        def f(x):
            return np.asarray(x, float) * scale + offset

        return replace(
            self,
            shells=[Shell(f(s.V), s.F, s.op) for s in self.shells],
            boxes=None
            if self.boxes is None
            else [(sg, f(lo), f(hi)) for sg, lo, hi in self.boxes],
            cores=[(f(c), r * scale) for c, r in self.cores],
            bounds=[(f(c), r * scale) for c, r in self.bounds],
        )


@dataclass
class Scene:
    name: str
    hand: list[Shape]
    obj: list[Shape]
    poses: np.ndarray
    scale: float = 1.0
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def hand_meshes(self) -> list[Mesh]:
        return [s.library_mesh() for s in self.hand]

    def object_meshes(self) -> list[Mesh]:
        return [s.library_mesh() for s in self.obj]

    def moved(self, scale: float, offset) -> Scene:
        """The same scene with x -> x * scale + offset applied to both solids and the poses
        conjugated: equal volumes times scale**3."""
        c = np.asarray(offset, float)
        P = self.poses.copy()
        R = P[:, :3, :3]
        P[:, :3, 3] = scale * P[:, :3, 3] + (c - R @ c)
        return Scene(
            f"{self.name} x{scale:g} +{np.abs(c).max():g}",
            [s.moved(scale, c) for s in self.hand],
            [s.moved(scale, c) for s in self.obj],
            P,
            self.scale * scale,
            self.offset * scale + c,
        )


def box_shape(lo, hi, n=1, name="box") -> Shape:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    V, F = box_mesh(lo, hi, n)
    c = (lo + hi) / 2
    return Shape(
        name,
        [Shell(V, F)],
        boxes=[(1, lo, hi)],
        cores=[(c, float((hi - lo).min() / 2))],
        bounds=[(c, float(np.linalg.norm(hi - lo) / 2))],
    )


def dyadic(rng, lo, hi, bits=6, size=None):
    """Uniform numbers in [lo, hi] rounded to multiples of 2**-bits (exact in binary)."""
    return np.round(rng.uniform(lo, hi, size) * 2.0**bits) / 2.0**bits


def random_box(rng, centre, bits=5, smin=0.25, smax=1.0):
    c = np.asarray(centre, float)
    size = dyadic(rng, smin, smax, bits, 3)
    lo = dyadic(rng, -0.2, 0.2, bits, 3) + np.round(c * 2.0**bits) / 2.0**bits - size / 2
    return lo, lo + size


# -- box world: exact rational references --------------------------------------------------


def box_world_shape(rng, kind: str) -> Shape:
    """An axis-aligned, dyadic solid of kind ``box``, ``fine_box``, ``boxes`` (several shells
    in one mesh, one near the origin and the others up to 6 units away), ``hollow_box``,
    ``overlapping_boxes`` (two shells in one mesh that overlap) or ``l_shape``."""
    if kind in ("box", "fine_box"):
        lo, hi = random_box(rng, (0, 0, 0), smin=0.4, smax=1.5)
        return box_shape(lo, hi, 3 if kind == "fine_box" else 1, kind)
    if kind == "boxes":
        k = int(rng.integers(2, 4))
        shells, boxes, cores, bounds = [], [], [], []
        for i in range(k):
            centre = (0, 0, 0) if i == 0 else rng.choice([-1, 1], 3) * dyadic(rng, 1.5, 6, 2, 3)
            lo, hi = random_box(rng, centre, smin=0.1, smax=0.7)
            if any(np.all(lo < h + 0.05) and np.all(hi > low - 0.05) for _, low, h in boxes):
                continue
            b = box_shape(lo, hi)
            shells += b.shells
            boxes += b.boxes
            cores += b.cores
            bounds += b.bounds
        return Shape(f"boxes[{len(shells)}]", shells, boxes, cores=cores, bounds=bounds)
    if kind == "hollow_box":
        lo, hi = random_box(rng, (0, 0, 0), smin=0.8, smax=1.5)
        wall = dyadic(rng, 0.0625, 0.25, 5, 3)
        ilo, ihi = lo + wall, hi - dyadic(rng, 0.0625, 0.25, 5, 3)
        outer, inner = box_mesh(lo, hi), box_mesh(ilo, ihi, int(rng.integers(1, 3)))
        c = (lo + hi) / 2
        return Shape(
            "hollow_box",
            [Shell(*outer), Shell(*inner, "sub")],
            [(1, lo, hi), (-1, ilo, ihi)],
            bounds=[(c, float(np.linalg.norm(hi - lo) / 2))],
        )
    if kind == "overlapping_boxes":
        # Coordinates of the first box on multiples of 1/16, of the second on odd multiples
        # of 1/32: the shells cross but share no plane.
        lo1 = dyadic(rng, -0.6, -0.2, 4, 3)
        hi1 = lo1 + dyadic(rng, 0.5, 1.2, 4, 3)
        size = rng.integers(4, 15, 3) / 16
        lo2 = (2 * np.round((lo1 + rng.uniform(0.1, 0.6, 3)) * 16) + 1) / 32
        hi2 = lo2 + size
        ilo, ihi = np.maximum(lo1, lo2), np.minimum(hi1, hi2)
        boxes = [(1, lo1, hi1), (1, lo2, hi2)]
        if np.all(ihi > ilo):
            boxes.append((-1, ilo, ihi))
        c = (lo1 + hi1) / 2
        return Shape(
            "overlapping_boxes",
            [Shell(*box_mesh(lo1, hi1)), Shell(*box_mesh(lo2, hi2))],
            boxes,
            resolve=True,
            cores=[(c, float((hi1 - lo1).min() / 2))],
            bounds=[(c, float(np.linalg.norm(np.maximum(hi1, hi2) - np.minimum(lo1, lo2))))],
        )
    if kind == "l_shape":
        a, b = dyadic(rng, 0.8, 1.6, 4, 2)
        t = dyadic(rng, 0.25, 0.5, 4)
        z0, z1 = -dyadic(rng, 0.2, 0.5, 4), dyadic(rng, 0.2, 0.5, 4)
        o = dyadic(rng, -0.5, 0.0, 4, 2)
        poly = np.array([[0, 0], [a, 0], [a, t], [t, t], [t, b], [0, b]]) + o
        V, F = prism_mesh(poly, z0, z1)
        lo1, hi1 = np.array([o[0], o[1], z0]), np.array([o[0] + a, o[1] + t, z1])
        lo2, hi2 = np.array([o[0], o[1] + t, z0]), np.array([o[0] + t, o[1] + b, z1])
        return Shape(
            "l_shape",
            [Shell(V, F)],
            [(1, lo1, hi1), (1, lo2, hi2)],
            cores=[((lo1 + hi1) / 2, float((hi1 - lo1).min() / 2))],
            bounds=[
                ((lo1 + hi2) / 2, float(np.linalg.norm(hi1 - lo1) + np.linalg.norm(hi2 - lo2)))
            ],
        )
    raise ValueError(kind)


BOX_KINDS = ("box", "fine_box", "boxes", "hollow_box", "overlapping_boxes", "l_shape")


def signed_permutation(rng) -> np.ndarray:
    if rng.random() < 0.35:
        return np.eye(3)
    R = np.eye(3)[rng.permutation(3)] * rng.choice([-1.0, 1.0], 3)[:, None]
    if np.linalg.det(R) < 0:
        R[0] *= -1
    return R


#: Gaps (> 0) and overlaps (< 0) of a contact, in the scene's units.
CONTACT_OFFSETS = (0.0, 2.0**-40, -(2.0**-40), 1e-12, -1e-12, 1e-14, -1e-14, 2.0**-20, -(2.0**-20))


def moved_boxes(boxes, pose):
    R, t = pose[:3, :3], pose[:3, 3]
    out = []
    for sg, lo, hi in boxes:
        corners = np.array([lo, hi]) @ R.T + t
        out.append((sg, corners.min(0), corners.max(0)))
    return out


def contact_pose(rng, hand: Shape, obj: Shape, offsets=CONTACT_OFFSETS) -> np.ndarray:
    """A signed-permutation pose putting a box of the object against a box of the hand: on 1
    to 3 axes (face, edge or corner contact) flush, or apart / overlapping by a tiny offset,
    and overlapping in projection on the others."""
    R = signed_permutation(rng)
    a = hand.boxes[int(rng.integers(len(hand.boxes)))]
    pos = [b for b in obj.boxes if b[0] > 0]
    b = pos[int(rng.integers(len(pos)))]
    P = np.eye(4)
    P[:3, :3] = R
    ((_, rlo, rhi),) = moved_boxes([b], P)
    t = np.zeros(3)
    axes = rng.permutation(3)[: int(rng.choice([1, 1, 1, 2, 3]))]
    for d in range(3):
        if d in axes:
            delta = float(rng.choice(offsets))
            if rng.random() < 0.5:
                t[d] = a[2][d] - rlo[d] + delta
            else:
                t[d] = a[1][d] - rhi[d] - delta
        else:
            t[d] = dyadic(rng, a[1][d] - rhi[d], a[2][d] - rlo[d], 6)
    P[:3, 3] = t
    return P


def inside_pose(rng, hand: Shape, obj: Shape, exact: bool) -> np.ndarray | None:
    """A pose putting one object component wholly inside a core ball of the hand (or one
    hand component inside an object core), the other components where they fall."""
    P = np.eye(4)
    P[:3, :3] = signed_permutation(rng) if exact else Rotation.random(random_state=rng).as_matrix()
    R = P[:3, :3]
    fits = [(c, oc) for c in hand.cores for oc in obj.bounds if oc[1] < c[1]]
    if fits and rng.random() < 0.6:
        (ch, _), (co, _) = fits[int(rng.integers(len(fits)))]
        t = ch - R @ co
    else:
        fits = [(hc, c) for c in obj.cores for hc in hand.bounds if hc[1] < c[1]]
        if not fits:
            return None
        (ch, _), (co, _) = fits[int(rng.integers(len(fits)))]
        t = ch - R @ co
    P[:3, 3] = np.round(t * 64) / 64 if exact else t
    return P


def box_scene(rng, hand_kind=None, obj_kind=None, contact_only=False, n_poses=5) -> Scene:
    """Axis-aligned dyadic solids and signed-permutation poses (mostly contacts)."""
    hand_kind = hand_kind or str(rng.choice(BOX_KINDS))
    obj_kind = obj_kind or str(rng.choice(BOX_KINDS))
    hand, obj = box_world_shape(rng, hand_kind), box_world_shape(rng, obj_kind)
    poses = []
    while len(poses) < n_poses:
        r = rng.random()
        if contact_only:
            offs = tuple(o for o in CONTACT_OFFSETS if o >= 0)
            poses.append(contact_pose(rng, hand, obj, offs))
        elif r < 0.6:
            poses.append(contact_pose(rng, hand, obj))
        elif r < 0.8 and (p := inside_pose(rng, hand, obj, exact=True)) is not None:
            poses.append(p)
        else:
            P = np.eye(4)
            P[:3, :3] = signed_permutation(rng)
            P[:3, 3] = dyadic(rng, -1.2, 1.2, 6, 3)
            poses.append(P)
    return Scene(f"box world: hand {hand.name}, object {obj.name}", [hand], [obj], np.array(poses))


def rational_volumes(scene: Scene) -> tuple[list[Fraction], Fraction]:
    """Exact volumes of hand ∩ moved object for a box-world scene (one hand shape, one
    object shape, signed-permutation poses), and the hand's exact volume."""
    (hand,), (obj,) = scene.hand, scene.obj
    A = [(sg, [Fraction(x) for x in lo], [Fraction(x) for x in hi]) for sg, lo, hi in hand.boxes]

    def overlap(a_lo, a_hi, b_lo, b_hi):
        v = Fraction(1)
        for d in range(3):
            w = min(a_hi[d], b_hi[d]) - max(a_lo[d], b_lo[d])
            if w <= 0:
                return Fraction(0)
            v *= w
        return v

    hand_volume = sum((sg * overlap(lo, hi, lo, hi) for sg, lo, hi in A), Fraction(0))
    out = []
    for pose in scene.poses:
        B = [
            (sg, [Fraction(float(x)) for x in lo], [Fraction(float(x)) for x in hi])
            for sg, lo, hi in moved_boxes(obj.boxes, pose)
        ]
        out.append(
            sum(
                (
                    sa * sb * overlap(la, ha, lb, hb)
                    for (sa, la, ha), (sb, lb, hb) in itertools.product(A, B)
                ),
                Fraction(0),
            )
        )
    return out, hand_volume


# -- curved world: manifold3d references ----------------------------------------------------


def curved_shape(rng, kind: str, centre=(0.0, 0.0, 0.0), size=1.0) -> Shape:
    """A solid of kind ``star``, ``tube``, ``rotated_boxes``, ``sphere``, ``multi_shell``
    (2-3 disjoint components in one mesh, up to 6 units apart), ``hollow_sphere`` (outer
    outward, inner reversed, sometimes a solid core inside the cavity), ``overlapping``
    (2-3 overlapping components in one mesh) or ``sliver`` (a star, tube or box with a face
    whose vertex is 1e-6 to 1e-12 from an edge)."""
    c = np.asarray(centre, float)
    if kind == "star":
        V, F = star_mesh(rng, c, size, int(rng.integers(1, 3)))
        return Shape("star", [Shell(V, F)], cores=[(c, 0.5 * size)], bounds=[(c, size)])
    if kind == "sphere":
        V, F = sphere_mesh(c, size, 2)
        return Shape("sphere", [Shell(V, F)], cores=[(c, 0.9 * size)], bounds=[(c, size)])
    if kind == "tube":
        V, F = tube_mesh(rng, c, 0.8 * size, 0.25 * size)
        return Shape("tube", [Shell(V, F)], bounds=[(c, 1.05 * size)])
    if kind == "rotated_boxes":
        V, F = rotated_boxes_mesh(rng, c, int(rng.integers(2, 4)))
        r = float(np.linalg.norm(V - c, axis=1).max())
        return Shape("rotated_boxes", [Shell(V, F)], cores=[(c, 0.12)], bounds=[(c, r)])
    if kind == "multi_shell":
        k = int(rng.integers(2, 4))
        parts = []
        for i in range(k):
            sub = str(rng.choice(["star", "sphere", "tube"]))
            at = c if i == 0 else c + rng.normal(size=3) / np.sqrt(3) * rng.uniform(2.5, 6.0)
            if any(
                np.linalg.norm(at - p.bounds[0][0]) < 0.8 * size + p.bounds[0][1] for p in parts
            ):
                continue
            parts.append(curved_shape(rng, sub, at, 0.4 * size))
        return Shape(
            f"multi_shell[{'+'.join(p.name for p in parts)}]",
            [s for p in parts for s in p.shells],
            cores=[x for p in parts for x in p.cores],
            bounds=[x for p in parts for x in p.bounds],
        )
    if kind == "hollow_sphere":
        inner = rng.uniform(0.4, 0.85)
        shells = [
            Shell(*sphere_mesh(c, size, 2)),
            Shell(
                *sphere_mesh(c + rng.normal(size=3) * 0.02, inner * size, 1 + rng.integers(2)),
                "sub",
            ),
        ]
        name = "hollow_sphere"
        if rng.random() < 0.4:
            shells.append(Shell(*star_mesh(rng, c, 0.6 * inner * size, 1)))
            name += "+core"
        return Shape(name, shells, bounds=[(c, size)])
    if kind == "overlapping":
        k = int(rng.integers(2, 4))
        shells = [Shell(*star_mesh(rng, c, size * 0.8, 1, rmin=0.7))]
        for _ in range(k - 1):
            shells.append(
                Shell(*star_mesh(rng, c + rng.normal(size=3) * 0.35 * size, size * 0.6, 1, 0.7))
            )
        return Shape(
            f"overlapping[{k}]",
            shells,
            resolve=True,
            cores=[(c, 0.5 * size)],
            bounds=[(c, 1.8 * size)],
        )
    if kind == "sliver":
        base = str(rng.choice(["star", "tube", "box"]))
        if base == "box":
            lo, hi = random_box(rng, c, smin=0.5 * size, smax=1.2 * size)
            V, F = box_mesh(lo, hi, int(rng.integers(1, 3)))
            bound = (c, float(np.linalg.norm(hi - lo)))
        else:
            s = curved_shape(rng, base, c, size)
            V, F = s.shells[0].V, s.shells[0].F
            bound = s.bounds[0]
        eps = 10.0 ** -rng.uniform(6, 12)
        off = float(rng.choice([0.0, 1.0, -1.0])) * 10.0 ** -rng.uniform(6, 12) * size
        for _ in range(int(rng.integers(1, 4))):
            V, F = sliver((V, F), rng, eps, off)
        return Shape(f"sliver[{base}, {eps:.1e}, {off:+.1e}]", [Shell(V, F)], bounds=[bound])
    raise ValueError(kind)


CURVED_KINDS = (
    "star",
    "tube",
    "rotated_boxes",
    "sphere",
    "multi_shell",
    "hollow_sphere",
    "overlapping",
    "sliver",
)


def curved_scene(rng, hand_kinds=CURVED_KINDS, obj_kinds=CURVED_KINDS, n_poses=5, links=None):
    """Curved or non-convex solids (1-2 hand links), random rotations, poses that overlap the
    two, hold one inside the other, or keep them apart."""
    n_links = links or int(rng.choice([1, 1, 2]))
    hand = [
        curved_shape(rng, str(rng.choice(hand_kinds)), rng.normal(size=3) * 0.3 * i, 1.0)
        for i in range(n_links)
    ]
    obj = [
        curved_shape(rng, str(rng.choice(obj_kinds)), np.zeros(3), float(rng.uniform(0.3, 0.9)))
    ]
    ch = hand[0].bounds[0][0]
    poses = []
    while len(poses) < n_poses:
        r = rng.random()
        P = np.eye(4)
        P[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        if r < 0.25 and (p := inside_pose(rng, hand[0], obj[0], exact=False)) is not None:
            P = p
        elif r < 0.35:
            P[:3, 3] = ch + rng.normal(size=3) * 20
        else:
            P[:3, 3] = ch + rng.uniform(-1.0, 1.0, 3)
        poses.append(P)
    label = "+".join(s.name for s in hand)
    return Scene(f"curved: hand {label}, object {obj[0].name}", hand, obj, np.array(poses))


def manifold_volumes(scene: Scene) -> tuple[np.ndarray, float]:
    """manifold3d volumes of (union of hand shapes) ∩ (moved union of object shapes), and the
    hand's volume, each shape built shell by shell (outward shells united, cavities cut)."""
    hand = scene.hand[0].manifold()
    for s in scene.hand[1:]:
        hand = hand + s.manifold()
    obj = scene.obj[0].manifold()
    for s in scene.obj[1:]:
        obj = obj + s.manifold()
    vols = np.array([(hand ^ obj.transform(p[:3, :])).volume() for p in scene.poses])
    return vols, float(hand.volume())


# -- convex pairs: scipy half-space intersection ---------------------------------------------


def hull_mesh(points) -> Mesh:
    points = np.asarray(points, float)
    h = ConvexHull(points)
    used = np.unique(h.simplices)
    remap = np.full(len(points), -1)
    remap[used] = np.arange(len(used))
    V, F = points[used], remap[h.simplices]
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    flip = np.einsum("ij,ij->i", n, V[F[:, 0]] - V.mean(0)) < 0
    F[flip] = F[flip][:, ::-1]
    return V, F


def convex_scene(rng, n_poses=4) -> Scene:
    """Two random convex polytopes, one sometimes with a point 1e-6..1e-12 outside the
    midpoint of an edge (a sliver facet pair), random poses."""
    shapes = []
    for _ in range(2):
        pts = rng.normal(size=(int(rng.integers(8, 40)), 3)) * rng.uniform(0.4, 1.0, 3)
        V, F = hull_mesh(pts)
        name = "hull"
        if rng.random() < 0.5:
            a, b = V[F[0, 0]], V[F[0, 1]]
            mid = 0.5 * (a + b)
            away = mid - V.mean(0)
            away -= away @ (b - a) / ((b - a) @ (b - a)) * (b - a)
            eps = 10.0 ** -rng.uniform(6, 12)
            V, F = hull_mesh(np.vstack([V, mid + eps * away / np.linalg.norm(away)]))
            name = f"hull+sliver {eps:.1e}"
        shapes.append(Shape(name, [Shell(V, F)], bounds=[(V.mean(0), 1.0)]))
    poses = np.tile(np.eye(4), (n_poses, 1, 1))
    poses[:, :3, :3] = Rotation.random(n_poses, random_state=rng).as_matrix()
    poses[:, :3, 3] = rng.uniform(-1.0, 1.0, (n_poses, 3))
    return Scene(f"convex: {shapes[0].name} / {shapes[1].name}", [shapes[0]], [shapes[1]], poses)


def halfspace_volume(Va: np.ndarray, Vb: np.ndarray) -> float | None:
    """Volume of the intersection of two convex hulls, with scipy only; None where the
    intersection is thinner than 1e-6 (its Chebyshev ball), too thin for qhull to be trusted."""
    eqs = np.vstack([ConvexHull(Va).equations, ConvexHull(Vb).equations])
    norm = np.linalg.norm(eqs[:, :3], axis=1)
    res = linprog(
        [0, 0, 0, -1],
        A_ub=np.hstack([eqs[:, :3], norm[:, None]]),
        b_ub=-eqs[:, 3],
        bounds=[(None, None)] * 3 + [(0, None)],
    )
    if res.status == 2:  # infeasible: the hulls are disjoint
        return 0.0
    if res.status != 0:
        raise RuntimeError(f"linprog failed: {res.message}")
    if res.x[3] <= 1e-6:
        return None
    return ConvexHull(HalfspaceIntersection(eqs, res.x[:3]).intersections).volume


def halfspace_volumes(scene: Scene) -> tuple[np.ndarray, float]:
    """Half-space intersection volumes of a convex pair (manifold3d for slivers of
    intersection thinner than 1e-6)."""
    Va = scene.hand[0].shells[0].V
    Vb = scene.obj[0].shells[0].V
    vols = [halfspace_volume(Va, Vb @ p[:3, :3].T + p[:3, 3]) for p in scene.poses]
    if any(v is None for v in vols):
        thin, _ = manifold_volumes(scene)
        vols = [thin[i] if v is None else v for i, v in enumerate(vols)]
    return np.array(vols, float), ConvexHull(Va).volume


# ---------------------------------------------------------------------------------------------
# Running and comparing
# ---------------------------------------------------------------------------------------------


def run_exact(scene: Scene, broadphase="coal", n_jobs=1) -> tuple[np.ndarray, Intersection]:
    """The exact volumes of a scene's poses, and the whole result (bounds, sources, stats)."""
    ex = ExactIntersector(
        scene.hand_meshes(), scene.object_meshes(), broadphase=broadphase, n_jobs=n_jobs
    )
    result = ex.intersect(scene.poses)
    return result.volumes, result


def reference(scene: Scene) -> tuple[np.ndarray, float]:
    """The independent reference volumes of a scene and the hand's volume: rational for box
    scenes, half-space intersection for convex pairs, manifold3d otherwise."""
    if is_rational(scene):
        vols, hv = rational_volumes(scene)
        return np.array([float(v) for v in vols]), float(hv)
    if scene.name.startswith("convex"):
        return halfspace_volumes(scene)
    return manifold_volumes(scene)


def is_rational(scene: Scene) -> bool:
    """Whether `reference` gives this scene's volumes exactly (rational arithmetic)."""
    return all(s.boxes is not None for s in scene.hand + scene.obj) and len(scene.hand) == 1


def reference_error(scene: Scene, want: np.ndarray, exact: bool) -> np.ndarray:
    """How far a reference volume may be from the truth: 0 for rational ones; for manifold3d
    and half-space ones, `plain_error` (1e-9 relative plus manifold3d's own tolerance, 1e-12
    of the coordinates' magnitude, times both surfaces' areas, four times over)."""
    if exact:
        return np.zeros_like(want)
    meshes = scene.hand_meshes() + scene.object_meshes()
    size = max(float(np.abs(V).max()) for V, _ in meshes)
    area = sum(
        float(
            np.linalg.norm(
                np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1
            ).sum()
        )
        / 2
        for V, F in meshes
    )
    return plain_error(want, size, area)


def mismatches(scene, got, want, bounds, exact):
    """Poses where `got` is farther from the reference `want` than the backend's own error
    bound (`Intersection.volume_bounds`) plus the reference's error."""
    allowed = bounds + reference_error(scene, want, exact)
    bad = ~(np.abs(got - want) <= allowed)
    return [
        f"{scene.name}, pose {i}: got {got[i]!r}, reference {want[i]!r}, error "
        f"{abs(got[i] - want[i]):.3g} > allowed {allowed[i]:.3g}"
        for i in np.flatnonzero(bad)
    ]


def assert_matches(scene, got, want, ex, exact):
    bad = mismatches(scene, got, want, ex.volume_bounds, exact)
    assert not bad, "\n".join(bad)


SETTINGS = dict(
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
seeds = st.integers(0, 2**32 - 1)


def scene_from(maker):
    return seeds.map(lambda s: maker(np.random.default_rng(s)))


def any_scene(rng) -> Scene:
    k = rng.integers(3)
    return (box_scene, curved_scene, convex_scene)[k](rng)


#: Every generator, by category (shared with ``benchmarks/fuzz_exact.py``).
SCENES = {
    "box_world": box_scene,
    "touching": lambda rng: box_scene(rng, contact_only=True),
    "nonconvex": lambda rng: curved_scene(
        rng, ("star", "tube", "rotated_boxes"), ("star", "tube", "rotated_boxes")
    ),
    "multi_shell": lambda rng: (
        curved_scene(rng, ("multi_shell", "sphere", "star"), ("multi_shell",))
        if rng.random() < 0.5
        else curved_scene(rng, ("multi_shell",), ("sphere", "star"))
    ),
    "multi_shell_boxes": lambda rng: box_scene(
        rng, *(("boxes", None) if rng.random() < 0.5 else (None, "boxes"))
    ),
    "hollow": lambda rng: curved_scene(rng, ("hollow_sphere", "star"), ("hollow_sphere", "star")),
    "overlapping_shells": lambda rng: (
        curved_scene(rng, ("overlapping",), CURVED_KINDS)
        if rng.random() < 0.5
        else curved_scene(rng, CURVED_KINDS, ("overlapping",))
    ),
    "sliver": lambda rng: (
        curved_scene(rng, ("sliver",), CURVED_KINDS)
        if rng.random() < 0.5
        else curved_scene(rng, CURVED_KINDS, ("sliver",))
    ),
    "convex": convex_scene,
}


def far_variant(rng, scene: Scene, exact: bool) -> Scene:
    """The scene moved 10 to 1000 units from the origin (a dyadic offset for box scenes)."""
    d = rng.normal(size=3)
    c = d / np.linalg.norm(d) * 10.0 ** rng.uniform(1, 3)
    return scene.moved(1.0, np.round(c * 16) / 16 if exact else c)


SCALES = (100.0, 1e-3, 2.0**7, 2.0**-10)


# ---------------------------------------------------------------------------------------------
# Properties
# ---------------------------------------------------------------------------------------------


@settings(max_examples=60, **SETTINGS)
@given(scene_from(box_scene))
def test_box_solids_in_contact_match_exact_rational_volumes(scene):
    got, ex = run_exact(scene)
    want, _hv = reference(scene)
    assert_matches(scene, got, want, ex, is_rational(scene))


@settings(max_examples=40, **SETTINGS)
@given(scene_from(SCENES["touching"]))
def test_exactly_touching_or_apart_solids_give_exactly_zero(scene):
    got, _ex = run_exact(scene)
    vols, _ = rational_volumes(scene)
    zero = np.array([v == 0 for v in vols])
    # Poses whose true volume is 0 (face, edge or corner contacts, or gaps); a contact with a
    # cavity's or another component's box may overlap elsewhere.
    assume(zero.any())
    assert got[zero].tolist() == [0.0] * int(zero.sum()), (scene.name, got, vols)


@settings(max_examples=25, **SETTINGS)
@given(scene_from(SCENES["nonconvex"]))
def test_non_convex_solids_match_manifold_reference(scene):
    got, ex = run_exact(scene)
    want, _hv = manifold_volumes(scene)
    assert_matches(scene, got, want, ex, is_rational(scene))


@settings(max_examples=25, **SETTINGS)
@given(scene_from(SCENES["multi_shell"]), st.sampled_from(["coal", "fcl", None]))
def test_multi_shell_meshes_match_reference_with_every_broadphase(scene, broadphase):
    got, ex = run_exact(scene, broadphase)
    want, _hv = manifold_volumes(scene)
    assert_matches(scene, got, want, ex, is_rational(scene))


@settings(max_examples=25, **SETTINGS)
@given(scene_from(SCENES["multi_shell_boxes"]), st.sampled_from(["coal", "fcl", None]))
def test_multi_shell_box_meshes_match_exact_rationals_with_every_broadphase(scene, broadphase):
    got, ex = run_exact(scene, broadphase)
    want, _hv = reference(scene)
    assert_matches(scene, got, want, ex, is_rational(scene))


def test_one_shell_inside_the_hand_and_one_far_away_counts_only_the_inner_one():
    hand = box_shape([0, 0, 0], [1, 1, 1])
    inner, far = box_shape([0.25, 0.25, 0.25], [0.5, 0.5, 0.5]), box_shape([5, 5, 5], [5.25] * 3)
    obj = Shape("inner+far", inner.shells + far.shells, inner.boxes + far.boxes)
    scene = Scene("inner + far cube", [hand], [obj], np.eye(4)[None])
    for bp in ("coal", "fcl", None):
        got, _ex = run_exact(scene, bp)
        assert got.tolist() == [0.25**3], bp


@settings(max_examples=20, **SETTINGS)
@given(scene_from(SCENES["hollow"]))
def test_hollow_solids_match_reference_with_the_cavity_cut(scene):
    got, ex = run_exact(scene)
    want, _hv = manifold_volumes(scene)
    assert_matches(scene, got, want, ex, is_rational(scene))


@settings(max_examples=20, **SETTINGS)
@given(scene_from(SCENES["overlapping_shells"]))
def test_overlapping_shells_in_one_mesh_count_their_union_once(scene):
    got, ex = run_exact(scene)
    want, _hv = manifold_volumes(scene)
    assert_matches(scene, got, want, ex, is_rational(scene))


@settings(max_examples=25, **SETTINGS)
@given(scene_from(SCENES["sliver"]))
def test_sliver_faces_match_manifold_reference(scene):
    got, ex = run_exact(scene)
    want, _hv = manifold_volumes(scene)
    assert_matches(scene, got, want, ex, is_rational(scene))


@settings(max_examples=20, **SETTINGS)
@given(scene_from(convex_scene))
def test_convex_pairs_with_slivers_match_halfspace_intersection(scene):
    got, ex = run_exact(scene)
    want, _hv = halfspace_volumes(scene)
    assert_matches(scene, got, want, ex, is_rational(scene))


@settings(max_examples=30, **SETTINGS)
@given(seeds)
def test_far_from_origin_gives_the_volumes_at_the_origin(seed):
    rng = np.random.default_rng(seed)
    exact = rng.random() < 0.5
    scene = box_scene(rng) if exact else curved_scene(rng, n_poses=4)
    far = far_variant(rng, scene, exact)
    want, _hv = reference(scene)
    got, ex = run_exact(far)
    assert_matches(far, got, want, ex, is_rational(far))


@settings(max_examples=25, **SETTINGS)
@given(seeds, st.sampled_from(SCALES))
def test_huge_and_tiny_scales_give_the_scaled_volumes(seed, scale):
    rng = np.random.default_rng(seed)
    exact = rng.random() < 0.5
    scene = box_scene(rng) if exact else curved_scene(rng, n_poses=4)
    moved = scene.moved(scale, np.zeros(3))
    got, ex = run_exact(moved)
    if exact:  # the rounded, scaled boxes' own exact volumes
        want, hv = reference(moved)
    else:
        want, hv = reference(scene)
        want, hv = want * scale**3, hv * scale**3
    assert_matches(moved, got, want, ex, is_rational(moved))


@settings(max_examples=40, **SETTINGS)
@given(scene_from(any_scene))
def test_volumes_are_never_negative(scene):
    got, _ex = run_exact(scene)
    assert (got >= 0).all(), (scene.name, got)


@settings(max_examples=20, **SETTINGS)
@given(scene_from(any_scene))
def test_broadphases_give_bit_identical_volumes(scene):
    base, _ = run_exact(scene, None)
    for bp in ("coal", "fcl"):
        got, _ex = run_exact(scene, bp)
        np.testing.assert_array_equal(got, base, err_msg=f"{scene.name}, broadphase {bp}")


@settings(max_examples=15, **SETTINGS)
@given(scene_from(any_scene))
def test_one_and_two_threads_give_identical_volumes(scene):
    one, _ = run_exact(scene, "coal", 1)
    two, _ = run_exact(scene, "coal", 2)
    np.testing.assert_array_equal(two, one, err_msg=scene.name)


def test_generators_build_valid_solids_with_matching_references():
    """Every generator yields meshes the reference accepts, and the references agree with
    each other where both apply (the checks above are only as good as the references)."""
    rng = np.random.default_rng(0)
    for kind in BOX_KINDS:
        s = box_world_shape(rng, kind)
        exact = float(sum(sg * np.prod(hi - lo) for sg, lo, hi in s.boxes))
        assert abs(s.manifold().volume() - exact) <= 1e-12 * exact, kind
    for kind in CURVED_KINDS:
        s = curved_shape(rng, kind)
        m = s.manifold()
        assert m.status().name == "NoError" and m.volume() > 0, kind
    scene = box_scene(rng, "box", "l_shape", n_poses=8)
    scene.poses[:, :3, 3] += 0.01  # away from exact contact, where manifold3d is reliable
    vols, hv = rational_volumes(scene)
    mv, mhv = manifold_volumes(scene)
    np.testing.assert_allclose(mv, [float(v) for v in vols], rtol=1e-12, atol=1e-12)
    assert abs(mhv - float(hv)) <= 1e-12 * float(hv)
