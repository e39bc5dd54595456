"""Benchmark: the volume's derivative by every vertex against the volume alone.

The built-in Barrett hand (medial joints at 1 rad) and a built-in object (the bottle with a
handle, or the cylinder, or the box), placed in the hand, at ``--poses`` poses of the object
around that placement, 8 cm above the hand frame's origin (rotations up to 0.1 rad, translations
up to 1 cm, seeded). Times, each
the median of ``--repeat`` runs after a warm-up (kernel compilation):

* ``calls``: `exactgrasp.intersection_volume(grasp, poses)` against
  `exactgrasp.intersection_volume_gradients(grasp, poses)`, whole calls (each builds its own
  intersector, as a user's call does);
* ``per pose``: the same poses on intersectors built once, `ExactIntersector.volumes` against
  `face_gradients.mesh_vertex_gradients` (the kernel with per-face moments of both meshes, and
  their sums onto every vertex, into arrays made in each call), its `face_gradients.mesh_tables`
  made once with the intersector.

Prints both ratios (gradients / volumes), wall clock and CPU time of the process (all
threads), and the share of poses with a non-zero volume.

    python benchmarks/vertex_gradients.py [--object bottle_with_handle] [--poses 256]
        [--repeat 5] [--jobs 1] [--json results.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def timed(fn, repeat: int) -> tuple[float, float, list[float]]:
    """Median wall and CPU seconds of ``fn()`` over ``repeat`` runs, and the wall times."""
    wall, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(wall), statistics.median(cpu), wall


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--object", default="bottle_with_handle")
    ap.add_argument("--poses", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    import numpy as np
    from scipy.spatial.transform import Rotation

    import exactgrasp as eg
    from exactgrasp.backends.exact import ExactBackend
    from exactgrasp.backends.exact.face_gradients import mesh_tables, mesh_vertex_gradients

    hand = eg.hands.barrett()
    closing = {name: 1.0 for name in hand.joint_names if "med" in name}
    hand = hand.with_joints(closing)
    obj = eg.objects.get(args.object)
    place = np.eye(4)
    place[:3, 3] = (0.0, 0.0, 0.08)
    grasp = eg.Grasp(hand, obj, place, name="benchmark")
    rng = np.random.default_rng(0)
    poses = np.tile(np.eye(4), (args.poses, 1, 1))
    poses[:, :3, :3] = Rotation.from_rotvec(rng.uniform(-0.1, 0.1, (args.poses, 3))).as_matrix()
    poses[:, :3, 3] = rng.uniform(-0.01, 0.01, (args.poses, 3))
    backend = ExactBackend(n_jobs=args.jobs)

    volumes = lambda: eg.intersection_volume(grasp, poses=poses, backend=backend)  # noqa: E731
    gradients = lambda: eg.intersection_volume_gradients(grasp, poses=poses, backend=backend)  # noqa: E731

    v = volumes()
    r = gradients()
    # The per-face intersector's unions keep every input face (manifold3d face ids), so its
    # volumes agree with the plain call's to rounding, not bit for bit.
    assert np.abs(v - r.volumes).max() <= 1e-12 * max(np.abs(v).max(), 1e-300)
    calls_v = timed(volumes, args.repeat)
    calls_g = timed(gradients, args.repeat)
    A = hand.link_arrays()
    R, t = place[:3, :3], place[:3, 3]
    B = [(obj.vertices @ R.T + t, obj.faces)]
    plain = backend.intersector_of(A, B)
    faces = backend.intersector_of(A, B, faces=True)
    tables = mesh_tables(faces, A, B)
    plain.volumes(poses)
    mesh_vertex_gradients(faces, A, B, poses, tables)
    pose_v = timed(lambda: plain.volumes(poses), args.repeat)
    pose_g = timed(lambda: mesh_vertex_gradients(faces, A, B, poses, tables), args.repeat)
    row = {
        "date": time.strftime("%Y-%m-%d"),
        "object": args.object,
        "hand_faces": int(sum(len(f) for _, f in A)),
        "object_faces": len(obj.faces),
        "poses": args.poses,
        "non_zero": float(np.mean(v > 0)),
        "threads": args.jobs,
        "calls_volumes_s": calls_v[0],
        "calls_gradients_s": calls_g[0],
        "calls_ratio": calls_g[0] / calls_v[0],
        "calls_ratio_cpu": calls_g[1] / calls_v[1],
        "per_pose_volumes_ms": 1e3 * pose_v[0] / args.poses,
        "per_pose_gradients_ms": 1e3 * pose_g[0] / args.poses,
        "per_pose_ratio": pose_g[0] / pose_v[0],
        "per_pose_ratio_cpu": pose_g[1] / pose_v[1],
        "runs": {"calls": [calls_v[2], calls_g[2]], "per_pose": [pose_v[2], pose_g[2]]},
    }
    print(
        f"{args.object} ({row['object_faces']} faces) in the Barrett hand ({row['hand_faces']} "
        f"faces), {args.poses} poses ({100 * row['non_zero']:.0f} % non-zero), "
        f"{args.jobs} thread(s)\n"
        f"calls:    volumes {calls_v[0]:.3f} s, with vertex gradients {calls_g[0]:.3f} s: "
        f"x{row['calls_ratio']:.2f} wall, x{row['calls_ratio_cpu']:.2f} CPU\n"
        f"per pose: volumes {row['per_pose_volumes_ms']:.3f} ms, with vertex gradients "
        f"{row['per_pose_gradients_ms']:.3f} ms: x{row['per_pose_ratio']:.2f} wall, "
        f"x{row['per_pose_ratio_cpu']:.2f} CPU",
        flush=True,
    )
    if args.json:
        args.json.write_text(json.dumps(row, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
