"""``exactgrasp demo``: built-in grasps on every available backend, a table and a plot."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from exactgrasp.cli.common import add_command, add_progress, add_sampler, sampler_from_args
from exactgrasp.cli.params import add_param, backend_names, build_backend, split_params
from exactgrasp.paths.presets import as_sampler

if TYPE_CHECKING:
    from exactgrasp.backends.base import Backend
    from exactgrasp.descriptor import Descriptor
    from exactgrasp.grasp import Grasp

__all__ = ["QUICK_SAMPLER", "add_parser", "cmd_demo", "demo_grasps", "run_demo"]

#: The sampler of ``--quick``: 34 paths (6 translations, 4 rotations, 24 both) x 5 steps.
QUICK_SAMPLER = {"n_translations": 6, "n_axes": 2, "n_amounts": 2, "n_steps": 5}


#: The command's line in ``exactgrasp --help``.
HELP = "built-in grasps on every available backend"
#: Its ``--help`` description, and the example that follows it.
DESCRIPTION = (
    "Close the built-in Barrett hand onto three built-in objects and the "
    "built-in parallel gripper onto a box, compute each "
    "grasp's descriptor with every available backend, print a table of times and values "
    "and write a plot, a summary and the descriptors into --out."
)
EXAMPLE = "exactgrasp demo --quick --out demo-output"


def _pose(rotation_deg: tuple[float, float, float], translation: tuple[float, float, float]):
    from scipy.spatial.transform import Rotation

    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_euler("xyz", rotation_deg, degrees=True).as_matrix()
    pose[:3, 3] = translation
    return pose


def demo_grasps() -> list[Grasp]:
    """Three contact grasps of the built-in Barrett hand on the built-in objects, and one of
    the built-in parallel gripper on a box.

    Each object is placed just clear of the open hand (the Barrett knuckles top out at
    z = 0.0914 m) and the fingers are closed onto it with
    `exactgrasp.grasp.closing.close_grasp`, so the intersection at the grasp itself is zero.

    Returns
    -------
    list of Grasp
    """
    from exactgrasp.geometry import objects
    from exactgrasp.grasp import Grasp
    from exactgrasp.grasp.closing import close_grasp
    from exactgrasp.hands.barrett import barrett
    from exactgrasp.hands.gripper import parallel_gripper

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
    grasps = [close_grasp(Grasp(barrett(), obj, pose, name=name)) for name, obj, pose in specs]
    # The parallel gripper closes towards its lower limit: a 5 cm box between its open jaws.
    box = objects.box((0.03, 0.05, 0.04))
    pose = _pose((0, 0, 0), (0, 0, 0.025))
    grasps.append(close_grasp(Grasp(parallel_gripper(), box, pose, name="gripper box")))
    return grasps


def _plot(descriptors: dict[tuple[str, str], Descriptor], path: Path) -> None:
    from exactgrasp.view.descriptors import write_descriptor_figure

    write_descriptor_figure(descriptors, path)


def run_demo(
    out: Path,
    sampler: Any = None,
    quick: bool = False,
    progress: bool | None = None,
    n_steps: int | None = None,
    backends: Sequence[Backend] | None = None,
) -> int:
    """Compute descriptors of the demo grasps with every available backend.

    Writes ``descriptors.png``, ``summary.json`` and one ``.npz`` per grasp and backend into
    ``out``; prints a table of times and values.

    Parameters
    ----------
    out : pathlib.Path
        Output folder (created).
    sampler : PathSampler or str or dict, optional
        Anything `exactgrasp.paths.as_sampler` takes (default: the ``"balanced"`` preset).
    quick : bool
        The small `QUICK_SAMPLER` (34 paths x 5 steps) instead of ``sampler``.
    progress : bool, optional
        Progress bars; default only on a terminal.
    n_steps : int, optional
        Poses per path, replacing the sampler's.
    backends : sequence of Backend, optional
        The backends to run, configured; default: every available one with the library
        defaults.

    Returns
    -------
    int
        Exit status (0).
    """
    from exactgrasp.backends import as_backend
    from exactgrasp.descriptor import compute_descriptor

    out.mkdir(parents=True, exist_ok=True)
    sampler = as_sampler(QUICK_SAMPLER if quick else sampler, n_steps=n_steps)
    if backends is None:
        backends = [as_backend(name) for name in backend_names()]
    engines = {engine.name: engine for engine in backends}
    backends = list(engines)
    print(f"sampler: {sampler!r} ({sampler.n_paths} paths, {sampler.n_poses} poses)")
    print(f"backends: {', '.join(backends)}")
    grasps = demo_grasps()
    descriptors: dict[tuple[str, str], Descriptor] = {}
    rows = []
    print(f"{'grasp':>12} {'backend':>8} {'seconds':>8} {'mean':>9} {'max':>9}")
    for grasp in grasps:
        for backend in backends:
            d = compute_descriptor(grasp, sampler, backend=engines[backend], progress=progress)
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
                f"{grasp.name:>12} {backend:>8} {row['seconds']:8.2f} "
                f"{row['mean']:9.5f} {row['max']:9.5f}"
            )
    _plot(descriptors, out / "descriptors.png")
    (out / "summary.json").write_text(json.dumps(rows, indent=1))
    print(f"wrote {out / 'descriptors.png'}, {out / 'summary.json'} and the .npz descriptors")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """Handler of ``exactgrasp demo``."""
    sampler = sampler_from_args(args)  # checked even with --quick, which replaces it
    if args.quick:
        sampler = as_sampler(QUICK_SAMPLER, n_steps=args.steps)
    names = backend_names()
    params = split_params(args.param, names)
    backends = [build_backend(name, params[name]) for name in names]
    return run_demo(Path(args.out), sampler, progress=args.progress, backends=backends)


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``demo`` sub-command to the ``exactgrasp`` command's subparsers."""
    parser = add_command(subparsers, "demo", cmd_demo, HELP, DESCRIPTION, EXAMPLE)
    quick = as_sampler(QUICK_SAMPLER)
    parser.add_argument("--out", default="demo-output", help="folder for the plot and table")
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"a small sampler ({quick.n_paths} paths x {quick.n_steps} steps) instead of "
        "--sampler, for a fast look",
    )
    add_param(parser)
    add_sampler(parser)
    add_progress(parser)
    return parser
