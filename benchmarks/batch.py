"""Batch throughput: grasps per minute with 1 and with 2 local workers, and the scaling ratio.

Builds a manifest of ``--grasps`` grasps of the built-in Barrett hand (finger joints and object
poses varied, objects from the built-in box and cylinder, one object file each, so the workers
read files as a real dataset would) or, with ``--data real``, of the 34 real cereal-box grasps
in ``barrett-grasps/grasps/`` of the shared data folder (`exactgrasp.datapath.data_dir`;
cycled to ``--grasps``), then runs `exactgrasp.batch.run_batch` into a fresh folder for each
worker count.

Reported per worker count:

* ``grasps/min``: rows computed over ``compute_seconds`` (first task submitted to last part
  written; the workers' start-up, numba cache loading included, is inside this window);
* ``wall grasps/min``: rows over the whole call, local cluster start and shutdown included;
* worker CPU seconds per grasp (from ``timings.jsonl``): the work itself, which a busy
  machine does not inflate the way it inflates wall time;
* the scaling ratio: grasps/min with N workers over grasps/min with 1.

One warm-up descriptor in this process first fills numba's on-disk cache, so no worker
compiles. The machine may be shared: the 1-minute load average is printed with each result.

Usage::

    python benchmarks/batch.py [--grasps 24] [--workers 1,2] [--sampler balanced]
                               [--backend voxel] [--data builtin|real] [--part-size 4]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import exactgrasp as eg
from exactgrasp.batch import run_batch
from exactgrasp.datapath import data_dir

SHARED_DATA = data_dir()


def builtin_manifest(folder: Path, n_grasps: int) -> Path:
    """``n_grasps`` grasps of the built-in hand on a box and a cylinder, as grasp files."""
    rng = np.random.default_rng(0)
    shapes = {"box": eg.objects.box((0.06, 0.1, 0.12)), "cylinder": eg.objects.cylinder()}
    rows = []
    for i in range(n_grasps):
        name = "box" if i % 2 == 0 else "cylinder"
        joints = {f"finger_{k}_med_joint": float(rng.uniform(0.3, 1.2)) for k in (1, 2, 3)}
        joints["finger_1_prox_joint"] = float(rng.uniform(0.0, 0.6))
        pose = np.eye(4)
        pose[:3, 3] = (*rng.uniform(-0.01, 0.01, 2), 0.11 + rng.uniform(0.0, 0.01))
        grasp = eg.Grasp(eg.hands.barrett(joints), shapes[name], pose, name=f"grasp{i}")
        grasp.save(folder / f"grasp{i}.json")
        rows.append({"id": f"grasp{i}", "grasp": f"grasp{i}.json"})
    path = folder / "manifest.jsonl"
    path.write_text("".join(json.dumps(row) + "\n" for row in rows))
    return path


def real_manifest(folder: Path, n_grasps: int) -> Path:
    """The real cereal-box grasps, by absolute path, cycled to ``n_grasps`` rows."""
    files = sorted((SHARED_DATA / "barrett-grasps" / "grasps").glob("obj5_*.json"))
    if not files:
        sys.exit(f"no real grasps under {SHARED_DATA}; use --data builtin")
    rows = [{"id": f"row{i}", "grasp": str(files[i % len(files)])} for i in range(n_grasps)]
    path = folder / "manifest.jsonl"
    path.write_text("".join(json.dumps(row) + "\n" for row in rows))
    return path


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grasps", type=int, default=24)
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    parser.add_argument("--sampler", default="balanced")
    parser.add_argument("--backend", default="voxel")
    parser.add_argument("--data", choices=["builtin", "real"], default="builtin")
    parser.add_argument("--part-size", type=int, default=4)
    args = parser.parse_args()
    counts = [int(n) for n in args.workers.split(",")]

    with tempfile.TemporaryDirectory(prefix="exactgrasp-bench-") as tmp:
        folder = Path(tmp)
        build = real_manifest if args.data == "real" else builtin_manifest
        manifest = build(folder, args.grasps)
        # Warm-up: compile (or load) the kernels once so that no worker compiles.
        first = json.loads(manifest.read_text().splitlines()[0])["grasp"]
        first = Path(first) if Path(first).is_absolute() else folder / first
        eg.compute_descriptor(eg.Grasp.from_file(first), args.sampler, args.backend)

        print(
            f"{args.grasps} {args.data} grasps, sampler {args.sampler!r}, backend "
            f"{args.backend!r}, part size {args.part_size}, {os.cpu_count()} cores"
        )
        rates = {}
        for n in counts:
            start = time.perf_counter()
            summary = run_batch(
                manifest,
                folder / f"out{n}",
                backend=args.backend,
                sampler=args.sampler,
                workers=n,
                part_size=args.part_size,
                progress=False,
            )
            wall = time.perf_counter() - start
            if summary.failed:
                sys.exit(f"{summary.failed} grasps failed: see {summary.out / 'errors.jsonl'}")
            rates[n] = 60.0 * summary.computed / summary.compute_seconds
            lines = (summary.out / "timings.jsonl").read_text().splitlines()
            cpu = sum(json.loads(line).get("cpu_seconds", 0.0) for line in lines)
            print(
                f"workers {n}: {rates[n]:7.1f} grasps/min ({summary.compute_seconds:6.1f} s "
                f"computing), wall {60.0 * summary.computed / wall:7.1f} grasps/min "
                f"({wall:6.1f} s with cluster start), worker CPU "
                f"{cpu / summary.computed:.2f} s/grasp, "
                f"load {os.getloadavg()[0]:.1f}"
            )
        for n in counts[1:]:
            print(f"scaling {n} vs {counts[0]} workers: {rates[n] / rates[counts[0]]:.2f}x")
        same = all(
            (folder / f"out{n}" / "descriptors.parquet").read_bytes()
            == (folder / f"out{counts[0]}" / "descriptors.parquet").read_bytes()
            for n in counts[1:]
        )
        print(f"descriptors.parquet identical across worker counts: {same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
