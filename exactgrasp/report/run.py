"""Run the whole validation: grasps, descriptors (cached), numbers, figures, report files."""

from __future__ import annotations

import datetime
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

from exactgrasp.backends import get_backend
from exactgrasp.report import figures as fig
from exactgrasp.report.cache import DescriptorCache
from exactgrasp.report.config import ValidationConfig
from exactgrasp.report.data import (
    Case,
    barrett_dir,
    cereal_cases,
    contact_cases,
    spray_case,
)
from exactgrasp.report.descriptors import descriptor_report
from exactgrasp.report.estimator import estimator_report
from exactgrasp.report.findings import (
    descriptor_findings,
    estimator_findings,
    headline,
    noise_findings,
)
from exactgrasp.report.noise import joint_noise_test, object_noise_test
from exactgrasp.report.write import write_html, write_json, write_markdown
from exactgrasp.version import __version__


def noise_cases(spray: Case, cereal: list[Case], closed: list[Case], n: int) -> list[Case]:
    """Grasps of the object-pose noise test, each on a different object."""
    picked, seen = [], set()
    for case in [spray, *cereal[:1], *closed]:
        if case.object not in seen and len(picked) < n:
            picked.append(case)
            seen.add(case.object)
    return picked


def usable_backends() -> list[str]:
    """``voxel``, and ``exact`` when it loads (a half-installed backend counts as missing)."""
    out = []
    for name in ("voxel", "exact"):
        try:
            get_backend(name)
        except Exception:
            continue
        out.append(name)
    return out


def _describe(cereal, spray, closed, skipped, noise) -> list[str]:
    lines = [
        f"{len(cereal)} adjusted cereal-box contact grasps (barrett-grasps/grasps).",
        "The spray-bottle grasp of the joint-noise set (barrett-grasps/noise/"
        f"{Path(spray.source).name}).",
        f"{len(closed)} contact grasps made from raw study records with close_fingers: "
        + (
            ", ".join(
                f"{c.name} (overlap {c.notes['overlap_before']:.2%} of the hand before, "
                f"{c.notes['overlap_after']:.1e} after; object backed off "
                f"{c.notes['backoff_m'] * 1e3:.1f} mm; {c.notes['fingers_in_contact']} fingers "
                "touching)"
                for c in closed
            )
            or "none"
        )
        + ".",
        f"{len(skipped)} study records could not be repaired and were skipped"
        + (": " + "; ".join(f"{s['record']} ({s['reason']})" for s in skipped) if skipped else "")
        + ".",
        "Object-pose noise test grasps: " + ", ".join(c.name for c in noise) + ".",
    ]
    return lines


def run_validation(
    data_dir: str | Path,
    out_dir: str | Path,
    config: ValidationConfig | None = None,
    cache_dir: str | Path | None = None,
    command: str = "exactgrasp validate",
    log: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Compute everything and write ``index.html``, ``summary.md``, ``summary.json`` and
    ``figures/*.png`` into ``out_dir``.

    Parameters
    ----------
    data_dir : path-like
        The shared data folder (``barrett-grasps/`` and ``osu-objects/``).
    out_dir : path-like
    config : ValidationConfig, optional
        Default: `ValidationConfig.paper`.
    cache_dir : path-like, optional
        Descriptor and closing cache (default ``out_dir/cache``).
    command : str
        The command line, written into the report.
    log : callable
        Called with a line of progress for each step (default `print`).

    Returns
    -------
    dict
        The summary written to ``summary.json``.
    """
    start = time.perf_counter()
    config = config or ValidationConfig.paper()
    barrett = barrett_dir(data_dir)
    out = Path(out_dir)
    figures_dir = out / "figures"
    figures_dir.mkdir(parents=True, exist_ok=True)
    cache_root = Path(cache_dir) if cache_dir else out / "cache"
    cache = DescriptorCache(cache_root / "descriptors", log=log)
    backends = usable_backends()
    notes = []
    if "exact" not in backends:
        notes.append(
            "the exact backend is not installed here, so the estimator and descriptor-level "
            "comparisons were skipped and the noise tests ran with the voxel backend only."
        )
    grasps = _read_grasps(barrett, config, cache_root, log, notes)
    summary: dict[str, Any] = {"grasps": grasps.summary()}
    findings: list[str] = []
    drawn = [
        (
            fig.figure1(
                config.main_sampler(), figures_dir / "figure1_paths.png", config.figure1_paths
            ),
            "Figure 1: sampled paths of a T-shaped object (union of two boxes), coloured by time.",
        )
    ]
    if "exact" in backends:
        drawn += _backends_compared(grasps, cache, config, figures_dir, log, summary, findings)
    drawn += _noise_tests(grasps, cache, config, backends, figures_dir, log, summary, findings)
    summary["findings"] = findings
    summary["headline"] = headline(summary)
    summary["meta"] = {
        "command": command,
        "data": str(Path(data_dir)),
        "config": config.to_dict(),
        "backends": backends,
        "version": __version__,
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "cpus": os.cpu_count(),
        "seconds": time.perf_counter() - start,
        "descriptors_computed": cache.computed,
        "descriptors_from_cache": cache.loaded,
        "compute": cache.compute_seconds,
        "notes": notes,
    }
    figure_list = [(f"figures/{path.name}", caption) for path, caption in drawn]
    write_json(summary, out / "summary.json")
    write_markdown(summary, figure_list, out / "summary.md")
    write_html(summary, figure_list, out / "index.html")
    log(f"report: {out / 'index.html'} ({summary['meta']['seconds']:.0f} s)")
    return summary


class _Grasps(NamedTuple):
    """The report's grasps: the adjusted cereal-box grasps, the spray-bottle grasp, the
    grasps closed from study records (and the records skipped), and the noise test's."""

    cereal: list[Case]
    spray: Case
    closed: list[Case]
    skipped: list[dict[str, Any]]
    noise: list[Case]

    @property
    def estimator(self) -> list[Case]:
        """The grasps of the estimator's comparison: all but the skipped."""
        return [*self.cereal, self.spray, *self.closed]

    def summary(self) -> dict[str, Any]:
        """The summary's ``grasps`` entry."""
        return {
            "estimator": [c.name for c in self.estimator],
            "noise": [c.name for c in self.noise],
            "closed": {c.name: c.notes for c in self.closed},
            "skipped": self.skipped,
            "description": _describe(
                self.cereal, self.spray, self.closed, self.skipped, self.noise
            ),
        }


def _read_grasps(
    barrett: Path, config: ValidationConfig, cache_root: Path, log, notes: list[str]
) -> _Grasps:
    """Read the shared data's grasps and close the study records (cached under
    ``cache_root/closing``); a shortfall of noise-test grasps is added to ``notes``."""
    log("grasps: reading the shared data and closing study records")
    cereal = cereal_cases(barrett, config.n_cereal, config.authors_samples)
    spray = spray_case(barrett, config.authors_samples)
    closed, skipped = contact_cases(
        barrett,
        config.contact_objects,
        config.contact_per_object,
        config.contact_tries,
        config.authors_samples,
        cache_root / "closing",
        log=log,
    )
    noise = noise_cases(spray, cereal, closed, config.n_noise_grasps)
    if len(noise) < config.n_noise_grasps:
        notes.append(
            f"only {len(noise)} grasps on different objects were available for the object-pose "
            f"noise test (asked for {config.n_noise_grasps})."
        )
    return _Grasps(cereal, spray, closed, skipped, noise)


def _backends_compared(
    grasps: _Grasps, cache, config, figures_dir: Path, log, summary, findings
) -> list[tuple[Path, str]]:
    """The estimator (voxel against exact, pose by pose) and descriptor-level comparisons:
    their numbers into ``summary`` and ``findings``, their figures returned with captions."""
    resolution_grasps = grasps.noise[: config.n_resolution_grasps]
    est, arrays = estimator_report(grasps.estimator, cache, config, resolution_grasps, log)
    summary["estimator"] = est
    findings += estimator_findings(est)
    drawn = [
        (
            fig.estimator_scatter(arrays, figures_dir / "estimator_scatter.png"),
            "Voxel estimate against exact volume, every pose of every grasp; right: "
            "relative error against the exact value.",
        ),
        (
            fig.error_by_step(est, arrays, figures_dir / "estimator_by_step.png"),
            "Relative error and false positives against the step along the paths.",
        ),
        (
            fig.error_histogram(arrays, figures_dir / "estimator_histogram.png"),
            "Histogram of the signed relative error, both surface weights.",
        ),
        (
            fig.resolution_grid(
                arrays["resolution_grid"], figures_dir / "estimator_resolution.png"
            ),
            "Error and time against object and hand resolution.",
        ),
    ]
    desc, matrices = descriptor_report(
        arrays["names"], arrays["voxel_descriptors"], arrays["exact_descriptors"]
    )
    summary["descriptors"] = desc
    findings += descriptor_findings(desc)
    drawn.append(
        (
            fig.distance_matrices(matrices, figures_dir / "descriptor_distances.png"),
            "L2 distance matrices from each backend, and every pair's distance with "
            "voxel against exact (L2 and L2 of differences).",
        )
    )
    return drawn


def _noise_tests(
    grasps: _Grasps, cache, config, backends: list[str], figures_dir: Path, log, summary, findings
) -> list[tuple[Path, str]]:
    """The object-pose and joint noise tests: their numbers into ``summary`` and
    ``findings``, their figures (the paper's Figs. 3 to 6) returned with captions."""
    pose_summary, pose_arrays = object_noise_test(grasps.noise, cache, config, backends, log)
    joint_summary, joint_arrays = joint_noise_test(grasps.spray, cache, config, backends, log)
    summary["noise"] = {"object_pose": pose_summary, "joints": joint_summary}
    findings += noise_findings(pose_summary, joint_summary)
    main = config.noise_samplers[0]
    joint_pose = pose_summary.get(config.joint_sampler, {}).get("backends", {})
    reference = {b: min(v["min_between"] for v in r["l2"].values()) for b, r in joint_pose.items()}
    return [
        (
            fig.within_between(pose_arrays, main, "l2", figures_dir / "noise_fig4.png"),
            f"Object-pose noise (paper Fig. 4), {main} sampler: within- vs between-object L2 "
            "distances, per backend and noise level.",
        ),
        (
            fig.per_grasp_spread(pose_summary, figures_dir / "noise_fig5.png"),
            "Per-grasp within-object and per-pair between-object L2 distances, mean and "
            f"standard deviation (paper Fig. 5), {main} sampler.",
        ),
        (
            fig.joint_noise(joint_arrays, reference, figures_dir / "noise_fig3_joints.png"),
            f"Joint noise on the spray-bottle grasp (paper Fig. 3), {config.joint_sampler} "
            "sampler: L2 distance to the unperturbed grasp per noise level.",
        ),
        (
            fig.presets(pose_arrays, list(config.noise_samplers), figures_dir / "noise_fig6.png"),
            "The samplers compared (paper Fig. 6): within- vs between-object distances per "
            f"sampler and backend, and L2 of differences for the {main} sampler.",
        ),
    ]
