"""``exactgrasp demo``: built-in grasps on every available backend, a table and a plot."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from exactgrasp.backends import available_backends
from exactgrasp.descriptor import Descriptor, compute_descriptor
from exactgrasp.geometry import objects
from exactgrasp.grasp import Grasp
from exactgrasp.paths.sampler import PathSampler


def _pose(rotation_deg: tuple[float, float, float], translation: tuple[float, float, float]):
    from scipy.spatial.transform import Rotation

    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_euler("xyz", rotation_deg, degrees=True).as_matrix()
    pose[:3, 3] = translation
    return pose


def demo_grasps() -> list[Grasp]:
    """Three contact grasps of the built-in Barrett hand on the built-in objects.

    Each object is placed just clear of the open hand (the knuckles top out at z = 0.0914 m)
    and the fingers are closed onto it with `exactgrasp.grasp.closing.close_grasp`, so the
    intersection at the grasp itself is zero.

    Returns
    -------
    list of Grasp
    """
    from exactgrasp.grasp.closing import close_grasp
    from exactgrasp.hands.barrett import barrett

    knuckle_top = 0.0914
    specs = [
        # a can lying across the palm, its axis along x (across the fingers)
        ("can", objects.cylinder(), _pose((0, 90, 0), (0, 0, knuckle_top + 0.036))),
        # a cereal-box-like box grasped across its 6 cm side
        ("box", objects.box((0.2, 0.06, 0.28)), _pose((0, 0, 0), (0, 0, knuckle_top + 0.141))),
        # the jug's handle, its outer bar along x, the body beyond it
        (
            "jug handle",
            objects.bottle_with_handle(),
            _pose((0, 90, 0), (-0.1, 0.0, knuckle_top + 0.085)),
        ),
    ]
    return [close_grasp(Grasp(barrett(), obj, pose, name=name)) for name, obj, pose in specs]


def _plot(descriptors: dict[tuple[str, str], Descriptor], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grasp_names = list(dict.fromkeys(g for g, _ in descriptors))
    backend_names = list(dict.fromkeys(b for _, b in descriptors))
    fig, axes = plt.subplots(1, len(grasp_names), figsize=(5 * len(grasp_names), 4), squeeze=False)
    styles = ["-", "--", ":", "-."]
    for ax, grasp_name in zip(axes[0], grasp_names, strict=True):
        for b, backend in enumerate(backend_names):
            d = descriptors.get((grasp_name, backend))
            if d is None:
                continue
            sampler = d.sampler
            table = sampler.paths
            chosen = np.flatnonzero(table.kind == "translation")
            for k, p in enumerate(chosen):
                ax.plot(
                    sampler.times,
                    d.values[p],
                    styles[b % len(styles)],
                    color=f"C{k % 10}",
                    label=backend if k == 0 else None,
                )
        ax.set_title(f"{grasp_name}: translation-only paths (colour = path)")
        ax.set_xlabel("path time t")
        ax.set_ylabel("intersection / hand volume")
        ax.legend(title="backend (line style)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_demo(
    out: Path, sampler_name: str = "balanced", quick: bool = False, progress: bool | None = None
) -> int:
    """Compute descriptors of the demo grasps with every available backend.

    Writes ``descriptors.png``, ``summary.json`` and one ``.npz`` per grasp and backend into
    ``out``; prints a table of times and values.

    Returns
    -------
    int
        Exit status (0).
    """
    out.mkdir(parents=True, exist_ok=True)
    sampler = (
        PathSampler(n_translations=6, n_axes=2, n_amounts=2, n_steps=5)
        if quick
        else PathSampler.preset(sampler_name)
    )
    backends = [b for b in ("voxel", "exact") if b in available_backends()]
    backends += sorted(available_backends() - set(backends))
    print(f"sampler: {sampler!r} ({sampler.n_paths} paths, {sampler.n_poses} poses)")
    print(f"backends: {', '.join(backends)}")
    grasps = demo_grasps()
    descriptors: dict[tuple[str, str], Descriptor] = {}
    rows = []
    print(f"{'grasp':>12} {'backend':>8} {'seconds':>8} {'mean':>9} {'max':>9}")
    for grasp in grasps:
        for backend in backends:
            d = compute_descriptor(grasp, sampler, backend=backend, progress=progress)
            descriptors[(grasp.name, backend)] = d
            d.save(out / f"{grasp.name.replace(' ', '_')}_{backend}.npz")
            row = {
                "grasp": grasp.name,
                "backend": backend,
                "seconds": d.metadata["seconds"],
                "mean": float(d.values.mean()),
                "max": float(d.values.max()),
            }
            rows.append(row)
            print(
                f"{grasp.name:>12} {backend:>8} {row['seconds']:8.2f} {row['mean']:9.5f} "
                f"{row['max']:9.5f}"
            )
    _plot(descriptors, out / "descriptors.png")
    (out / "summary.json").write_text(json.dumps(rows, indent=1))
    print(f"wrote {out / 'descriptors.png'}, {out / 'summary.json'} and the .npz descriptors")
    return 0
