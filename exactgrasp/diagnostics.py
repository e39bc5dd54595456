"""What users are warned about: suspicious grasps, and the warnings kept from them.

`check_descriptor` looks at a grasp and its descriptor values once, warns (through
`exactgrasp.errors.warn_caller`) about grasps whose descriptor is probably not what was meant,
and returns the metadata entries that record it; `exactgrasp.descriptor.compute_descriptor`
calls it. `third_party_warnings_ignored` keeps warnings raised inside the libraries under
exactgrasp (dask, trimesh, mujoco, ...) from the users of `run_batch` and of the command line.
See ``docs/diagnostics.md``.
"""

from __future__ import annotations

import contextlib
import functools
import re
import warnings
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

from exactgrasp.cache import LRUCache
from exactgrasp.errors import warn_caller

if TYPE_CHECKING:
    from exactgrasp.backends import Backend
    from exactgrasp.grasp import Grasp

__all__ = [
    "GAP_TOLERANCE",
    "MINKOWSKI_POINTS",
    "PENETRATION_LIMIT",
    "SIZE_RATIO_RANGE",
    "THIRD_PARTY_PACKAGES",
    "VALUE_LIMIT",
    "VALUE_TOLERANCE",
    "check_descriptor",
    "hull_gap",
    "ignores_third_party_warnings",
    "third_party_warnings_ignored",
]

#: Warn when, at the grasp pose itself, hand ∩ object exceeds this fraction of the smaller of
#: the object's and the hand's volumes (a grasp in contact overlaps by a few percent at most).
PENETRATION_LIMIT = 0.10
#: Values are volume(hand ∩ object) / volume(hand), at most 1 for a true intersection; warn
#: above this (an estimator over-counting, typically for an object larger than the hand).
VALUE_LIMIT = 1.0
#: Relative slack on `VALUE_LIMIT`: the exact backend's agreement with manifold3d's boolean.
VALUE_TOLERANCE = 1e-9
#: Plausible range of the object's size over the hand's (longest sides of their bounding boxes,
#: the hand posed): a grasped object from a few millimetres to a few metres beside a 25 cm hand.
#: A units mistake moves the ratio by 10 (cm), 25.4 (inch) or 1000 (mm): outside this range the
#: descriptor is warned about, naming the likely mistake.
SIZE_RATIO_RANGE = (0.01, 10.0)
#: Convex hulls closer than this (m) are taken to touch.
GAP_TOLERANCE = 1e-9
#: Most points of the Minkowski difference `hull_gap` builds; above it, the larger hull's
#: vertices are thinned (the gap found is then at most slightly too large).
MINKOWSKI_POINTS = 1_000_000
#: Points tested against a hull at a time by the touching test, which stops at the first inside.
INSIDE_BLOCK = 64
#: Top-level packages whose own warnings `third_party_warnings_ignored` drops: the libraries
#: exactgrasp calls, and the ones they call (dask's stack).
THIRD_PARTY_PACKAGES = (
    "dask", "distributed", "tornado", "cloudpickle", "msgpack", "zict", "toolz", "tlz",
    "partd", "fsspec", "psutil", "bokeh", "pandas", "pyarrow", "numpy",
    "scipy", "trimesh", "networkx", "rtree", "lxml", "manifold3d", "mujoco", "coal", "fcl",
    "pymeshfix", "pyvista", "vtk", "matplotlib", "PIL", "plotly", "tqdm", "jsonschema",
)  # fmt: skip
_THIRD_PARTY_MODULE = rf"({'|'.join(map(re.escape, THIRD_PARTY_PACKAGES))})(\.|$)"

# Convex hulls of posed hands and of objects in their own coordinates, reused across the
# descriptors of one hand or one object.
_HAND_HULLS = LRUCache(16)
_OBJECT_HULLS = LRUCache(16)


@contextlib.contextmanager
def third_party_warnings_ignored() -> Iterator[None]:
    """Drop, inside the block, warnings raised inside the packages of `THIRD_PARTY_PACKAGES`.

    A warning belongs to the module its ``stacklevel`` points at, so exactgrasp's warnings
    (attributed to the caller's line by `exactgrasp.errors.warn_caller`) and the caller's own
    still show, as they do under ``-W error``. The previous filters come back on the way out
    (not thread-safe, as `warnings.catch_warnings`).
    """
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", module=_THIRD_PARTY_MODULE)
        yield


def ignores_third_party_warnings(function: Callable) -> Callable:
    """Decorate an entry point so that it runs inside `third_party_warnings_ignored`.

    The wrapper is defined here, inside the package, so that `exactgrasp.errors.warn_caller`
    passes over its frame (a ``contextlib`` decorator's frame would take the warnings).
    """

    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with third_party_warnings_ignored():
            return function(*args, **kwargs)

    return wrapper


# -- convex hulls -------------------------------------------------------------------------------


def _hull_vertices(points: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices (k, 3), facet equations (f, 4)) of the convex hull, None when degenerate."""
    from scipy import spatial  # here, not above: the command line's --help imports this module

    try:
        hull = spatial.ConvexHull(points)
    except (spatial.QhullError, ValueError):
        return None
    return points[hull.vertices], hull.equations


def _inside(equations: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Whether each point (n, 3) lies in the hull of these facet equations (n·x + d <= 0)."""
    scale = max(float(np.abs(points).max(initial=0.0)), 1.0)
    # Broadcast sums, not a matrix product: BLAS threads cost more than these few products.
    side = equations[:, 3] + sum(points[:, k, None] * equations[:, k] for k in range(3))
    return np.all(side <= GAP_TOLERANCE * scale, axis=1)


def _origin_distance(points: np.ndarray, triangles: np.ndarray) -> float:
    """Distance from the origin to the surface of triangles (f, 3) of ``points`` (n, 3)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    height = np.einsum("ij,ij->i", a, normal)
    foot = height[:, None] * normal
    # The foot of the perpendicular is in the triangle when it is left of all three edges.
    inside = np.ones(len(a), dtype=bool)
    for p, q in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(q - p, foot - p), normal) >= 0
    best = float(np.abs(height[inside]).min(initial=np.inf))
    for p, q in ((a, b), (b, c), (c, a)):
        edge = q - p
        t = np.clip(-np.einsum("ij,ij->i", p, edge) / np.einsum("ij,ij->i", edge, edge), 0, 1)
        best = min(best, float(np.linalg.norm(p + t[:, None] * edge, axis=1).min()))
    return best


def hull_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between the convex hulls of two point sets; 0 when they meet.

    Parameters
    ----------
    a, b : numpy.ndarray, shape (n, 3) and (m, 3)
        Points, in one frame and one length unit.

    Returns
    -------
    float
        In the unit of the points: the distance from the origin to the convex hull of the
        Minkowski difference ``a - b`` (exact, unless more than `MINKOWSKI_POINTS` points
        would be needed: then slightly too large). 0 when either hull is flat.
    """
    hull_a, hull_b = _hull_vertices(np.asarray(a, float)), _hull_vertices(np.asarray(b, float))
    if hull_a is None or hull_b is None:
        return 0.0
    return _gap(hull_a, hull_b)


def _gap(hull_a: tuple, hull_b: tuple) -> float:
    (va, ea), (vb, eb) = hull_a, hull_b
    boxes_apart = np.any(va.min(axis=0) > vb.max(axis=0)) or np.any(
        vb.min(axis=0) > va.max(axis=0)
    )
    if not boxes_apart and (
        _any_inside(eb, va, vb.mean(axis=0)) or _any_inside(ea, vb, va.mean(axis=0))
    ):
        return 0.0
    if len(va) * len(vb) > MINKOWSKI_POINTS:
        many, few = (va, vb) if len(va) >= len(vb) else (vb, va)
        step = -(-len(many) * len(few) // MINKOWSKI_POINTS)
        va, vb = (many[::step], few) if many is va else (few, many[::step])
    from scipy import spatial

    difference = (va[:, None, :] - vb[None, :, :]).reshape(-1, 3)
    try:
        hull = spatial.ConvexHull(difference)
    except spatial.QhullError:
        return 0.0
    if np.all(hull.equations[:, 3] <= 0.0):  # the origin is inside: the hulls meet
        return 0.0
    return _origin_distance(hull.points, hull.simplices)


def _any_inside(equations: np.ndarray, points: np.ndarray, centre: np.ndarray) -> bool:
    """Whether any point lies in the hull; nearest ``centre`` first, so that a grasped object
    usually answers within the first block."""
    order = np.argsort(np.sum((points - centre) ** 2, axis=1))
    for start in range(0, len(order), INSIDE_BLOCK):
        if _inside(equations, points[order[start : start + INSIDE_BLOCK]]).any():
            return True
    return False


def _hand_hull(grasp: Grasp) -> tuple | None:
    def build():
        return _hull_vertices(np.concatenate([v for v, _ in grasp.hand.link_arrays()]))

    return _HAND_HULLS.get(grasp.hand_key, build)


def _object_hull_in_hand(grasp: Grasp) -> tuple | None:
    obj = grasp.object
    hull = _OBJECT_HULLS.get(obj.hash, lambda: _hull_vertices(obj.vertices))
    if hull is None:
        return None
    pose = grasp.object_pose
    vertices, equations = hull
    rotation, shift = pose[:3, :3], pose[:3, 3]
    moved = equations.copy()
    moved[:, :3] = equations[:, :3] @ rotation.T
    moved[:, 3] = equations[:, 3] - moved[:, :3] @ shift
    return vertices @ rotation.T + shift, moved


def grasp_hull_gap(grasp: Grasp) -> float:
    """Distance (m) from the object at the grasp pose to the convex hull of the hand; 0 when
    the object's convex hull meets it."""
    hand, obj = _hand_hull(grasp), _object_hull_in_hand(grasp)
    if hand is None or obj is None:
        return 0.0
    return _gap(hand, obj)


# -- the checks ---------------------------------------------------------------------------------


def check_descriptor(
    grasp: Grasp, values: np.ndarray, backend: Backend, hand_volume: float | None = None
) -> dict[str, Any]:
    """Check a grasp and its descriptor values; warn once per finding.

    Warns when the object is implausibly small or large beside the hand
    (`SIZE_RATIO_RANGE`: usually a units mistake), when the object does not reach the convex
    hull of the hand (every value is then 0), when every value is 0 for another reason, when
    the object overlaps the hand at the grasp pose by more than `PENETRATION_LIMIT` of the
    smaller volume, and when a value exceeds
    `VALUE_LIMIT`.

    Parameters
    ----------
    grasp : Grasp
    values : numpy.ndarray, shape (n_paths, n_steps)
        Intersection volume / hand volume (dimensionless).
    backend : Backend
        The backend that computed ``values``; asked for one more pose, the grasp pose itself,
        unless the object is away from the hand.
    hand_volume : float, optional
        The hand's volume (m^3) when the caller has it already; else ``grasp.hand.volume``.

    Returns
    -------
    dict
        Metadata entries: ``max_value`` (the largest value), ``volume_ratio`` (object volume
        / hand volume), ``size_ratio`` (the object's longest bounding-box side over the posed
        hand's), ``hull_gap_m`` (m, 0 when the object reaches the hand's convex hull),
        ``grasp_overlap`` (hand ∩ object at the grasp pose / the smaller volume, as
        ``backend`` measures it), ``warnings`` (the messages issued, a list of str).
    """
    name = f"grasp {grasp.name!r}" if grasp.name else "the grasp"
    max_value = float(values.max(initial=0.0))
    if hand_volume is None:
        hand_volume = grasp.hand.volume
    object_volume = grasp.object.volume
    ratio = object_volume / hand_volume
    gap = grasp_hull_gap(grasp)
    overlap = 0.0
    size_ratio, size_message = _size_check(grasp, name)
    messages = [size_message] if size_message else []
    if gap > GAP_TOLERANCE:
        messages.append(
            f"{name}: the object does not reach the hand's convex hull (it is {_length(gap)} "
            "away at the grasp pose), so every value of its descriptor is 0; check the object "
            "pose (object coordinates to hand coordinates, metres) and the object's units."
        )
    else:
        smaller = min(hand_volume, object_volume)
        pose = np.eye(4)[None]
        volume_m3 = float(backend.volumes(grasp, pose)[0]) / grasp.frame.scale**3
        overlap = volume_m3 / smaller
        if overlap > PENETRATION_LIMIT:
            which = "object's" if object_volume <= hand_volume else "hand's"
            messages.append(
                f"{name}: at the grasp pose the object already overlaps the hand by "
                f"{overlap:.0%} of the {which} volume ({volume_m3:.3g} m^3 by the "
                f"{backend.name} backend; warned above {PENETRATION_LIMIT:.0%}): it sits inside "
                "the hand rather than against it; check the object pose and the object's units."
            )
        if max_value == 0.0:
            messages.append(
                f"{name}: every value of its descriptor is 0: the object does not meet the "
                "hand at any pose of the sampler; check the object pose and the sampler."
            )
    if max_value > VALUE_LIMIT * (1.0 + VALUE_TOLERANCE):
        messages.append(
            f"{name}: descriptor values reach {max_value:.3g}, above {VALUE_LIMIT:g}; a value "
            "is intersection volume / hand volume, which a true intersection never exceeds, "
            f"so the {backend.name} backend over-counts here (the object's volume is "
            f"{ratio:.3g} times the hand's). The exact backend gives true values; check the "
            "object's units."
        )
    for message in messages:
        warn_caller(message)
    return {
        "max_value": max_value,
        "volume_ratio": ratio,
        "size_ratio": size_ratio,
        "hull_gap_m": gap,
        "grasp_overlap": overlap,
        "warnings": messages,
    }


def _size_check(grasp: Grasp, name: str) -> tuple[float, str | None]:
    """The object's size over the hand's, and the warning when it is outside
    `SIZE_RATIO_RANGE` (None inside)."""
    hull = _hand_hull(grasp)
    hand_vertices = (
        hull[0] if hull is not None else np.concatenate([v for v, _ in grasp.hand.link_arrays()])
    )
    hand_size = float(np.ptp(hand_vertices, axis=0).max())
    object_size = grasp.object.extent
    ratio = object_size / hand_size
    low, high = SIZE_RATIO_RANGE
    sizes = f"the object is {_size(object_size)} across, the hand {_size(hand_size)}"
    fix = (
        "check the units the object and the hand were read in (units= of Solid.from_file and "
        'Hand.from_file, "object_units" in a grasp file, --units on the command line).'
    )
    if ratio < low:
        return ratio, (
            f"{name}: the object is {1 / ratio:,.0f} times smaller than the hand ({sizes}); an "
            "object modelled in metres and read as millimetres (units='mm'), or a hand "
            f"modelled in millimetres and read as metres, looks like this; {fix}"
        )
    if ratio > high:
        return ratio, (
            f"{name}: the object is {ratio:,.3g} times larger than the hand ({sizes}); an "
            "object modelled in centimetres or inches and read as metres (units='m', the "
            "default), or a hand modelled in metres and read as millimetres, looks like this; "
            f"{fix}"
        )
    return ratio, None


def _size(metres: float) -> str:
    return f"{metres * 1000:.3g} mm" if metres < 1.0 else f"{metres:.3g} m"


def _length(metres: float) -> str:
    return f"{metres * 1000:.1f} mm" if metres < 1.0 else f"{metres:.3g} m"
