"""Cold start: one voxel and one exact descriptor in a fresh process, empty numba cache or full.

The winding-number, crossing and voxel kernels are compiled when the package is built
(Cython): a cold run compiles only the numba kernels that remain (the exact backend's, with the
orientation predicates they call). ``--again`` also computes each descriptor a second time in
the same process (phase ``<backend> again``: every kernel, grid and cache warm) and prints the
first descriptor's time over that warm one's.

Each run is a new Python process with ``NUMBA_CACHE_DIR`` pointing at a folder of its own, so
the package's own ``__pycache__`` is never read or written. A cold run starts from an empty
folder (every kernel is compiled); the warm run after it is a second process on the folder the
cold run filled (every kernel is loaded from the cache). Each process imports `exactgrasp`,
reads the real spray-bottle grasp (``barrett-grasps/noise/spray_bottle_base.json``: the
authors' Barrett URDF and the bottle) with `Grasp.from_file`, then computes
`compute_descriptor(grasp, "balanced", backend=...)` with the library's defaults, voxel first
and exact second (``--order`` swaps them). Reported per phase: the median over ``--repeat``
cold/warm pairs (3 by default), wall seconds and CPU seconds (all threads; on a shared machine
the CPU seconds move less than the wall seconds). The compile notice is silenced
(``EXACTGRASP_NO_PROGRESS=1``).

``--functions`` also records every numba function compiled: CPU seconds of the compiling
thread (inclusive of the functions compiled for it, and its own share), the signatures it was
compiled for and what needed it (another function, or ``python:<module>``). They come from
numba's ``numba:compile`` event, which fires on a cache miss only: a warm run records none.

    python benchmarks/cold_start.py [--repeat 3] [--functions] [--order voxel,exact] [--again]
                                    [--builtin] [--json results.json]

``--builtin`` uses the README's first grasp instead: the built-in Barrett hand, fingers half
closed, on the built-in 6 x 10 x 10 cm box (no data folder needed; building the hand from its
model runs the geometry's shell check, whose crossing kernels are compiled Cython: with the
voxel backend alone, a cold run compiles nothing).

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


def _record_compiles() -> list[dict]:
    """Start recording numba compilations; returns the list the records go to.

    One record per function and signature compiled: ``function``, ``signature``, ``parent``
    (the function whose compilation needed it, or ``python:<module>`` for a kernel called from
    Python), ``total`` and ``own`` CPU seconds of the compiling thread (own leaves out the
    functions compiled for this one).
    """
    from numba.core import event

    records: list[dict] = []
    stack: list[list] = []

    def name_of(dispatcher) -> str:
        fn = dispatcher.py_func
        return f"{fn.__module__}.{fn.__qualname__}"

    class Recorder(event.Listener):
        def on_start(self, ev):
            if stack:
                parent = name_of(stack[-1][0])
            else:
                frame = sys._getframe(1)
                while frame is not None and not frame.f_globals.get("__name__", "").startswith(
                    "exactgrasp."
                ):
                    frame = frame.f_back
                parent = "python:" + (frame.f_globals["__name__"] if frame else "?")
            stack.append([ev.data["dispatcher"], ev.data["args"], time.thread_time(), 0.0, parent])

        def on_end(self, ev):
            dispatcher, args, start, inner, parent = stack.pop()
            total = time.thread_time() - start
            if stack:
                stack[-1][3] += total
            records.append(
                {
                    "function": name_of(dispatcher),
                    "signature": str(tuple(args)),
                    "parent": parent,
                    "total": total,
                    "own": total - inner,
                }
            )

    event.register("numba:compile", Recorder())
    return records


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


def child(data: Path | None, order: list[str], functions: bool, again: bool = False) -> dict:
    """One process's phases (seconds), and its compile records if asked."""
    clock = [time.perf_counter(), time.process_time()]
    times, cpu = {}, {}

    def lap(phase):
        now = [time.perf_counter(), time.process_time()]
        times[phase], cpu[phase] = now[0] - clock[0], now[1] - clock[1]
        clock[:] = now

    sys.path.insert(0, str(ROOT))
    records = _record_compiles() if functions else None
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
    return {"seconds": times, "cpu_seconds": cpu, "sums": values, "compiles": records}


def run_child(cache: Path, args: argparse.Namespace) -> dict:
    """Run `child` in a fresh process with ``NUMBA_CACHE_DIR=cache``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), EXACTGRASP_NO_PROGRESS="1")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--data", str(args.data)]
    cmd += ["--builtin"] if args.builtin else []
    cmd += ["--order", ",".join(args.order)] + (["--functions"] if args.functions else [])
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


def function_table(runs: list[dict]) -> list[tuple[str, int, float, float, str]]:
    """Per function over the cold runs: (name, signatures, median own s, median inclusive s,
    what it was compiled for), heaviest first."""
    per_run = []
    for run in runs:
        table: dict[str, list] = {}
        for rec in run["compiles"]:
            row = table.setdefault(rec["function"], [set(), 0.0, 0.0, set()])
            row[0].add(rec["signature"])
            row[1] += rec["own"]
            row[2] += rec["total"]
            row[3].add(rec["parent"].rsplit(".", 1)[-1])
        per_run.append(table)
    rows = []
    for name in {n for t in per_run for n in t}:
        got = [t[name] for t in per_run if name in t]
        rows.append(
            (
                name,
                max(len(r[0]) for r in got),
                statistics.median(r[1] for r in got),
                statistics.median(r[2] for r in got),
                ", ".join(sorted(set().union(*(r[3] for r in got)))),
            )
        )
    return sorted(rows, key=lambda r: -r[2])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="cold/warm pairs (median reported)")
    ap.add_argument("--order", type=lambda s: s.split(","), default=["voxel", "exact"])
    ap.add_argument("--functions", action="store_true", help="per-function compile seconds")
    ap.add_argument("--again", action="store_true", help="each descriptor again, warm")
    ap.add_argument("--builtin", action="store_true", help="the README's built-in grasp")
    ap.add_argument("--top", type=int, default=40, help="functions listed (default 40)")
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--json", type=Path, help="also write every run to this JSON file")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        data = None if args.builtin else args.data
        print(json.dumps(child(data, args.order, args.functions, args.again)))
        return 0
    if not args.builtin and not (args.data / GRASP).is_file():
        print(f"skipped: real data not found at {(args.data / GRASP).resolve()}")
        return 0
    runs = {"cold": [], "warm": []}
    for _ in range(max(1, args.repeat)):
        with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
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
    if args.functions:
        warm = sum(len(r["compiles"]) for r in runs["warm"])
        print(f"functions compiled in the warm runs: {warm}")
        rows = function_table(runs["cold"])
        total = sum(r[2] for r in rows)
        print(f"\ncompiled functions (cold runs, median CPU s; own s sum to {total:.1f}):")
        print(f"{'own s':>7} {'incl s':>7} {'sigs':>4}  function  [compiled for]")
        for name, sigs, own, incl, parents in rows[: args.top]:
            print(f"{own:>7.2f} {incl:>7.2f} {sigs:>4}  {name}  [{parents}]")
    if args.json:
        args.json.write_text(json.dumps(runs, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
