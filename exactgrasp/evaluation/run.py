"""Build the report "What the descriptor tells you": every section, its figures, one Markdown.

``python -m exactgrasp.evaluation`` runs `build_report`. Each section's numbers are kept in
``CACHE/sections/NAME.json`` (with the descriptors in ``CACHE/descriptors``), so a second run
only redraws and rewrites; ``--fresh`` recomputes the sections (descriptors stay cached).
``--sections hands`` (any of `SECTIONS`) computes only those sections and takes the others'
numbers from the report's existing ``summary.json``: their text is rewritten from the same
numbers and their figures are left as they are.
"""

from __future__ import annotations

import datetime
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from exactgrasp.errors import EvaluationError
from exactgrasp.evaluation import figures as fig
from exactgrasp.evaluation.study import (
    Study,
    choose_default,
    clusters_section,
    hands_section,
    noise_section,
    raw_section,
    sampling_section,
)
from exactgrasp.evaluation.text import report_markdown
from exactgrasp.paths.sampler import PathSampler
from exactgrasp.version import __version__

__all__ = ["SAMPLING", "SECTIONS", "build_report"]

#: The report's sections that compute numbers, in order.
SECTIONS = ("clusters", "noise", "sampling", "raw", "hands")


def _s(n_t: int, n_a: int, n_r: int, n_steps: int = 9) -> dict[str, int]:
    return {"n_translations": n_t, "n_axes": n_a, "n_amounts": n_r, "n_steps": n_steps}


#: The sampling trade-off's samplers: sizes from 24 paths to five times the balanced preset,
#: then the balanced preset's paths with other step counts; which backends run each (the
#: exact backend costs about a minute per grasp at the balanced preset on two shared cores,
#: so it runs at three sizes only).
SAMPLING: dict[str, dict[str, Any]] = {
    "24 paths": {"sampler": _s(4, 2, 2), "backends": ("voxel", "exact"), "noise": True},
    "34 paths": {"sampler": _s(6, 2, 2), "backends": ("voxel",), "noise": True},
    "98 paths": {"sampler": _s(10, 2, 4), "backends": ("voxel", "exact"), "noise": True},
    "194 paths": {"sampler": _s(14, 3, 4), "backends": ("voxel",), "noise": True},
    "balanced": {"sampler": _s(18, 4, 6), "backends": ("voxel", "exact"), "noise": True},
    "674 paths": {"sampler": _s(26, 4, 6), "backends": ("voxel",), "noise": True},
    "1368 paths": {"sampler": _s(36, 6, 6), "backends": ("voxel",), "noise": True},
    "2498 paths": {"sampler": _s(50, 6, 8), "backends": ("voxel",), "noise": True},
    "balanced, 3 steps": {"sampler": _s(18, 4, 6, 3), "backends": ("voxel",)},
    "balanced, 5 steps": {"sampler": _s(18, 4, 6, 5), "backends": ("voxel",)},
    "balanced, 15 steps": {"sampler": _s(18, 4, 6, 15), "backends": ("voxel",)},
}

#: A run of a few minutes for checking the machinery (not the committed report).
QUICK_SAMPLING = {k: SAMPLING[k] for k in ("24 paths", "34 paths")}


def _without_curves(value: Any) -> Any:
    """The summary without its ROC curves (they are in the figures; kept out of the JSON)."""
    if isinstance(value, dict):
        return {k: _without_curves(v) for k, v in value.items() if k != "curve"}
    if isinstance(value, list):
        return [_without_curves(v) for v in value]
    return value


def build_report(
    data: str | Path,
    out: str | Path,
    cache: str | Path,
    quick: bool = False,
    fresh: bool = False,
    n_boot: int = 2000,
    command: str = "python -m exactgrasp.evaluation",
    log: Callable[[str], None] = print,
    sections: tuple[str, ...] | None = None,
) -> dict[str, Any]:
    """Compute (or read back) every section, draw the figures, write ``report.md`` and
    ``summary.json`` into ``out``.

    Parameters
    ----------
    data : path-like
        The shared data folder.
    out : path-like
        Report folder (``docs/reports/descriptor-meaning`` for the committed one).
    cache : path-like
        Descriptor and section cache.
    quick : bool
        A small sampler and few bootstrap replicates: minutes, for checking.
    fresh : bool
        Recompute the sections' numbers (descriptors are still read from the cache).
    n_boot : int
    command : str
        Written into the report.
    log : callable
        Called with a line for each section computed and for the report written (default
        `print`).
    sections : tuple of str, optional
        Compute only these of `SECTIONS` (from their cache unless ``fresh``) and redraw only
        their figures; the other sections' numbers are read from ``out/summary.json``, which
        must exist. Default: every section.

    Returns
    -------
    dict
        The summary written to ``summary.json``, which leaves out its ROC curves.
    """
    start = time.perf_counter()
    out, cache = Path(out), Path(cache)
    study = Study(Path(data), cache, n_boot=200 if quick else n_boot, log=log)
    main = PathSampler(**(SAMPLING["34 paths" if quick else "balanced"]["sampler"]))
    sections_dir = cache / ("sections-quick" if quick else "sections")
    sections_dir.mkdir(parents=True, exist_ok=True)

    previous = {} if sections is None else _previous_summary(out, sections, quick)
    section = _Sections(sections_dir, sections, previous, fresh, log).get
    clusters = section("clusters", lambda: clusters_section(study, main))
    noise = section("noise", lambda: noise_section(study, main))
    chosen = choose_default(clusters, noise)
    default = chosen["default"]
    sampling = section(
        "sampling",
        lambda: sampling_section(
            study, QUICK_SAMPLING if quick else SAMPLING, default, ("voxel", "exact")
        ),
    )
    raw = section("raw", lambda: raw_section(study, main, clusters))
    hands = section("hands", lambda: hands_section(study, main, default))
    drawn = _figures(
        out,
        sections,
        previous,
        default,
        clusters=clusters,
        raw=raw,
        sampling=sampling,
        hands=hands,
    )
    today = datetime.date.today().isoformat()
    runs = {name: {"command": command, "date": today} for name in sections or ()}
    summary = {
        "version": __version__,
        "date": previous.get("date", today),
        "command": previous.get("command", command),
        "section_runs": {**previous.get("section_runs", {}), **runs},
        "quick": quick,
        "default": chosen,
        "clusters": clusters,
        "noise": noise,
        "sampling": sampling,
        "raw": raw,
        "hands": hands,
        "figures": {k: str(v.relative_to(out)) for k, v in drawn.items()},
        "seconds": previous.get("seconds", 0.0) if sections else time.perf_counter() - start,
    }
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(
        json.dumps(_without_curves(summary), indent=1, default=float)
    )
    (out / "report.md").write_text(report_markdown(summary))
    log(f"wrote {out / 'report.md'}")
    return summary


def _previous_summary(out: Path, sections: tuple[str, ...], quick: bool) -> dict[str, Any]:
    """The report's existing ``summary.json``, whose numbers the sections not in ``sections``
    keep; refused when a section is unknown, the file is missing or it is not a ``quick`` run
    like this one."""
    unknown = sorted(set(sections) - set(SECTIONS))
    if unknown:
        raise EvaluationError(f"unknown sections {unknown}; the sections: {list(SECTIONS)}")
    try:
        previous = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError) as exc:
        raise EvaluationError(
            f"--sections needs the report's existing summary.json for the other "
            f"sections' numbers: {exc}"
        ) from None
    if bool(previous.get("quick")) != quick:
        raise EvaluationError(
            f"{out / 'summary.json'} is {'a quick' if previous.get('quick') else 'a full'} "
            "run; --sections keeps its other sections, so run with the same --quick setting."
        )
    return previous


class _Sections:
    """Each section's numbers: the existing summary's for a section not asked for, else those
    kept in ``folder/NAME.json`` (unless ``fresh``), else computed and kept there."""

    def __init__(self, folder: Path, asked, previous: dict, fresh: bool, log) -> None:
        self.folder, self.asked, self.previous = folder, asked, previous
        self.fresh, self.log = fresh, log

    def get(self, name: str, compute: Callable[[], dict]) -> dict:
        """The numbers of section ``name``; ``compute()`` makes them."""
        if self.asked is not None and name not in self.asked:
            return self.previous[name]
        file = self.folder / f"{name}.json"
        if file.exists() and not self.fresh:
            return json.loads(file.read_text())
        t = time.perf_counter()
        value = compute()
        value["section_seconds"] = time.perf_counter() - t
        file.write_text(json.dumps(value, default=float))
        self.log(f"section {name}: {value['section_seconds']:.0f} s")
        return value


def _figures(
    out: Path,
    sections: tuple[str, ...] | None,
    previous: dict,
    default: str,
    *,
    clusters: dict,
    raw: dict,
    sampling: dict,
    hands: dict,
) -> dict[str, Path]:
    """Every figure of the report by key: drawn into ``out/figures`` from its section's
    numbers when the section was computed, else the existing summary's file."""
    figures = out / "figures"
    # Each figure with the section it draws (ROC curves are not kept in summary.json, so a
    # section taken from it keeps its figures as they are).
    drawers = {
        "roc": (
            "clusters",
            lambda: fig.roc_figure(clusters, default, figures / "roc-clusters.png"),
        ),
        "aucs": (
            "clusters",
            lambda: fig.auc_bars(
                clusters, figures / "auc-clusters.png", "adjusted contact grasps"
            ),
        ),
        "raw": ("raw", lambda: fig.auc_bars(raw, figures / "auc-raw.png", "raw study records")),
        "sampling": ("sampling", lambda: fig.sampling_figure(sampling, figures / "sampling.png")),
        "steps": ("sampling", lambda: fig.steps_figure(sampling, figures / "steps.png")),
        "hands": ("hands", lambda: fig.hands_figure(hands, figures / "hands.png")),
    }
    return {
        key: draw() if sections is None or name in sections else out / previous["figures"][key]
        for key, (name, draw) in drawers.items()
    }
