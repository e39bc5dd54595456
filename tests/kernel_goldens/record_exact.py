"""Record what the exact kernel (`pose_volumes`) returns on fixed scenes.

``numba_exact.npz`` in this folder holds, per scene, the poses and everything the numba kernel
of commit 09a1e26 (the last with it) returned for them: volumes, bounds, codes, statistics and
the moment entries (``start``, and a SHA-256 of ``rows`` and ``values``), recorded with that
commit's package::

    python tests/kernel_goldens/record_exact.py   # writes numba_exact.npz beside it

The scenes (`scenes`): the built-in Barrett hand (medial joints at 1 rad) with the bottle, the
box (most of the hand inside) and the cylinder, 96 poses each around a grasp, with volumes only,
with moments per link and with moments per face of both meshes; the same hand and box scaled
by 1e-3 and by 1e3 and moved far from the origin; a pose set with a crossing capacity of 16
(poses that overflow it); and the touching solids of `tests.touching_meshes` against a ball
and against boxes on their special lines. The tables the kernel reads are built again from the
scenes each time, so the check covers the compiled grid rasteriser and face terms too.

`tests/test_exact_kernel_goldens.py` checks that the compiled kernel gives the same results to
the bit. Run this again only to add a case on purpose (the file then records the kernel of the day,
which the test can no longer compare with numba's).
"""

from __future__ import annotations

import hashlib
import sys
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
OUT = HERE / "numba_exact.npz"
OUTPUTS = ("volumes", "bounds", "codes", "stats", "start", "rows", "values")
#: Outputs stored as a SHA-256 of their bytes (dtype and shape included), the rest in full.
HASHED = ("rows", "values")
#: Where the built-in objects sit in the hand's frame (m).
LIFT = np.array([0.0, 0.0, 0.08])
#: Poses per built-in scene and per touching scene with a ball.
POSES = 96

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def _poses(rng, n, spread=0.01, turn=0.1, scale=1.0):
    from scipy.spatial.transform import Rotation

    poses = np.tile(np.eye(4), (n, 1, 1))
    poses[:, :3, :3] = Rotation.from_rotvec(rng.uniform(-turn, turn, (n, 3))).as_matrix()
    poses[:, :3, 3] = rng.uniform(-spread, spread, (n, 3)) * scale
    return poses


def _barrett_scenes(rng):
    """(label, hand links, object bodies, poses, faces, moments, capacity) of the built-in
    hand; poses in the hand's frame."""
    import exactgrasp as eg

    hand = eg.hands.barrett()
    hand = hand.with_joints({n: 1.0 for n in hand.joint_names if "med" in n})
    links = hand.link_arrays()
    for name in ("bottle_with_handle", "box", "cylinder"):
        obj = eg.objects.get(name)
        body = [(obj.vertices + LIFT, obj.faces)]
        poses = _poses(rng, POSES)
        yield f"barrett/{name}/volumes", links, body, poses, False, False, None
        yield f"barrett/{name}/links", links, body, poses, False, True, None
        yield f"barrett/{name}/faces", links, body, poses, True, True, None
    obj = eg.objects.get("box")
    for tag, s, shift in (("1e-3", 1e-3, 0.0), ("1e3", 1e3, 0.0), ("far", 1.0, 700.0)):
        moved = [(V * s + shift, F) for V, F in links]
        body = [((obj.vertices + LIFT) * s + shift, obj.faces)]
        poses = _poses(rng, POSES // 2, scale=s)
        yield f"barrett/box/{tag}", moved, body, poses, True, True, None
    obj = eg.objects.get("bottle_with_handle")
    body = [(obj.vertices + LIFT, obj.faces)]
    yield "barrett/bottle/capacity16", links, body, _poses(rng, 32), False, True, 16


def _touching_scenes(rng):
    """The touching family (`tests.touching_meshes.scenes`), each scene once (the solid as
    the hand, the box or ball as the object); a pre-moved object at the identity pose."""
    import trimesh

    from tests.touching_meshes import scenes

    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    ball = (np.asarray(ball.vertices), np.asarray(ball.faces))
    for label, solid, obj, poses, _ in scenes(rng, ball, n_ball=POSES // 4):
        if poses is None:
            poses = np.eye(4)[None]
        yield f"touching/{label}", solid, obj, poses, True, True, None


def digest(a: np.ndarray) -> np.ndarray:
    """A SHA-256 of an array's dtype, shape and bytes, as a string array."""
    h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode())
    h.update(np.ascontiguousarray(a).tobytes())
    return np.array(h.hexdigest())


def scenes(rng=None):
    """Every scene the goldens hold, from a fixed seed."""
    rng = np.random.default_rng(20261205) if rng is None else rng
    yield from _barrett_scenes(rng)
    yield from _touching_scenes(rng)


def run_kernel(label, links, bodies, poses, faces, moments, capacity):
    """The kernel's raw outputs on one scene, as a dict of arrays (`OUTPUTS`), or None where
    the intake refuses the scene (recorded as refused)."""
    from exactgrasp.backends.exact import ExactBackend
    from exactgrasp.errors import ExactGraspError
    from exactgrasp.overlap import _operands

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if label.startswith("touching/"):
                # Read as solids, as `intersection` reads them (edges of four faces split).
                units = ("m", "m")
                links, bodies = _operands(links, bodies, units, repair=True, check_scale=False)
            x = ExactBackend().intersector_of(links, bodies, faces=faces)
    except ExactGraspError:
        return None
    # The same motions about the intersector's local origin c: x -> R x + (R c + t - c).
    local = np.array(poses, dtype=float)
    local[:, :3, 3] += local[:, :3, :3] @ x.origin - x.origin
    capacity = x.capacity if capacity is None else capacity
    o, b, c, st, entries = x._kernel(local, capacity, moments)
    start = np.append(entries.begin, entries.end[-1:])
    rows, values = entries.rows, entries.values
    return dict(volumes=o, bounds=b, codes=c, stats=st, start=start, rows=rows, values=values)


def main() -> int:
    record = {}
    refused = []
    for label, links, bodies, poses, faces, moments, capacity in scenes():
        got = run_kernel(label, links, bodies, poses, faces, moments, capacity)
        if got is None:
            refused.append(label)
            continue
        record[f"{label}/poses"] = poses
        for key in OUTPUTS:
            record[f"{label}/{key}"] = digest(got[key]) if key in HASHED else got[key]
    record["refused"] = np.array(refused)
    np.savez_compressed(OUT, **record)
    n = sum(1 for key in record if key.endswith("/codes"))
    print(f"{OUT.name}: {n} scenes, {len(refused)} refused")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
