"""How big a validation run is: every size in one place (paper, standard and quick)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from exactgrasp.paths.sampler import PRESETS, PathSampler

#: Objects whose raw study records are closed onto with `close_fingers` to make contact grasps
#: (the cereal box already has 34 contact grasps, the spray bottle has the noise-set grasp).
CONTACT_OBJECTS = (
    "PringlesCan",
    "TapeRoll",
    "Remote",
    "SoapDispenser",
    "WineGlass",
    "CrackerBox",
    "FoodClip",
)

#: The paper's two object-pose noise levels, (eps, delta).
NOISE_LEVELS = ((0.0125, 64.0), (0.025, 32.0))


def _preset(name: str, **changes: Any) -> dict[str, Any]:
    return {**PRESETS[name], "n_steps": 9, **changes}


def _samplers() -> dict[str, dict[str, Any]]:
    return {
        "balanced": _preset("balanced"),
        "translations": _preset("translations"),
        "rotations": _preset("rotations"),
        # 10 x 2 x 4 + 10 + 8 = 98 paths: a fifth of the balanced preset's poses, for the
        # exact backend's share of the noise tests when the time is short.
        "reduced": {"n_translations": 10, "n_axes": 2, "n_amounts": 4, "n_steps": 9},
    }


@dataclass
class ValidationConfig:
    """Sizes and settings of a validation run.

    Three sizes: `paper` (the committed report and the default: the paper's sizes everywhere,
    both backends; about 36 minutes on two cores), `standard` (fewer grasps, exact joint-noise
    draws and exact presets; about 13 minutes) and `quick` (under a minute, for the tests).

    Attributes
    ----------
    name : str
        ``"paper"``, ``"standard"`` or ``"quick"`` (written into the report).
    samplers : dict of str to dict
        Named `PathSampler` arguments the other settings refer to.
    estimator_sampler : str
        Sampler of the estimator and descriptor-level reports.
    noise_samplers : tuple of str
        Samplers of the object-pose noise test (the paper's Fig. 6 compares presets); the
        first is the main one (Figs. 4 and 5, L2 of differences).
    exact_noise_samplers : tuple of str or None
        Those of `noise_samplers` also run with the exact backend (None: all).
    joint_sampler : str
        Sampler of the joint-noise test.
    n_cereal : int or None
        Cereal-box contact grasps in the estimator report, evenly spread over the 34 sorted by
        name (None: all).
    contact_objects : tuple of str
        Objects whose study records are closed onto to make contact grasps.
    contact_per_object : int
        Contact grasps kept per object (records that cannot be repaired are skipped).
    contact_tries : int
        Records tried per object before giving up on it.
    voxel : dict
        Voxel backend parameters of the main comparison (the paper's: hand 100, object 50).
    exact : dict
        Exact backend parameters (speed only: the volumes do not depend on them).
    object_resolutions, hand_resolutions : tuple of int
        The resolution sweep (voxel only; compared with the same exact values).
    n_resolution_grasps : int
        Grasps in the resolution sweep (the noise-test grasps).
    noise_levels : tuple of (float, float)
        Object-pose noise levels (eps, delta).
    noise_copies : int
        Perturbed copies per grasp and level.
    n_noise_grasps : int
        Grasps in the object-pose noise test (each on a different object).
    joint_levels : tuple of float
        Joint-noise levels as fractions of each joint's range.
    joint_draws : int
        Random joint perturbations per level.
    exact_joint_draws : int or None
        Joint-noise draws per level with the exact backend (None: `joint_draws`).
    authors_samples : bool
        Give the voxel estimator the authors' MeshLab surface samples (``*_P.ply`` beside each
        object) as the paper did; False: the backend generates its own.
    figure1_paths : int
        Paths drawn in the Figure-1 picture.
    seed : int
        Seed of every random draw (noise copies, joint noise).
    """

    name: str = "paper"
    samplers: dict[str, dict[str, Any]] = field(default_factory=_samplers)
    estimator_sampler: str = "balanced"
    noise_samplers: tuple[str, ...] = ("balanced", "translations", "rotations")
    exact_noise_samplers: tuple[str, ...] | None = None
    joint_sampler: str = "balanced"
    n_cereal: int | None = None
    contact_objects: tuple[str, ...] = CONTACT_OBJECTS
    contact_per_object: int = 2
    contact_tries: int = 6
    voxel: dict[str, Any] = field(
        default_factory=lambda: {"object_resolution": 50, "hand_resolution": 100}
    )
    exact: dict[str, Any] = field(default_factory=lambda: {"n_jobs": -1})
    object_resolutions: tuple[int, ...] = (25, 50, 100)
    hand_resolutions: tuple[int, ...] = (50, 100, 200)
    n_resolution_grasps: int = 6
    noise_levels: tuple[tuple[float, float], ...] = NOISE_LEVELS
    noise_copies: int = 6
    n_noise_grasps: int = 6
    joint_levels: tuple[float, ...] = (0.01, 0.02, 0.03, 0.04, 0.05)
    joint_draws: int = 20
    exact_joint_draws: int | None = None
    authors_samples: bool = True
    figure1_paths: int = 8
    seed: int = 0

    @classmethod
    def paper(cls, **overrides: Any) -> ValidationConfig:
        """The paper's sizes everywhere, with both backends (the committed report).

        About 36 minutes on two cores.
        """
        return cls(**overrides)

    @classmethod
    def standard(cls, **overrides: Any) -> ValidationConfig:
        """Fewer grasps and exact draws (about 13 minutes on two cores).

        The estimator report uses the balanced preset on 12 cereal-box grasps, the spray
        bottle and one closed grasp on each of 7 other objects. The noise tests keep the
        paper's grasps, levels, copies, joint-noise levels and the balanced preset for both
        backends; the translations and rotations presets (Fig. 6) run with the voxel
        estimator only, and the exact backend makes 2 joint-noise draws per level (the voxel
        estimator 20).
        """
        settings: dict[str, Any] = {
            "name": "standard",
            "exact_noise_samplers": ("balanced",),
            "n_cereal": 12,
            "contact_per_object": 1,
            "exact_joint_draws": 2,
        }
        settings.update(overrides)
        return cls(**settings)

    @classmethod
    def quick(cls, **overrides: Any) -> ValidationConfig:
        """A run of well under a minute on two cores: tiny sampler, few grasps, few copies."""
        settings: dict[str, Any] = {
            "name": "quick",
            "samplers": {"tiny": {"n_translations": 4, "n_axes": 2, "n_amounts": 2, "n_steps": 3}},
            "estimator_sampler": "tiny",
            "noise_samplers": ("tiny",),
            "joint_sampler": "tiny",
            "n_cereal": 2,
            "contact_objects": ("PringlesCan",),
            "contact_per_object": 1,
            "contact_tries": 3,
            "voxel": {"object_resolution": 25, "hand_resolution": 50},
            "object_resolutions": (15, 25),
            "hand_resolutions": (40, 50),
            "n_resolution_grasps": 2,
            "noise_copies": 2,
            "n_noise_grasps": 3,
            "joint_levels": (0.01, 0.05),
            "joint_draws": 2,
            "exact_joint_draws": 1,
            "figure1_paths": 4,
        }
        settings.update(overrides)
        return cls(**settings)

    @classmethod
    def named(cls, size: str, **overrides: Any) -> ValidationConfig:
        """`paper`, `standard` or `quick` by name."""
        if size not in SIZES:
            raise ValueError(f"unknown size {size!r}; use one of {SIZES}.")
        return getattr(cls, size)(**overrides)

    def sampler(self, label: str) -> PathSampler:
        """The named sampler."""
        if label not in self.samplers:
            raise KeyError(f"no sampler {label!r} in {sorted(self.samplers)}")
        return PathSampler(**self.samplers[label])

    def main_sampler(self) -> PathSampler:
        """The sampler of the estimator report."""
        return self.sampler(self.estimator_sampler)

    def runs_exact(self, noise_sampler: str) -> bool:
        """Whether the object-pose noise test on this sampler runs with the exact backend."""
        return self.exact_noise_samplers is None or noise_sampler in self.exact_noise_samplers

    def voxel_params(self, **changes: Any) -> dict[str, Any]:
        """Voxel backend parameters of the main comparison, with some changed."""
        return {**self.voxel, **changes}

    def backend_params(self, backend: str) -> dict[str, Any]:
        """Parameters of a backend in this run."""
        return self.voxel_params() if backend == "voxel" else dict(self.exact)

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable settings (written into the report)."""
        return asdict(self)


SIZES = ("paper", "standard", "quick")
