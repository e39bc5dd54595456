"""Cold start: one voxel and one exact descriptor in a fresh process, empty disk caches or full.

Every kernel is compiled when the package is built (Cython): nothing compiles at a first call,
so a fresh process pays for the import, reading the grasp and what each backend builds once
per hand and object. ``--again`` also computes each descriptor a second time in the same
process (phase ``<backend> again``: every grid and cache in memory warm) and prints the first
descriptor's time over that warm one's.

Each run is a new Python process with ``EXACTGRASP_CACHE`` pointing at a folder of its own. A
cold run starts from an empty folder (every link mesh and object is resolved); the warm run
after it is a second process on the folder the cold run filled (they are read back from
`exactgrasp.cache.DiskCache`). Each process imports `exactgrasp`, reads the real spray-bottle
grasp (``barrett-grasps/noise/spray_bottle_base.json``: the authors' Barrett URDF and the
bottle) with `Grasp.from_file`, then computes `compute_descriptor(grasp, "balanced",
backend=...)` with the library's defaults, voxel first and exact second (``--order`` swaps
them). Reported per phase: the median over ``--repeat`` cold/warm pairs (3 by default), wall
seconds and CPU seconds (all threads; on a shared machine the CPU seconds move less than the
wall seconds). Progress is silenced (``EXACTGRASP_NO_PROGRESS=1``).

    python benchmarks/cold_start.py [--repeat 3] [--order voxel,exact] [--again] [--builtin]
                                    [--json results.json]

``--builtin`` uses the README's first grasp instead: the built-in Barrett hand, fingers half
closed, on the built-in 6 x 10 x 10 cm box (no data folder needed).

Without ``--builtin``, needs the shared data folder (``$EXACTGRASP_DATA``, else
``../shared/data`` beside the repository; ``--data`` elsewhere); skips with a message when it
is absent.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# The data folder's helper alone: importing exactgrasp here would warm what is being timed.
_DATAPATH = importlib.util.spec_from_file_location("datapath", ROOT / "exactgrasp" / "datapath.py")
datapath = importlib.util.module_from_spec(_DATAPATH)
_DATAPATH.loader.exec_module(datapath)
DATA = datapath.data_dir()
GRASP = "barrett-grasps/noise/spray_bottle_base.json"
#: What ``--builtin`` computes, as the README's first example.
BUILTIN = "the README's grasp: built-in Barrett hand, 6 x 10 x 10 cm box"
PHASES = ("import", "load grasp", "voxel", "exact")


def builtin_grasp(eg):
    """The README's first grasp: the built-in hand, fingers half closed, on the box."""
    import numpy as np

    hand = eg.hands.barrett({f"finger_{i}_med_joint": 0.6 for i in (1, 2, 3)})
    pose = np.eye(4)
    pose[:3, 3] = (0.0, 0.0, 0.125)
    return eg.Grasp(hand, eg.objects.box((0.06, 0.1, 0.1)), pose, name="box")


def phases(order: list[str], again: bool) -> list[str]:
    """The phases a process times, in order (the whole process's wall time last)."""
    backends = [name for backend in order for name in (backend, f"{backend} again")[: 1 + again]]
    return [*PHASES[:2], *backends, "process"]


def child(data: Path | None, order: list[str], again: bool = False) -> dict:
    """One process's phases (seconds)."""
    clock = [time.perf_counter(), time.process_time()]
    times, cpu = {}, {}

    def lap(phase):
        now = [time.perf_counter(), time.process_time()]
        times[phase], cpu[phase] = now[0] - clock[0], now[1] - clock[1]
        clock[:] = now

    sys.path.insert(0, str(ROOT))
    import exactgrasp as eg

    lap("import")
    grasp = builtin_grasp(eg) if data is None else eg.Grasp.from_file(data / GRASP)
    lap("load grasp")
    values = {}
    for backend in order:
        d = eg.compute_descriptor(grasp, "balanced", backend=backend, progress=False)
        lap(backend)
        values[backend] = float(d.values.sum())
        if again:
            d = eg.compute_descriptor(grasp, "balanced", backend=backend, progress=False)
            lap(f"{backend} again")
            assert float(d.values.sum()) == values[backend]
    return {"seconds": times, "cpu_seconds": cpu, "sums": values}


def run_child(cache: Path, args: argparse.Namespace) -> dict:
    """Run `child` in a fresh process with ``EXACTGRASP_CACHE=cache``."""
    env = dict(os.environ, EXACTGRASP_CACHE=str(cache), EXACTGRASP_NO_PROGRESS="1")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--data", str(args.data)]
    cmd += ["--builtin"] if args.builtin else []
    cmd += ["--order", ",".join(args.order)]
    cmd += ["--again"] if args.again else []
    t0, r0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True, check=False)
    wall, r1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode:
        raise SystemExit(f"child failed:\n{out.stderr}")
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["seconds"]["process"] = wall
    result["cpu_seconds"]["process"] = r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime
    result["stderr"] = out.stderr
    return result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="cold/warm pairs (median reported)")
    ap.add_argument("--order", type=lambda s: s.split(","), default=["voxel", "exact"])
    ap.add_argument("--again", action="store_true", help="each descriptor again, warm")
    ap.add_argument("--builtin", action="store_true", help="the README's built-in grasp")
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--json", type=Path, help="also write every run to this JSON file")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        data = None if args.builtin else args.data
        print(json.dumps(child(data, args.order, args.again)))
        return 0
    if not args.builtin and not (args.data / GRASP).is_file():
        print(f"skipped: real data not found at {(args.data / GRASP).resolve()}")
        return 0
    runs = {"cold": [], "warm": []}
    for _ in range(max(1, args.repeat)):
        with tempfile.TemporaryDirectory(prefix="exactgrasp-cache-") as cache:
            runs["cold"].append(run_child(Path(cache), args))
            runs["warm"].append(run_child(Path(cache), args))
    columns = phases(args.order, args.again)
    what = BUILTIN if args.builtin else args.data / GRASP
    print(f"{what}, balanced preset, defaults; median of {len(runs['cold'])}")
    print(f"{'seconds':>10}" + "".join(f"{p:>14}" for p in columns))
    for kind, got in runs.items():
        med = [statistics.median(r["seconds"][p] for r in got) for p in columns]
        print(f"{kind:>10}" + "".join(f"{m:>14.3f}" for m in med))
    for kind, got in runs.items():
        med = [statistics.median(r["cpu_seconds"][p] for r in got) for p in columns]
        print(f"{kind + ' cpu':>10}" + "".join(f"{m:>14.3f}" for m in med))
    if args.again:
        for backend in args.order:
            for kind, got in runs.items():
                ratios = [r["seconds"][backend] / r["seconds"][f"{backend} again"] for r in got]
                print(
                    f"{backend}, {kind}: first descriptor / the same again, median "
                    f"{statistics.median(ratios):.1f}x (each run: "
                    + ", ".join(f"{x:.1f}" for x in ratios)
                    + ")"
                )
    sums = {kind: [r["sums"] for r in got] for kind, got in runs.items()}
    same = all(s == sums["cold"][0] for got in sums.values() for s in got)
    print(f"descriptors identical in every run: {same}")
    if args.json:
        args.json.write_text(json.dumps(runs, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
