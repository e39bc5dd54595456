"""The exact fallback's arrangement near the object against the whole surfaces' arrangement.

On the messy-hand scene of `exact_per_pose` (17 links, 272k triangles after intake, the
built-in bottle in its palm), the poses of the balanced preset that the kernel reads within
its bound of zero go to the exact arrangement (``pose_sources == "arrangement"``). For each,
times `ArrangedHand.volume` (only the faces near the moved object's box are cut; the hand
welded and its own contacts found once, before the timing) against `level_set` of the whole
surfaces (every face welded, cut and asked), each the median of ``--repeat`` runs in turn,
and checks that the exact volumes are equal.

    python benchmarks/exact_fallback.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np
from exact_per_pose import scene_and_poses


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    args.scene, args.data = "messy", None
    warnings.simplefilter("ignore")
    grasp, poses = scene_and_poses(args)
    from exactgrasp.backends.exact import ExactBackend
    from exactgrasp.backends.exact.arranged import moved_like_the_kernel
    from exactgrasp.geometry.level_sets import level_set

    backend = ExactBackend(broadphase=None, n_jobs=1)
    intersector = backend.intersector(grasp)
    local = poses.copy()
    local[:, :3, 3] += local[:, :3, :3] @ intersector.origin - intersector.origin
    sources = intersector.intersect(poses).pose_sources
    hand, obj = intersector.hand_mesh, intersector.object_mesh
    arranged = intersector.arranged
    print(f"{int((sources == 'arrangement').sum())} of {len(poses)} poses arranged")
    for i in np.flatnonzero(sources == "arrangement").tolist():
        near, whole = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            got = arranged.volume(obj.vertices, obj.faces, local[i])[2].volume
            t1 = time.perf_counter()
            moved = moved_like_the_kernel(obj.vertices, local[i])
            V = np.concatenate([hand.vertices, moved])
            F = np.concatenate([hand.faces, np.asarray(obj.faces) + len(hand.vertices)])
            want = level_set(V, F, 2).volume
            t2 = time.perf_counter()
            near.append(t1 - t0)
            whole.append(t2 - t1)
            assert got == want
        a, b = statistics.median(near), statistics.median(whole)
        print(f"pose {i}: near the object {a:.4f} s, whole surfaces {b:.4f} s: x{b / a:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
