"""Loading a big hand whose meshes are as labs ship them: the first load, and the next ones.

Writes a hand of 17 STL link meshes and about 283k triangles, the size of a dexterous hand
exported from Onshape, with the same defects: 7 links made of two parts that share an edge
(edges of four faces) and a palm of 82k triangles whose surface passes through itself (1,704
crossing triangle pairs, more than real exports have). Then times ``Hand.from_mjcf`` in fresh
processes: the first with an empty solid cache, then with the cache the first one wrote. One
untimed load first brings the package's files into the operating system's cache.

    python benchmarks/messy_hand.py [--repeat 3] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

N_EDGE_LINKS = 7
N_CLEAN_LINKS = 9


def pushed_sphere(subdivisions: int = 6, radius: float = 0.05):
    """An icosphere whose top cap is turned and pushed down through its bottom."""
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    V, F = np.array(sphere.vertices), np.array(sphere.faces)
    cap = V[:, 2] > 0.62 * radius
    c, s = np.cos(0.37), np.sin(0.37)
    x, y = V[cap, 0].copy(), V[cap, 1].copy()
    V[cap, 0], V[cap, 1] = c * x - s * y, s * x + c * y
    V[cap, 2] -= 1.9 * radius + 0.0131 * V[cap, 0]
    return V, F


def boxes_sharing_an_edge(side: float = 0.02, subdivisions: int = 5):
    """Two finely meshed boxes that share one edge (its faces split alike in both)."""
    parts = []
    for lo in ((0, 0, 0), (side, side, 0)):
        box = trimesh.creation.box(bounds=[lo, np.add(lo, side)])
        V, F = box.vertices, box.faces
        for _ in range(subdivisions):
            V, F = trimesh.remesh.subdivide(V, F)
        parts.append((V, F))
    V = np.concatenate([parts[0][0], parts[1][0]])
    F = np.concatenate([parts[0][1], parts[1][1] + len(parts[0][0])])
    return V, F


def write_hand(folder: Path) -> tuple[Path, int]:
    meshes = {"palm": pushed_sphere()}
    for i in range(N_EDGE_LINKS):
        meshes[f"split{i}"] = boxes_sharing_an_edge()
    for i in range(N_CLEAN_LINKS):
        capsule = trimesh.creation.capsule(height=0.03, radius=0.008, count=[48, 48])
        meshes[f"clean{i}"] = (capsule.vertices, capsule.faces)
    assets, bodies = [], []
    for i, (name, (V, F)) in enumerate(meshes.items()):
        trimesh.Trimesh(V, F, process=False).export(folder / f"{name}.stl")
        assets.append(f'<mesh name="{name}" file="{name}.stl"/>')
        bodies.append(
            f'<body name="{name}" pos="{0.12 * (i % 6)} {0.12 * (i // 6)} 0">'
            f'<geom type="mesh" mesh="{name}"/></body>'
        )
    path = folder / "hand.xml"
    path.write_text(
        "<mujoco><asset>"
        + "".join(assets)
        + '</asset><worldbody><body name="base">'
        + "".join(bodies)
        + "</body></worldbody></mujoco>"
    )
    return path, sum(len(F) for _, F in meshes.values())


LOAD = """
import sys, time, warnings
t, c = time.perf_counter(), time.process_time()
import exactgrasp as eg
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    hand = eg.Hand.from_mjcf(sys.argv[1], frame=eg.HandFrame.identity())
    t1, c1 = time.perf_counter(), time.process_time()
    volume = hand.volume
print(t1 - t, c1 - c, time.perf_counter() - t1, time.process_time() - c1, repr(volume))
"""


def load_seconds(path: Path, cache: Path) -> tuple[float, float, float, float, float]:
    """Wall and CPU seconds of importing exactgrasp and loading the hand in a new process;
    wall and CPU seconds of then computing its volume (the union of the links); the volume."""
    env = dict(os.environ, EXACTGRASP_CACHE=str(cache))
    out = subprocess.run(
        [sys.executable, "-c", LOAD, str(path)], env=env, check=True, capture_output=True
    ).stdout.split()
    return tuple(float(x) for x in out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path, n_faces = write_hand(folder)
        load_seconds(path, folder / "warm-up-cache")  # the package's files read once, untimed
        first, again, volumes = [], [], set()
        for k in range(args.repeat):
            cache = folder / f"cache{k}"
            *seconds, volume = load_seconds(path, cache)
            first.append(seconds)
            *seconds, volume_again = load_seconds(path, cache)
            again.append(seconds)
            volumes |= {volume, volume_again}
    result = {
        "date": time.strftime("%Y-%m-%d"),
        "links": 1 + N_EDGE_LINKS + N_CLEAN_LINKS,
        "triangles": n_faces,
        "load_average": os.getloadavg()[0],
        "first_load_wall_s": statistics.median(r[0] for r in first),
        "first_load_cpu_s": statistics.median(r[1] for r in first),
        "cached_load_wall_s": statistics.median(r[0] for r in again),
        "cached_load_cpu_s": statistics.median(r[1] for r in again),
        "hand_volume_wall_s": statistics.median(r[2] for r in again),
        "hand_volume_cpu_s": statistics.median(r[3] for r in again),
        "first_runs": first,
        "cached_runs": again,
        "hand_volumes_equal": len(volumes) == 1,
    }
    print(json.dumps(result, indent=2))
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
