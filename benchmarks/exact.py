"""Benchmark of the exact backend on the real Barrett-hand grasps.

For each grasp: seconds per descriptor (all poses), share of poses and hand parts culled, and
the plain loop (one manifold3d boolean of the whole hand and the whole object per pose) timed
in the same run on a subsample of poses, with the largest relative difference between the two.

    python benchmarks/exact.py [--poses-subsample 40] [--n-jobs 2] [--broadphase coal]

Needs ``../shared/data`` (relative to the repository); skips with a message when it is absent.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / ".." / "shared" / "data"
GRASPS = (
    "barrett-grasps/noise/noise_grasp0.json",
    "barrett-grasps/grasps/obj5_sub4_grasp1_optimal0_target.json",
    "barrett-grasps/grasps/obj5_sub5_grasp5_optimal0_target.json",
)
#: The paper's frame: grasp centre at z = 0.08 + 0.085 / 2 in the hand frame, half-depth = 1.
CENTRE = np.array([0.0, 0.0, 0.1225])
SCALE = 2.0 / 0.085


def load_grasp(path: Path) -> tuple[list, list]:
    """Hand links and object of a grasp JSON file, in the canonical frame.

    Returns
    -------
    (links, bodies)
        Lists of (V (n, 3) float64, F (m, 3) int64), canonical units.
    """
    import mujoco
    import trimesh

    path = Path(path)
    g = json.loads(path.read_text())
    model = mujoco.MjModel.from_xml_path(str((path.parent / g["hand_model"]).resolve()))
    data = mujoco.MjData(model)
    for name, q in g["joints"].items():
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = q
    mujoco.mj_kinematics(model, data)
    links = []
    for i in range(model.ngeom):
        k = model.geom_dataid[i]
        a, n = model.mesh_vertadr[k], model.mesh_vertnum[k]
        fa, fn = model.mesh_faceadr[k], model.mesh_facenum[k]
        V = model.mesh_vert[a : a + n].astype(np.float64)
        V = V @ data.geom_xmat[i].reshape(3, 3).T + data.geom_xpos[i]
        # MuJoCo splits vertices; merging restores closed shells.
        mesh = trimesh.Trimesh(V, model.mesh_face[fa : fa + fn], process=True)
        links.append(
            ((np.asarray(mesh.vertices) - CENTRE) * SCALE, np.asarray(mesh.faces, np.int64))
        )
    obj = trimesh.load(path.parent / g["object"], force="mesh")
    obj = trimesh.Trimesh(obj.vertices, obj.faces, process=True)
    scale = {"mm": 1e-3, "m": 1.0}[g.get("object_units", "mm")]
    T = np.asarray(g["object_pose_in_hand"], float)
    V = (np.asarray(obj.vertices) * scale) @ T[:3, :3].T + T[:3, 3]
    return links, [((V - CENTRE) * SCALE, np.asarray(obj.faces, np.int64))]


def random_poses(n: int, seed: int = 0, tmax: float = 1.0, amax: float = np.pi) -> np.ndarray:
    """Random rigid poses: rotation angle up to `amax`, translation up to `tmax` (canonical)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    axis = Rotation.random(n, random_state=rng).as_rotvec()
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    P = np.tile(np.eye(4), (n, 1, 1))
    P[:, :3, :3] = Rotation.from_rotvec(axis * rng.uniform(0, amax, n)[:, None]).as_matrix()
    t = rng.normal(size=(n, 3))
    P[:, :3, 3] = t * (rng.uniform(0, tmax, n) / np.linalg.norm(t, axis=1))[:, None]
    return P


def preset_poses() -> tuple[np.ndarray, str]:
    """The balanced preset's poses, or random ones of the same count until it exists."""
    try:
        from exactgrasp.sampling import PathSampler

        return np.asarray(PathSampler.preset("balanced").poses()), "balanced preset"
    except Exception as exc:  # the sampler is written concurrently; say what was used
        return random_poses(474 * 9, seed=1), f"random (474 x 9; preset unavailable: {exc!r})"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--poses-subsample",
        type=int,
        default=40,
        help="poses timed with the plain loop (default 40)",
    )
    ap.add_argument("--n-jobs", type=int, default=2)
    ap.add_argument("--broadphase", default="coal", choices=["coal", "fcl", "none"])
    ap.add_argument(
        "--grasps",
        nargs="*",
        default=list(GRASPS),
        help="grasp JSON files relative to ../shared/data",
    )
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"skipped: real data not found at {DATA.resolve()} (../shared/data)")
        return 0
    sys.path.insert(0, str(ROOT))
    from exactgrasp.backends.exact import ExactIntersector, agrees, plain_volumes

    poses, kind = preset_poses()
    flat = poses.reshape(-1, 4, 4)
    print(
        f"poses: {kind}, {len(flat)} per descriptor; n_jobs={args.n_jobs}, "
        f"broadphase={args.broadphase}"
    )
    header = (
        "grasp",
        "hand tri",
        "obj tri",
        "build s",
        "s/descr",
        "poses culled",
        "parts culled",
        "parts inside",
        "parts clipped",
        "booleans",
        "plain s/pose",
        "speed-up",
        "max rel diff",
        "agree 1e-9",
    )
    rows = []
    sub = np.random.default_rng(0).choice(
        len(flat), min(args.poses_subsample, len(flat)), replace=False
    )
    for rel in args.grasps:
        links, bodies = load_grasp(DATA / rel)
        t0 = time.perf_counter()
        ex = ExactIntersector(
            links,
            bodies,
            broadphase=None if args.broadphase == "none" else args.broadphase,
            n_jobs=args.n_jobs,
        )
        ex.volumes(flat[:2])  # compile / warm caches outside the timing
        build = time.perf_counter() - t0
        t0 = time.perf_counter()
        vol = ex.volumes(flat)
        per_descr = time.perf_counter() - t0
        st = ex.stats
        t0 = time.perf_counter()
        ref = plain_volumes(links, bodies, flat[sub])
        plain = (time.perf_counter() - t0) / len(sub)
        diff = np.abs(vol[sub] - ref) / np.maximum(np.abs(ref), 1e-300)
        parts = st["parts"] * st["poses"]
        rows.append(
            (
                Path(rel).stem,
                str(sum(len(F) for _, F in links)),
                str(sum(len(F) for _, F in bodies)),
                f"{build:.1f}",
                f"{per_descr:.2f}",
                f"{st['poses_culled'] / st['poses']:.1%}",
                f"{st['parts_culled'] / parts:.1%}",
                f"{st['parts_inside'] / parts:.1%}",
                f"{st['parts_clipped'] / parts:.1%}",
                str(st["poses_boolean"]),
                f"{plain:.3f}",
                f"{plain * len(flat) / per_descr:.0f}x",
                f"{diff.max():.1e}",
                str(bool(agrees(vol[sub], ref, ex.hand_volume).all())),
            )
        )
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print("  ".join(h.rjust(w) for h, w in zip(header, widths, strict=True)))
    for r in rows:
        print("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
