"""The coal / python-fcl adapter: BVHs of triangle meshes, their distances, whole-pose culling.

The only module of exactgrasp that imports coal or fcl (both optional, extra ``exact``). Both
libraries take int64 triangles. `cached_bvh` builds a BVH once per engine and mesh content in
a process (kept in `BVHS`), to be posed by a rigid transform for each query: finger closing's
link BVHs, whatever the joint angles.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

from exactgrasp.cache import LRUCache, mesh_key
from exactgrasp.errors import require

__all__ = [
    "BVHS",
    "DEFAULT_ENGINE",
    "ENGINES",
    "MeshPair",
    "available_engines",
    "build_bvh",
    "cached_bvh",
    "distance",
    "require_engine",
]

#: BVH libraries by engine name: ``(module, pip package)``.
ENGINES = {"coal": ("coal", "coal"), "fcl": ("fcl", "python-fcl")}
#: The engine used unless one is asked for.
DEFAULT_ENGINE = "coal"
#: BVHs this process has built, by engine and mesh content (`cached_bvh`); ``BVHS.builds``
#: counts them.
BVHS = LRUCache(512)


def require_engine(engine: str, feature: str | None = None) -> Any:
    """Import the library of ``engine`` or raise `MissingDependencyError` naming it.

    Parameters
    ----------
    engine : {"coal", "fcl"}
    feature : str, optional
        What needs it, for the message (default: "BVH distances with <engine>").

    Returns
    -------
    module
        ``coal`` or ``fcl``.
    """
    if engine not in ENGINES:
        raise ValueError(f"unknown BVH engine {engine!r}; use one of {sorted(ENGINES)}")
    module, package = ENGINES[engine]
    return require(module, feature or f"BVH distances with {engine}", package, "exact")


def available_engines() -> set[str]:
    """The engines whose library is installed."""
    out = set()
    for engine in ENGINES:
        try:
            require_engine(engine)
        except ImportError:
            continue
        out.add(engine)
    return out


def build_bvh(engine: str, V: np.ndarray, F: np.ndarray) -> Any:
    """A bounding-volume hierarchy of a triangle mesh, in the mesh's own frame.

    Parameters
    ----------
    engine : {"coal", "fcl"}
    V : numpy.ndarray, shape (n, 3)
        Vertices (m).
    F : numpy.ndarray, shape (m, 3)
        Triangles (vertex indices).

    Returns
    -------
    coal.BVHModelOBBRSS or fcl.BVHModel
    """
    lib = require_engine(engine)
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    if engine == "coal":
        bvh = lib.BVHModelOBBRSS()
        bvh.beginModel(len(F), len(V))
        bvh.addVertices(V)
        bvh.addTriangles(F)
    else:
        bvh = lib.BVHModel()
        bvh.beginModel(len(F), len(V))
        bvh.addSubModel(V, F)
    bvh.endModel()
    return bvh


def cached_bvh(engine: str, V: np.ndarray, F: np.ndarray) -> Any:
    """`build_bvh` of a mesh, built once per engine and content (`exactgrasp.cache.mesh_key`)
    in this process and kept in `BVHS`; same parameters and result."""
    return BVHS.get((engine, mesh_key(V, F)), lambda: build_bvh(engine, V, F))


def _coal_transform(coal, pose: np.ndarray):
    return coal.Transform3s(pose[:3, :3].copy(), pose[:3, 3].copy())


def _fcl_transform(fcl, pose: np.ndarray):
    return fcl.Transform(pose[:3, :3].copy(), pose[:3, 3].copy())


def distance(engine: str, a: Any, pose_a: np.ndarray, b: Any, pose_b: np.ndarray) -> float:
    """Distance between two posed BVHs (m); 0 or negative when their surfaces cross.

    Safe to call from several threads on shared BVHs.

    Parameters
    ----------
    engine : {"coal", "fcl"}
        The engine that built ``a`` and ``b`` (`build_bvh`).
    a, b : BVH
    pose_a, pose_b : numpy.ndarray, shape (4, 4)
        Rigid poses of ``a`` and ``b`` in one common frame.

    Returns
    -------
    float
    """
    lib = require_engine(engine)
    if engine == "coal":
        tf_a, tf_b = _coal_transform(lib, pose_a), _coal_transform(lib, pose_b)
        return float(lib.distance(a, tf_a, b, tf_b, lib.DistanceRequest(), lib.DistanceResult()))
    # New collision objects per call: fcl objects carry their transform.
    obj_a = lib.CollisionObject(a, _fcl_transform(lib, pose_a))
    obj_b = lib.CollisionObject(b, _fcl_transform(lib, pose_b))
    return float(lib.distance(obj_a, obj_b, lib.DistanceRequest(), lib.DistanceResult()))


class MeshPair:
    """Two meshes with their BVHs: is the moved second one's surface far from the first's?

    Parameters
    ----------
    engine : {"coal", "fcl"}
    AV, AF : numpy.ndarray, shapes (n, 3) and (m, 3)
        The fixed mesh (vertices, triangles).
    BV, BF : numpy.ndarray, shapes (k, 3) and (l, 3)
        The moving mesh, in its own frame.
    gap : float
        Surfaces at most this far apart are "near" (same length unit as the vertices).
    feature : str, optional
        What needs the engine, for the missing-dependency message.
    """

    def __init__(self, engine: str, AV, AF, BV, BF, gap: float, feature: str | None = None):
        self.engine = engine
        self.gap = gap
        self._lib = lib = require_engine(engine, feature)
        a, b = build_bvh(engine, AV, AF), build_bvh(engine, BV, BF)
        if engine == "coal":
            self._a, self._b = a, b
        else:
            self._a = lib.CollisionObject(a, lib.Transform())
            self._b = lib.CollisionObject(b, lib.Transform())
            self._lock = threading.Lock()

    def far(self, pose: np.ndarray) -> bool:
        """True when the surfaces are certainly more than `gap` apart.

        Parameters
        ----------
        pose : numpy.ndarray, shape (4, 4)
            Rigid pose of the second mesh in the first's frame.
        """
        lib = self._lib
        if self.engine == "coal":
            # One collision test with the gap as its security margin ("in collision" when
            # nearer than the gap): no distance query, which costs several times more.
            req, res = lib.CollisionRequest(), lib.CollisionResult()
            req.security_margin = self.gap
            tf = _coal_transform(lib, pose)
            return lib.collide(self._a, lib.Transform3s(), self._b, tf, req, res) == 0
        with self._lock:  # fcl collision objects carry their transform: not thread-safe
            self._b.setTransform(_fcl_transform(lib, pose))
            if lib.collide(self._a, self._b, lib.CollisionRequest(), lib.CollisionResult()) > 0:
                return False
            dreq, dres = lib.DistanceRequest(), lib.DistanceResult()
            return lib.distance(self._a, self._b, dreq, dres) > self.gap
