"""Batch throughput on the human-study records: grasps per second, parallel efficiency, and what
a row costs inside a Dask worker against the same row in this process.

Rows: ``--records`` (24) of the shared data's raw study records
(``barrett-grasps/study-records/``), every k-th of the sorted list so that all 13 objects with a
closed mesh appear (the FoodClip's records are left out: its mesh needs ``--repair``). Every
row uses the same Barrett hand at its own joint angles.

``throughput``: for each backend, `exactgrasp.batch.run_batch` with **default options**
(sampler, backend parameters, part size) and 1 and 2 local workers, alternating which goes
first from one repeat to the next, the disk cache of the rows' resolved objects filled
beforehand as any later run over a dataset finds them. Reported per run:
grasps/s over ``compute_seconds`` (first task submitted to last part written; the workers'
start-up inside it, the cluster's start outside), the workers' CPU seconds over their busy
seconds (their thread use: 1.00 is one core each), each worker's busy seconds, and the 1-minute
load average before and after. Per backend: the speed-up (2 workers over 1, median over
repeats), the parallel efficiency (speed-up / 2), and whether ``descriptors.parquet`` came out
byte-identical. Before each repeat, what the machine itself gives: a loop of pure Python
arithmetic (no memory traffic, no library) run alone and then as two processes at once; their
speed-up is the most any two-process work can get at that moment (2.0 on two idle cores; less
where the cores are shared with other machines' work or are one core's two hardware threads).

``row-cost``: one local worker with one row per task, against `compute_rows` on one thread in
a fresh process of its own (spawned, as the worker is), on the same rows; the first row of
each (compiling, loading, preparing the hand) is left out. Median ratio over the rows, of the
wall seconds and of the computing thread's CPU seconds (which the machine's load inflates
much less).

``contention``: one row per task, 1 and 2 workers, alternating; per repeat, the median over
the rows (each worker's first left out: it prepares the hand) of a row's CPU seconds on its
computing thread with 2 workers over the same row's with 1. Above 1, the same work costs more
CPU while the other core computes too: what the cores share (caches, memory, the host), not
the batch.

``idle``: the CPU seconds a local cluster of 2 workers takes in 10 s while it computes nothing
(its scheduler, nannies and workers: dask's housekeeping, which the rows lose when every core
computes), with dask's defaults and with `exactgrasp.batch.worker.WORKER_CONFIG`.

The machine may be shared: compare figures only within one run of this script, and read the
load averages printed beside them.

Usage::

    python benchmarks/batch.py throughput [--records 24] [--backends voxel,exact] [--repeat 1]
    python benchmarks/batch.py row-cost [--records 6] [--backends voxel] [--repeat 3]
    python benchmarks/batch.py contention [--records 24] [--backends voxel] [--repeat 3]
    python benchmarks/batch.py idle [--repeat 1]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

from shared_data import add_data_options, data_or_skip

from exactgrasp.batch import read_manifest, run_batch
from exactgrasp.batch.worker import compute_rows
from exactgrasp.grasp import Grasp
from exactgrasp.paths.presets import as_sampler

RECORDS = "barrett-grasps/study-records"


def study_manifest(data: Path, folder: Path, n: int) -> Path:
    """``n`` study records, every k-th of the sorted closed-mesh ones, as a JSONL manifest."""
    records = sorted((data / RECORDS).rglob("*.json"))
    records = [p for p in records if p.parent.name != "FoodClip"]
    step = max(1, len(records) // n)
    rows = [{"id": p.stem, "grasp": str(p.resolve())} for p in records[::step][:n]]
    path = folder / "manifest.jsonl"
    path.write_text("".join(json.dumps(row) + "\n" for row in rows))
    return path


def study_rows(args: argparse.Namespace, every: int):
    """``(manifest, rows)``: every ``every``-th of the 24 rows of `study_manifest` (in a new
    temporary folder), for a benchmark that times rows one by one; None, after saying so,
    when the shared data is absent. The records' mesh warnings, which other benchmarks print,
    are turned off."""
    data = data_or_skip(args, f"{RECORDS}/README.md")
    if data is None:
        return None
    warnings.simplefilter("ignore")
    manifest = study_manifest(data, Path(tempfile.mkdtemp(prefix="exactgrasp-bench-")), 24)
    return manifest, read_manifest(manifest).rows[::every]


def _timings(out: Path) -> list[dict]:
    lines = (out / "timings.jsonl").read_text().splitlines()
    return [t for t in map(json.loads, lines) if "part" in t]


#: The loop of `machine_speedup`: about 1.5 s of one core.
_SPIN = """
import time
t = time.perf_counter()
x = 0
for i in range(15_000_000):
    x += i * i
print(time.perf_counter() - t)
"""


def machine_speedup(processes: int = 2) -> float:
    """How many times one loop's work ``processes`` copies of it do in the same wall time.

    The loop is pure Python arithmetic: what the cores give to work that shares nothing."""
    spin = [sys.executable, "-c", _SPIN]
    alone = float(subprocess.run(spin, capture_output=True, text=True, check=True).stdout)
    start = time.perf_counter()
    running = [subprocess.Popen(spin, stdout=subprocess.DEVNULL) for _ in range(processes)]
    for process in running:
        process.wait()
    return processes * alone / (time.perf_counter() - start)


def _warm(manifest: Path, backend: str) -> None:
    """Fill the disk cache of the rows' objects (`grasp.files.OBJECT_SOLIDS`), as any run after
    the first over the same dataset finds it: every run of every repeat reads the objects back
    alike."""
    rows = read_manifest(manifest).rows
    compute_rows(rows[:1], str(manifest.parent), backend, as_sampler(None).params)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the workers give the same ones
        for row in rows:
            Grasp.from_file(row.grasp)


def throughput(args, manifest: Path, folder: Path) -> dict:
    counts = [int(n) for n in args.workers.split(",")]
    figures = {}
    for backend in args.backends.split(","):
        _warm(manifest, backend)
        runs = {n: [] for n in counts}
        outs = {}
        machine = []
        for repeat in range(args.repeat):
            machine.append(machine_speedup(max(counts)))
            print(
                f"the machine: {max(counts)} loops at once over one: x{machine[-1]:.2f}",
                flush=True,
            )
            order = counts if repeat % 2 == 0 else counts[::-1]
            for n in order:
                out = folder / f"{backend}-{n}-{repeat}"
                load = os.getloadavg()[0]
                summary = run_batch(manifest, out, backend=backend, workers=n, progress=False)
                if summary.failed:
                    sys.exit(f"{summary.failed} rows failed: see {out / 'errors.jsonl'}")
                tasks = _timings(out)
                busy: dict[str, float] = {}
                for t in tasks:
                    busy[t["worker"]] = busy.get(t["worker"], 0.0) + t["seconds"]
                cpu = sum(t["cpu_seconds"] for t in tasks) / sum(t["seconds"] for t in tasks)
                run = {
                    "grasps_per_s": summary.computed / summary.compute_seconds,
                    "compute_s": summary.compute_seconds,
                    "wall_s": summary.seconds,
                    "cpu_per_busy": cpu,
                    "busy_s": sorted(busy.values(), reverse=True),
                    "tasks": len(tasks),
                    "load": [load, os.getloadavg()[0]],
                }
                runs[n].append(run)
                outs[n] = out
                print(
                    f"{backend} {n} worker(s), repeat {repeat}: {run['grasps_per_s']:.3f} "
                    f"grasps/s ({run['compute_s']:.1f} s computing, {run['wall_s']:.1f} s in "
                    f"all), {run['tasks']} tasks, worker CPU/busy {cpu:.2f}, busy s "
                    f"{', '.join(f'{b:.1f}' for b in run['busy_s'])}, load "
                    f"{run['load'][0]:.1f} -> {run['load'][1]:.1f}",
                    flush=True,
                )
        rate = {n: statistics.median(r["grasps_per_s"] for r in runs[n]) for n in counts}
        same = all(
            (outs[n] / "descriptors.parquet").read_bytes()
            == (outs[counts[0]] / "descriptors.parquet").read_bytes()
            for n in counts
        )
        result = {
            "runs": runs,
            "median_grasps_per_s": rate,
            "identical_bytes": same,
            "machine_speedup": machine,
        }
        for n in counts[1:]:
            speedup = rate[n] / rate[counts[0]]
            result[f"speedup_{n}"] = speedup
            result[f"efficiency_{n}"] = speedup * counts[0] / n
            print(
                f"{backend}: {n} workers over {counts[0]}: x{speedup:.2f} (efficiency "
                f"{speedup * counts[0] / n:.2f}); descriptors identical: {same}; the "
                f"machine's own: x{statistics.median(machine):.2f} (median; "
                f"{', '.join(f'{m:.2f}' for m in machine)})",
                flush=True,
            )
            per_repeat = [
                runs[n][r]["grasps_per_s"] / runs[counts[0]][r]["grasps_per_s"]
                for r in range(args.repeat)
            ]
            result[f"speedup_{n}_per_repeat"] = per_repeat
            print(f"{backend}: per repeat: {', '.join(f'{x:.2f}' for x in per_repeat)}")
        figures[backend] = result
    return figures


def _in_process(manifest: str, backend: str, queue) -> None:
    """Each row alone through `compute_rows` on one thread, in this (fresh) process."""
    m = read_manifest(manifest)
    sampler = as_sampler(None).params
    seconds = []
    for row in m.rows:
        outcome = compute_rows([row], str(m.base_dir), backend, sampler)
        seconds.append((outcome["seconds"], outcome["thread_cpu_seconds"]))
    queue.put(seconds)


def row_cost(args, manifest: Path, folder: Path) -> dict:
    figures = {}
    spawn = multiprocessing.get_context("spawn")
    for backend in args.backends.split(","):
        _warm(manifest, backend)
        ratios, cpu_ratios, pairs = [], [], []
        for repeat in range(args.repeat):
            queue = spawn.Queue()
            proc = spawn.Process(target=_in_process, args=(str(manifest), backend, queue))
            proc.start()
            here = queue.get()
            proc.join()
            out = folder / f"rowcost-{backend}-{repeat}"
            run_batch(manifest, out, backend=backend, workers=1, part_size=1, progress=False)
            tasks = sorted(_timings(out), key=lambda t: t["first_row"])
            worker = [(t["seconds"], t["thread_cpu_seconds"]) for t in tasks]
            pairs.append({"in_process_s": here, "in_worker_s": worker})
            ratio = [w[0] / h[0] for w, h in zip(worker[1:], here[1:], strict=True)]
            cpu = [w[1] / h[1] for w, h in zip(worker[1:], here[1:], strict=True)]
            ratios.extend(ratio)
            cpu_ratios.extend(cpu)
            print(
                f"{backend} repeat {repeat}: a row in a worker / in this process, wall: "
                f"{', '.join(f'{r:.2f}' for r in ratio)}; CPU of the computing thread: "
                f"{', '.join(f'{r:.2f}' for r in cpu)}; sums {sum(w[0] for w in worker[1:]):.2f}"
                f" s / {sum(h[0] for h in here[1:]):.2f} s; load {os.getloadavg()[0]:.1f}",
                flush=True,
            )
        median, median_cpu = statistics.median(ratios), statistics.median(cpu_ratios)
        print(
            f"{backend}: median row in a worker / in process: wall x{median:.3f}, "
            f"CPU x{median_cpu:.3f}",
            flush=True,
        )
        figures[backend] = {"median_ratio": median, "median_cpu_ratio": median_cpu}
        figures[backend]["runs"] = pairs
    return figures


def contention(args, manifest: Path, folder: Path) -> dict:
    figures = {}
    for backend in args.backends.split(","):
        _warm(manifest, backend)
        ratios = []
        for repeat in range(args.repeat):
            rows = {}
            for n in (1, 2) if repeat % 2 == 0 else (2, 1):
                out = folder / f"contention-{backend}-{n}-{repeat}"
                run_batch(manifest, out, backend=backend, workers=n, part_size=1, progress=False)
                rows[n] = {t["first_row"]: t for t in _timings(out)}
            firsts = {r for r, t in rows[2].items() if t["links_prepared"]} | {0}
            ratios.append(
                statistics.median(
                    rows[2][r]["thread_cpu_seconds"] / rows[1][r]["thread_cpu_seconds"]
                    for r in rows[1]
                    if r not in firsts
                )
            )
            print(
                f"{backend} repeat {repeat}: a row's CPU s with 2 workers over 1, median over "
                f"{len(rows[1]) - len(firsts)} rows: x{ratios[-1]:.3f}; load "
                f"{os.getloadavg()[0]:.1f}",
                flush=True,
            )
        figures[backend] = {"median_cpu_ratio_per_repeat": ratios}
    return figures


def _idle_cpu_seconds(config: dict, seconds: float = 10.0) -> float:
    """CPU seconds of this process and its children while a 2-worker local cluster idles."""
    import dask
    import psutil
    from distributed import Client, LocalCluster

    from exactgrasp.batch.threads import THREAD_ENV

    with dask.config.set(config):
        cluster = LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
            silence_logs=50, env=THREAD_ENV,
        )  # fmt: skip
    with cluster, Client(cluster):
        time.sleep(3.0)  # the workers' start-up done
        processes = [psutil.Process(), *psutil.Process().children(recursive=True)]
        before = [sum(p.cpu_times()[:2]) for p in processes]
        time.sleep(seconds)
        return sum(sum(p.cpu_times()[:2]) - b for p, b in zip(processes, before, strict=True))


def idle(args) -> dict:
    from exactgrasp.batch.worker import WORKER_CONFIG

    figures = {"dask_defaults": [], "worker_config": []}
    for repeat in range(args.repeat):
        for name, config in (("dask_defaults", {}), ("worker_config", WORKER_CONFIG)):
            figures[name].append(_idle_cpu_seconds(config))
            print(
                f"repeat {repeat}: an idle 2-worker cluster, {name}: "
                f"{figures[name][-1]:.2f} CPU s in 10 s; load {os.getloadavg()[0]:.1f}",
                flush=True,
            )
    return figures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["throughput", "row-cost", "contention", "idle"])
    parser.add_argument("--records", type=int, default=None, help="rows (24; row-cost: 6)")
    parser.add_argument("--backends", default=None, help="voxel,exact (row-cost: voxel)")
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    parser.add_argument("--repeat", type=int, default=None, help="1 (row-cost: 3)")
    add_data_options(parser)
    args = parser.parse_args()
    cost = args.mode == "row-cost"
    args.records = args.records or (6 if cost else 24)
    one = args.mode in ("row-cost", "contention")
    args.backends = args.backends or ("voxel" if one else "voxel,exact")
    args.repeat = args.repeat or (3 if one else 1)
    if args.mode == "idle":
        figures = idle(args)
        if args.json:
            args.json.write_text(json.dumps(figures, indent=1) + "\n")
        return 0
    data = data_or_skip(args, f"{RECORDS}/README.md")
    if data is None:
        return 0
    with tempfile.TemporaryDirectory(prefix="exactgrasp-bench-") as tmp:
        folder = Path(tmp)
        manifest = study_manifest(data, folder, args.records)
        print(
            f"{args.records} study records, default options, {os.cpu_count()} cores, "
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
            flush=True,
        )
        mode = {"throughput": throughput, "row-cost": row_cost, "contention": contention}
        figures = mode[args.mode](args, manifest, folder)
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
