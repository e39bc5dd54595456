"""The exact volume's derivatives by every vertex of both meshes, from per-face moments.

Moving a point of a solid's boundary outward along ``δ`` adds ``δ · n`` of volume per unit
of area where the boundary lies inside the other solid. A vertex ``i`` of a triangle mesh
moves each face ``f`` around it with velocity ``φ_i δ`` (``φ_i`` the face's barycentric weight
of ``i``), so

``dV/dx_i = Σ_f (∫_{f ∩ other} φ_i dA) n_f``,

``n_f`` the face's unit outward normal. ``φ_i`` is linear, so per face the area ``A`` and the
first moment ``P = ∫ x dA`` of ``f ∩ other`` are enough, and the kernel sums, per face of
either union (`ExactIntersector` with ``faces=True``), ``F = ∫ n dA = n A`` and
``M = ∫ x × n dA = P × n``. For a face with corners ``(x_j, y, z)`` in turn (``a, b, c``;
``N = (b - a) × (c - a)``),

``∫ φ_j dA = ((z - y) × (P - A y)) · N / |N|² = (M · (z - y) + (F · n)((y × z) · n)) / |N|``

(``P = n × M + n (n · P)`` and ``z - y`` lies in the face's plane): a fixed weight row per
face and corner (`vertex_tables`) against the moments' row ``(F, M)``. Each face of a union
lies in one input face (manifold3d face ids, `moments.face_sources`), whose pieces add up.
The kernel sums, as each pose ends, only the rows it touched onto the vertices
(`_face_gradients.pose_sums`; `_entries.vertex_sums` does the same from `moment_entries` where the
limit or the arrangement gave a pose's rows), a hand part classified whole and inside, or an
inside vertex of a part classified vertex by vertex, being one marker that stands for its whole
edges' shares (`moment_layout.vertex_markers`): what a marker gives each vertex is summed once
per intersector (`vertex_tables`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from exactgrasp.backends.exact.intersector import ExactIntersector

__all__ = [
    "VertexTables",
    "mesh_tables",
    "mesh_vertex_gradients",
    "vertex_gradients",
    "vertex_tables",
]


class VertexTables(NamedTuple):
    """Per row of an intersector's per-face moments (`ExactIntersector.face_sources`: the
    hand's union's faces, then the object's), what its moments give each corner's vertex
    (`vertex_tables`). ``L`` rows."""

    #: (L, 3, 6) float64: per corner ``j`` the row ``(((y × z) · n) n, z - y) / |N|`` of its
    #: input face (local coordinates, the object's unmoved): ``∫ φ_j dA`` is its product with
    #: the moments ``(F, M)`` of the face's part inside (0 for a face of no area).
    weights: np.ndarray
    #: (L, 3) float64: the input face's unit normal in the frame the derivatives are wanted in.
    directions: np.ndarray
    #: (L, 3) int64: the vertex (of its side's, numbered as the caller's) at each corner.
    targets: np.ndarray
    #: (1,) int64: the first of the object's rows.
    object_from: np.ndarray
    #: (1,) int64: the first part marker's row (`tables.MomentTables.part_from`).
    part_from: np.ndarray
    #: (parts + n + 1,) int64: CSR start of each marker's entries in `part_targets`: the
    #: parts', then the hand vertices' (`moment_layout.vertex_markers`).
    part_start: np.ndarray
    #: (q,) int64: the hand vertices a marker's whole edges inside move the volume by.
    part_targets: np.ndarray
    #: (q, 3) float64: by how much (its entries' rows' corners summed; as `directions`).
    part_vectors: np.ndarray


def _side_tables(pairs, sources, targets, origin):
    """`VertexTables`' weights, unit normals and targets of one side's rows: ``pairs`` its
    meshes (V, F), ``sources`` (r, 2) each row's (mesh, face), ``targets`` per mesh (m_i, 3)
    vertex indices, ``origin`` (3,) the local origin."""
    face_at = np.cumsum([0] + [len(F) for _, F in pairs])
    vertex_at = np.cumsum([0] + [len(V) for V, _ in pairs])
    face = face_at[sources[:, 0]] + sources[:, 1]
    corner = np.concatenate([F + o for (_, F), o in zip(pairs, vertex_at, strict=False)])[face]
    corners = np.concatenate([V for V, _ in pairs])[corner] - origin
    target = np.concatenate(targets)[face].astype(np.int64)
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    N = np.cross(b - a, c - a)
    norm = np.sqrt(np.einsum("ij,ij->i", N, N))
    inv = np.divide(1.0, norm, out=np.zeros_like(norm), where=norm > 0)
    n = N * inv[:, None]
    weights = np.empty((len(face), 3, 6))
    for j, (y, z) in enumerate(((b, c), (c, a), (a, b))):
        s = np.einsum("ij,ij->i", np.cross(y, z), n) * inv
        weights[:, j, :3] = n * s[:, None]
        weights[:, j, 3:] = (z - y) * inv[:, None]
    return weights, n, target


def vertex_tables(
    intersector: ExactIntersector, hand: tuple, body: tuple, turn: np.ndarray | None = None
) -> VertexTables:
    """The `VertexTables` of an intersector built with ``faces=True``.

    Parameters
    ----------
    intersector : ExactIntersector
    hand, body : (list of (V (n, 3), F (m, 3)), list of (m_i, 3) int)
        The meshes it was built from (length units, the body at its place) and, per mesh,
        the vertex each face corner's derivative goes to (numbered over the side).
    turn : numpy.ndarray, shape (3, 3), optional
        The body's derivatives are wanted for its vertices before this rotation (``x -> turn
        x``); None: as placed.
    """
    hand_src, body_src = intersector.face_sources
    c = intersector.origin
    wa, na, ta = _side_tables(hand[0], hand_src, hand[1], c)
    wb, nb, tb = _side_tables(body[0], body_src, body[1], c)
    if turn is not None:
        nb = nb @ turn
    # The tables `vertex_gradients` runs the kernel with: a marker per part and per vertex.
    mom = intersector.vertex_moment_tables
    return VertexTables(
        np.concatenate([wa, wb]),
        np.concatenate([na, nb]),
        np.concatenate([ta, tb]),
        np.array([len(hand_src)], np.int64),
        mom.part_from,
        *_part_sums(mom, wa, na, ta),
    )


def _part_sums(mom, weights, directions, targets):
    """Per marker (`tables.MomentTables.part_start` ...), what its entries give each hand vertex
    (`VertexTables.part_start`, ``part_targets``, ``part_vectors``), from the hand's rows'
    ``weights``, ``directions`` and ``targets`` (`_side_tables`)."""
    n_parts = len(mom.part_start) - 1
    rows = mom.part_link
    w = np.einsum("ecd,ed->ec", weights[rows], mom.part_moments)
    vectors = (w[:, :, None] * directions[rows][:, None, :]).reshape(-1, 3)
    n = int(targets.max()) + 1 if len(targets) else 1
    part = np.repeat(np.arange(n_parts), np.diff(mom.part_start))
    keys, back = np.unique((part[:, None] * n + targets[rows]).reshape(-1), return_inverse=True)
    sums = np.zeros((len(keys), 3))
    np.add.at(sums, back.reshape(-1), vectors)
    start = np.zeros(n_parts + 1, np.int64)
    np.cumsum(np.bincount(keys // n, minlength=n_parts), out=start[1:])
    return start, (keys % n).astype(np.int64), sums


def vertex_gradients(
    intersector: ExactIntersector,
    tables: VertexTables,
    poses: np.ndarray,
    out_a: np.ndarray,
    out_b: np.ndarray,
) -> np.ndarray:
    """Volumes (k,) of poses (k, 4, 4), their derivatives by every vertex written to ``out_a``
    (k, n_a, 3) and ``out_b`` (k, n_b, 3) (every element; squared length units), as
    ``tables`` (`vertex_tables`) numbers and turns them."""
    tables_run = intersector.vertex_moment_tables
    return intersector.moment_entries(poses, tables_run, (tables, out_a, out_b))[0]


def mesh_tables(
    intersector: ExactIntersector,
    hand: list[tuple[np.ndarray, np.ndarray]],
    bodies: list[tuple[np.ndarray, np.ndarray]],
) -> VertexTables:
    """`vertex_tables` of an intersector built with ``faces=True`` from ``hand`` and
    ``bodies`` (lists of (V (n, 3), F (m, 3))), each side's vertices numbered in order."""
    sides = []
    for meshes in (hand, bodies):
        offsets = np.cumsum([0] + [len(V) for V, _ in meshes])
        sides.append((meshes, [F + o for (_, F), o in zip(meshes, offsets, strict=False)]))
    return vertex_tables(intersector, sides[0], sides[1])


def mesh_vertex_gradients(
    intersector: ExactIntersector,
    hand: list[tuple[np.ndarray, np.ndarray]],
    bodies: list[tuple[np.ndarray, np.ndarray]],
    poses: np.ndarray,
    tables: VertexTables | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Volumes and the volume's derivative by every vertex of the hand's links and of the
    object's bodies (each in its own frame), for poses (k, 4, 4).

    Parameters
    ----------
    intersector : ExactIntersector
        Built with ``faces=True`` from ``hand`` and ``bodies``.
    hand, bodies : list of (V (n, 3), F (m, 3))
        The meshes it was built from (length units).
    poses : numpy.ndarray, shape (k, 4, 4)
        Checked rigid motions of the bodies.
    tables : VertexTables, optional
        `mesh_tables` of the same (made here where None).

    Returns
    -------
    volumes : numpy.ndarray, shape (k,)
    hand_grads, body_grads : numpy.ndarray, shapes (k, Σ n_hand, 3) and (k, Σ n_body, 3)
        The meshes' vertices in order, squared length units (volume per length of vertex
        motion); a body's in its own frame (``R^T`` of the derivative by its moved vertex).
    """
    tables = mesh_tables(intersector, hand, bodies) if tables is None else tables
    out_a = np.empty((len(poses), sum(len(V) for V, _ in hand), 3))
    out_b = np.empty((len(poses), sum(len(V) for V, _ in bodies), 3))
    volumes = vertex_gradients(intersector, tables, poses, out_a, out_b)
    return volumes, out_a, out_b
