"""The manifold3d adapter: solids from (vertices, faces) arrays, unions, and arrays back.

Everything in exactgrasp that hands meshes to manifold3d goes through `to_manifold`, which
refuses, naming the mesh, the defect and the fix, what manifold3d cannot take as a solid.
Double precision throughout (``Mesh64``).
"""

from __future__ import annotations

from collections.abc import Sequence

import manifold3d
import numpy as np

from exactgrasp.errors import Fix, MeshError
from exactgrasp.geometry.topology import edge_defects, format_point

__all__ = [
    "MeshArrays",
    "mesh_arrays",
    "placed",
    "start_thread_pool",
    "to_manifold",
    "union",
    "union_solids",
    "union_volume",
    "union_volume_by_overlaps",
]

MeshArrays = tuple[np.ndarray, np.ndarray]

# How closely manifold3d's volume of a solid must match the divergence volume of its arrays:
# its own simplification moves them by about its tolerance, 1e-12 of the coordinates.
_VOLUME_AGREEMENT = 1e-8

REPAIR_HINT = (
    "manifold3d needs a closed, consistently oriented surface; load the mesh with ",
    Fix("repair", True),
    " (or fix it in a mesh editor) and try again.",
)


def to_manifold(
    vertices: np.ndarray,
    faces: np.ndarray,
    name: str = "mesh",
    fix: str | None = None,
    face_ids: bool = False,
) -> manifold3d.Manifold:
    """A manifold3d solid from arrays, or a `MeshError` naming the mesh.

    Parameters
    ----------
    vertices : numpy.ndarray, shape (n, 3), float
    faces : numpy.ndarray, shape (m, 3), int
        Outward-oriented triangles.
    name : str
        The mesh, in messages (``"hand link 3"``).
    fix : str, optional
        How to fix a mesh manifold3d refuses, in messages; default `REPAIR_HINT`.
    face_ids : bool
        Give each triangle its index as manifold3d's face id: every triangle of the solid and
        of any boolean with it then lies in the input triangle its ``face_id`` names (no two
        triangles merged, as manifold3d merges coplanar ones of one face id). Default: face ids
        left to manifold3d.

    Returns
    -------
    manifold3d.Manifold
        Of positive volume.
    """
    fix_parts = REPAIR_HINT if fix is None else (fix,)
    V = np.ascontiguousarray(vertices, dtype=np.float64)
    F = np.asarray(faces)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise MeshError(
            f"{name}: expected vertices (n, 3) and faces (m, 3), got "
            f"{V.shape} and {F.shape}; pass a non-empty triangle mesh."
        )
    if not np.all(np.isfinite(V)):
        raise MeshError(f"{name}: vertex coordinates contain NaN or infinity; ", *fix_parts)
    if F.min() < 0 or F.max() >= len(V):
        raise MeshError(f"{name}: face indices out of range; ", *fix_parts)
    defects = edge_defects(V, F)
    if defects.nonmanifold:
        # manifold3d would drop faces around such an edge and change the solid.
        raise MeshError(
            f"{name}: {defects.nonmanifold} edges are shared by more than two faces (e.g. at "
            f"{format_point(defects.nonmanifold_at)}), which manifold3d cannot take as they "
            "are; read the mesh as an exactgrasp.Solid first, which splits them into a "
            "2-manifold of the same solid."
        )
    # Copies: manifold3d takes writable arrays only (a Solid's arrays are read-only).
    solid = manifold3d.Manifold(
        manifold3d.Mesh64(
            vert_properties=np.array(V, dtype=np.float64, order="C"),
            tri_verts=np.array(F, dtype=np.uint64, order="C"),
            face_id=np.arange(len(F), dtype=np.uint64) if face_ids else None,
        )
    )
    status = solid.status()
    if status != manifold3d.Error.NoError or solid.is_empty():
        raise MeshError(
            f"{name}: manifold3d refuses it as a solid ({status.name}): it is not a closed "
            "manifold surface; ",
            *fix_parts,
        )
    if solid.volume() <= 0:
        raise MeshError(f"{name} has non-positive volume (faces inward?); ", *fix_parts)
    _check_volume_kept(solid, V, np.asarray(F, dtype=np.int64), name)
    return solid


def _check_volume_kept(solid: manifold3d.Manifold, V: np.ndarray, F: np.ndarray, name: str):
    """Refuse a mesh whose volume manifold3d does not keep: it simplifies features thinner
    than its tolerance (about 1e-12 of the largest coordinate), and slivers that thin (left
    where faces built to lie in one plane were rotated in floating point) can make that
    simplification drop part of the solid."""
    P = V - V.mean(0)
    a, b, c = P[F[:, 0]], P[F[:, 1]], P[F[:, 2]]
    cross = np.cross(b - a, c - a)
    volume = float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)
    if abs(solid.volume() - volume) <= _VOLUME_AGREEMENT * abs(volume):
        return
    edges = np.linalg.norm(P[F[:, [1, 2, 0]]] - P[F], axis=2).max(1)
    height = np.linalg.norm(cross, axis=1) / np.maximum(edges, 1e-300)
    thinnest = int(np.argmin(height))
    raise MeshError(
        f"{name}: manifold3d reads a volume of {solid.volume():.9g} where the surface "
        f"bounds {volume:.9g}: its simplification (tolerance {solid.get_tolerance():.2g}) "
        f"drops slivers as thin as {height[thinnest]:.2g} (e.g. near "
        f"{format_point(V[F[thinnest]].mean(0))}), left where faces built to lie in one plane "
        "were rotated or moved in floating point; load the mesh in the frame where those "
        "faces are exact (before rotating it), or merge its overlapping parts in a modeller."
    )


def union_solids(solids: Sequence[manifold3d.Manifold]) -> manifold3d.Manifold:
    """Union of manifold3d solids (overlaps counted once)."""
    if len(solids) == 1:
        return solids[0]
    return manifold3d.Manifold.batch_boolean(list(solids), manifold3d.OpType.Add)


def union(parts: Sequence[MeshArrays], name: str = "hand") -> manifold3d.Manifold:
    """Union of closed parts that may overlap.

    Parameters
    ----------
    parts : sequence of (vertices (n, 3), faces (m, 3))
    name : str
        The whole, in messages (part ``i`` is ``"{name} part {i}"``).

    Returns
    -------
    manifold3d.Manifold
    """
    return union_solids([to_manifold(v, f, f"{name} part {i}") for i, (v, f) in enumerate(parts)])


def union_volume(parts: Sequence[MeshArrays], name: str = "hand") -> float:
    """Volume of the union of closed parts (overlaps counted once), in cubed input units."""
    return float(union(parts, name).volume())


def placed(solid: manifold3d.Manifold, pose: np.ndarray) -> manifold3d.Manifold:
    """``solid`` moved by the rigid ``pose`` (4, 4) (lazily: manifold3d applies it on use)."""
    return solid.transform(np.ascontiguousarray(np.asarray(pose, dtype=np.float64)[:3, :4]))


def union_volume_by_overlaps(
    solids: Sequence[manifold3d.Manifold], volumes: Sequence[float] | None = None
) -> float:
    """Volume of the union of solids by inclusion-exclusion over the ones that overlap.

    ``vol(A1 u ... u An) = sum vol(Ai) - sum vol(Ai n Aj) + sum vol(Ai n Aj n Ak) - ...``,
    an identity, with every term that is not zero: a set of solids whose common part has
    volume is a set of which every pair overlaps, so only sets grown from overlapping pairs
    are intersected. For a hand, whose links overlap only at their joints, that is a few small
    intersections instead of one boolean of the whole surface; each term is a manifold3d
    boolean, as the union is, and the two agree to rounding (tested on the study's hands).

    Parameters
    ----------
    solids : sequence of manifold3d.Manifold
        Closed solids in one frame.
    volumes : sequence of float, optional
        Their volumes, when known (a rigid motion does not change them).

    Returns
    -------
    float
        Cubed units of the solids.
    """
    n = len(solids)
    vols = [float(s.volume()) for s in solids] if volumes is None else [float(v) for v in volumes]
    boxes = [np.asarray(s.bounding_box(), dtype=np.float64).reshape(2, 3) for s in solids]
    total = sum(vols)
    overlaps: dict[int, set[int]] = {i: set() for i in range(n)}
    common: dict[tuple[int, int], manifold3d.Manifold] = {}
    for i in range(n):
        for j in range(i + 1, n):
            if np.all(boxes[i][0] <= boxes[j][1]) and np.all(boxes[j][0] <= boxes[i][1]):
                both = solids[i] ^ solids[j]
                volume = float(both.volume())
                if volume > 0:
                    total -= volume
                    overlaps[i].add(j)
                    common[i, j] = both

    def grow(members: tuple[int, ...], part: manifold3d.Manifold, sign: float) -> None:
        nonlocal total
        for k in sorted(set.intersection(*(overlaps[m] for m in members))):
            more = part ^ solids[k]
            volume = float(more.volume())
            if volume > 0:  # nothing grown from an empty common part has volume
                total += sign * volume
                grow((*members, k), more, -sign)

    for (i, j), part in common.items():
        grow((i, j), part, 1.0)
    return total


def start_thread_pool() -> None:
    """Run one boolean large enough for manifold3d to start its thread pool.

    manifold3d (3.x wheels) has TBB built in, with no setting for its threads: TBB sizes its
    pool once per process, from the CPUs the process's main thread may run on at its first
    parallel call. `exactgrasp.batch.threads.limit_threads` narrows those CPUs around this
    call, so that a batch worker's booleans use exactly its share of the cores.
    """
    sphere = manifold3d.Manifold.sphere(1.0, 256)
    float((sphere + sphere.translate((0.5, 0.0, 0.0))).volume())


def mesh_arrays(solid: manifold3d.Manifold) -> MeshArrays:
    """Vertices (n, 3) float64 and faces (m, 3) int64 of a manifold3d solid, C-contiguous.

    Fresh writable copies: manifold3d's buffers are read-only, and the kernels would be
    compiled a second time for read-only arrays."""
    mesh = solid.to_mesh64()
    V = np.array(np.asarray(mesh.vert_properties)[:, :3], dtype=np.float64, order="C")
    F = np.array(np.asarray(mesh.tri_verts), dtype=np.int64, order="C")
    return V, F
