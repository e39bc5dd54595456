"""Write the golden descriptors that ``tests/test_goldens.py`` compares against.

Run from the repository root when a default changes on purpose (a sampler rule, a backend's
default resolution, the built-in hand's shape), then review and commit the changed files::

    python tests/goldens/regenerate.py                  # every case, every available backend
    python tests/goldens/regenerate.py --backend voxel  # one backend
    python tests/goldens/regenerate.py --case builtin_box

Cases on the real Barrett data are written only when the shared data folder is there
(``$EXACTGRASP_DATA``, else ``../shared/data`` beside the repository, as ``tests/conftest.py``).
Each golden is ``<case>.<backend>.npz`` in this folder, written by `exactgrasp.Descriptor.save`
without the run-dependent ``seconds``.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

import exactgrasp as eg
from exactgrasp.datapath import data_dir

GOLDEN_DIR = Path(__file__).resolve().parent
#: ``$EXACTGRASP_DATA``, else ``../shared/data`` beside the repository (as ``tests/conftest.py``).
SHARED_DATA = data_dir()
#: Small on purpose: 3 directions x 2 axes x 2 amounts -> 19 paths, 3 steps each.
SAMPLER_PARAMS = {"n_translations": 3, "n_axes": 2, "n_amounts": 2, "n_steps": 3}
#: Backends with their default parameters, so that a changed default shows up here.
BACKENDS = ("voxel", "exact")


def sampler() -> eg.PathSampler:
    """The sampler of every golden: 19 paths x 3 steps."""
    return eg.PathSampler(**SAMPLER_PARAMS)


def _pose(translation, euler_deg=(0.0, 0.0, 0.0)) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_euler("xyz", euler_deg, degrees=True).as_matrix()
    pose[:3, 3] = translation
    return pose


def builtin_box(shared_data: Path) -> eg.Grasp:
    """Built-in hand, fingers half closed, a 6 x 10 x 10 cm box sunk 5 mm into the palm."""
    joints = {f"finger_{i}_med_joint": 0.6 for i in (1, 2, 3)}
    hand = eg.hands.barrett(joints)
    return eg.Grasp(hand, eg.objects.box((0.06, 0.1, 0.1)), _pose((0, 0, 0.125)), "builtin_box")


def builtin_cylinder(shared_data: Path) -> eg.Grasp:
    """Built-in hand, spread 0.5 rad, a can lying across the palm, off centre."""
    joints = {"finger_1_prox_joint": 0.5, "finger_1_med_joint": 0.9, "finger_3_med_joint": 1.1}
    hand = eg.hands.barrett(joints)
    pose = _pose((0.01, 0.005, 0.112), (0.0, 90.0, 10.0))
    return eg.Grasp(hand, eg.objects.cylinder(), pose, "builtin_cylinder")


def real_noise_grasp0(shared_data: Path) -> eg.Grasp:
    """The real spray-bottle grasp ``noise/noise_grasp0.json`` (slight penetration)."""
    return eg.Grasp.from_file(shared_data / "barrett-grasps" / "noise" / "noise_grasp0.json")


def real_cereal_box(shared_data: Path) -> eg.Grasp:
    """A real cereal-box contact grasp (zero intersection at the grasp pose)."""
    name = "obj5_sub4_grasp1_optimal0_target.json"
    return eg.Grasp.from_file(shared_data / "barrett-grasps" / "grasps" / name)


def adroit_box(shared_data: Path) -> eg.Grasp:
    """The Adroit hand (package gymnasium-robotics), fingers half bent, thumb across, a
    4 x 6 x 6 cm box against the palm."""
    joints = {f"{f}J{k}": 0.6 for f in ("FF", "MF", "RF", "LF") for k in (2, 1)}
    hand = eg.hands.adroit({**joints, "THJ3": 0.8})
    pose = _pose((0.005, -0.04, 0.48))
    return eg.Grasp(hand, eg.objects.box((0.06, 0.04, 0.06)), pose, "adroit_box")


#: name -> (grasp builder, needs the shared data)
CASES: dict[str, tuple[Callable[[Path], eg.Grasp], bool]] = {
    "builtin_box": (builtin_box, False),
    "builtin_cylinder": (builtin_cylinder, False),
    "real_noise_grasp0": (real_noise_grasp0, True),
    "real_cereal_box": (real_cereal_box, True),
    "adroit_box": (adroit_box, False),
}
#: Cases whose hand comes from an optional package: name -> that package's import name.
NEEDS_PACKAGE = {"adroit_box": "gymnasium_robotics"}


def package_missing(case: str) -> str | None:
    """The optional package a case needs and this environment lacks, else None."""
    name = NEEDS_PACKAGE.get(case)
    return name if name and importlib.util.find_spec(name) is None else None


def golden_path(case: str, backend: str) -> Path:
    """Where the golden of ``case`` on ``backend`` lives."""
    return GOLDEN_DIR / f"{case}.{backend}.npz"


def backend_available(name: str) -> bool:
    """Whether ``name`` can be built here (a backend still being written counts as absent)."""
    try:
        eg.get_backend(name)
    except Exception:
        return False
    return True


def compute(case: str, backend: str) -> eg.Descriptor:
    """The descriptor of a golden case, without the run-dependent ``seconds``."""
    build, _ = CASES[case]
    descriptor = eg.compute_descriptor(build(SHARED_DATA), sampler(), backend, progress=False)
    descriptor.metadata.pop("seconds", None)
    return descriptor


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", choices=BACKENDS, action="append")
    parser.add_argument("--case", choices=sorted(CASES), action="append")
    args = parser.parse_args(argv)
    have_data = (SHARED_DATA / "barrett-grasps").is_dir()
    for backend in args.backend or BACKENDS:
        if not backend_available(backend):
            print(f"skip {backend}: backend not available here", file=sys.stderr)
            continue
        for case in args.case or CASES:
            if CASES[case][1] and not have_data:
                print(f"skip {case}: no shared data at {SHARED_DATA}", file=sys.stderr)
                continue
            if missing := package_missing(case):
                print(f"skip {case}: the package {missing} is not installed", file=sys.stderr)
                continue
            path = compute(case, backend).save(golden_path(case, backend))
            print(f"wrote {path.relative_to(GOLDEN_DIR.parents[1])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
