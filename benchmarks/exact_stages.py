"""Where the exact kernel's time goes: its per-pose stages, one thread, on the real spray bottle.

The stages of ``pose.pose_volumes`` (move, near runs, seeds, pairs, classify, sum; see "Method,
per pose" in ``docs/exact-backend.md``) are composed here in a numba function that stops after
stage k, for k = 1, 2, ...; each stage's cost is the difference between consecutive stopping
points, over every distinct pose of the balanced preset (thread CPU seconds, median of
``--repeat`` runs). The full composition must give the kernel's volumes bit for bit, else the
script stops. Also printed: seeds, crossing pairs and hand parts per pose.

    python benchmarks/exact_stages.py [--repeat 3] [--json results.json]

Skips with a message when the data folder is absent.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from shared_data import add_data_options, data_or_skip  # noqa: E402

GRASP = "barrett-grasps/noise/spray_bottle_base.json"
STAGES = (
    "move the object",
    "near runs",
    "seeds: object edges",
    "seeds: co-tree edges",
    "pairs: traced curves",
    "classify vertices",
    "sum",
)


def staged_kernel():
    """A numba function running the kernel's stages on poses (k, 4, 4) up to stage ``upto``
    (1-based, `STAGES`); returns (volumes, seeds from object edges, seeds from co-tree edges,
    crossing pairs), or None where a pose needs larger tables (not on this grasp)."""
    from numba import njit

    from exactgrasp.backends.exact import pose as P
    from exactgrasp.backends.exact.classify import classify_vertices
    from exactgrasp.backends.exact.search import trace_pairs
    from exactgrasp.backends.exact.seeds import cotree_seeds, object_edge_seeds
    from exactgrasp.backends.exact.sums import volume_sum
    from exactgrasp.backends.exact.tables import GROW, OK
    from exactgrasp.backends.exact.tolerances import LENGTH_FLOOR

    @njit(nogil=True, error_model="numpy")
    def run(poses, hand_mesh, hand, hand_grid, object_mesh, obj, object_grid, tiny, cap, upto):
        work = P._workspace(
            hand_mesh, hand, hand_grid, object_mesh, object_grid, cap, P.PAIR_TABLE,
            P.SEED_ROWS, False,
        )  # fmt: skip
        scratch = P._scratch(hand_mesh, hand, hand_grid, object_mesh, obj, object_grid, cap, work)
        W = scratch.work
        out = np.zeros(poses.shape[0])
        counts = np.zeros(3, np.int64)
        amax = max(P._vertex_bound(hand_mesh.vertices), LENGTH_FLOOR)
        bmax = P._vertex_bound(object_mesh.vertices)
        token = -1
        for ip in range(poses.shape[0]):
            R, t = poses[ip, :3, :3], poses[ip, :3, 3]
            gb = P.move_object(
                R, t, object_mesh.vertices, object_mesh.faces, tiny, bmax, scratch.object_V,
                scratch.object_D, scratch.object_N,
            )  # fmt: skip
            if upto == 1:
                continue
            gscale = max(amax, gb)
            ferr = P.near_pass(R, t, gscale, hand, hand_grid, obj, object_grid, scratch)
            if upto == 2:
                continue
            P._clear_records(W)
            n1 = object_edge_seeds(
                object_mesh, obj, hand, hand_grid, scratch.object_V, scratch.near, gscale, W, 0
            )
            counts[0] += n1
            if upto == 3:
                continue
            n2 = cotree_seeds(
                hand_mesh, hand, obj, object_grid, R, t, scratch.near_cotree, gscale, ferr,
                hand_grid.cell, W, n1,
            )  # fmt: skip
            if n1 < 0 or n2 < 0:
                return None
            counts[1] += n2 - n1
            if upto == 4:
                continue
            seg, segerr, ncross, _, code = trace_pairs(
                hand_mesh, hand, object_mesh, obj, scratch.object_V, scratch.object_D,
                scratch.object_N, W, n2, gscale, gb, hand_grid.cell, ip + 1,
            )  # fmt: skip
            if code == GROW:
                return None
            counts[2] += ncross
            if upto == 5:
                continue
            code, token = classify_vertices(
                R, t, hand_mesh, hand, object_mesh, obj, hand_grid, object_grid, scratch, code,
                token, ferr,
            )  # fmt: skip
            if upto == 6:
                continue
            if code == OK:
                out[ip] = volume_sum(
                    hand_mesh, hand, object_mesh, obj, scratch, seg, segerr, gscale, gb
                )[0]
        return out, counts

    return run


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per stopping point (median)")
    add_data_options(ap)
    args = ap.parse_args(argv)
    data = data_or_skip(args, GRASP)
    if data is None:
        return 0
    from exactgrasp import Grasp
    from exactgrasp.backends.exact import ExactIntersector
    from exactgrasp.backends.exact.intersector import repeated_poses
    from exactgrasp.paths.sampler import PathSampler

    grasp = Grasp.from_file(data / GRASP)
    ex = ExactIntersector(
        grasp.canonical_hand_links(), grasp.canonical_object_bodies(), broadphase=None, n_jobs=1
    )
    every = PathSampler.preset("balanced").poses().reshape(-1, 4, 4)
    canonical = every[np.unique(repeated_poses(every))]
    # The same motions about the intersector's local origin c, as its kernel sees them.
    poses = np.array(canonical)
    poses[:, :3, 3] += poses[:, :3, :3] @ ex.origin - ex.origin
    tables = (
        ex.hand_mesh, ex.hand_tables, ex.hand_grid, ex.object_mesh, ex.object_tables,
        ex.object_grid, ex.tiny, ex.capacity,
    )  # fmt: skip
    run = staged_kernel()
    result = run(poses, *tables, len(STAGES))
    if result is None:
        print("a pose needs larger tables than the kernel's first ones; not timed")
        return 1
    volumes, counts = result
    whole = ex.intersect(canonical)
    kernel = whole.volumes
    if not np.array_equal(volumes, kernel):
        print("the staged composition does not give the kernel's volumes; not timed")
        return 1
    for upto in range(1, len(STAGES) + 1):
        run(poses, *tables, upto)  # compiled once per stopping point before timing
    seconds = {}
    for upto in range(1, len(STAGES) + 1):
        runs = []
        for _ in range(args.repeat):
            t0 = time.thread_time()
            run(poses, *tables, upto)
            runs.append(time.thread_time() - t0)
        seconds[upto] = float(np.median(runs))
    n = len(poses)
    print(f"{GRASP}: {n} distinct poses, one thread, median of {args.repeat}")
    rows = {}
    before = 0.0
    for upto, name in enumerate(STAGES, 1):
        ms = 1e3 * (seconds[upto] - before) / n
        rows[name] = ms
        print(f"  {name:28s} {ms:7.3f} ms a pose")
        before = seconds[upto]
    total = 1e3 * seconds[len(STAGES)] / n
    print(f"  {'all stages':28s} {total:7.3f} ms a pose")
    per_pose = {
        "seeds from object edges": counts[0] / n,
        "seeds from co-tree edges": counts[1] / n,
        "crossing face pairs": counts[2] / n,
        "pairs evaluated": whole.stats["pairs_tested"] / whole.stats["poses"],
        "hand parts classified vertex by vertex": whole.stats["parts_clipped"]
        / whole.stats["poses"],
        "hand parts": whole.stats["parts"],
    }
    for name, value in per_pose.items():
        print(f"  {name:40s} {value:9.1f} a pose" if name != "hand parts" else f"  {name} {value}")
    if args.json:
        args.json.write_text(
            json.dumps({"ms_per_pose": rows, "total_ms": total, "per_pose": per_pose}, indent=2)
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
