"""An evaluation's files: ``evaluation.json``, ``evaluation.md`` and ``roc.png``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from exactgrasp.evaluation.evaluate import EvaluationResult
from exactgrasp.evaluation.text import number
from exactgrasp.report.figures import save_figure

__all__ = ["auc_table", "finish_roc", "roc_figure", "write_evaluation"]


def roc_figure(result: EvaluationResult, path: Path, names: list[str] | None = None) -> Path:
    """ROC curves of the chosen evaluations (default: all) in one PNG."""
    fig, ax = plt.subplots(figsize=(5.5, 5))
    for name in names or list(result.evaluations):
        ev = result.evaluations[name]
        style = "--" if name.startswith("baseline") else "-"
        ax.plot(*ev.curve, style, label=f"{name}: {ev.auc:.3f}", lw=1.4)
    return finish_roc(
        fig,
        ax,
        path,
        f"{len(result.pairs)} pairs, {result.pairs.n_same} same",
        x_label="false positive rate (different pairs called same)",
        y_label="true positive rate (same pairs called same)",
    )


def finish_roc(fig, ax, path: Path, title: str, *, x_label: str, y_label: str) -> Path:
    """Draw chance's diagonal, name the axes, title and legend an ROC plot, and write its
    figure to the PNG file ``path`` (returned)."""
    ax.plot([0, 1], [0, 1], ":", color="grey", lw=0.8)
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    ax.set_title(title)
    ax.legend(fontsize=7, loc="lower right")
    return save_figure(fig, path)


def auc_table(result: EvaluationResult) -> list[str]:
    """Markdown rows: distance, AUC, interval, per-group AUCs."""
    groups = sorted({g for ev in result.evaluations.values() for g in ev.groups})
    head = "| distance | AUC | interval |" + "".join(f" {g} |" for g in groups)
    rows = [head, "|---" * (3 + len(groups)) + "|"]
    for name, ev in result.evaluations.items():
        cells = [name, number(ev.auc), f"{number(ev.low)} .. {number(ev.high)}"]
        cells += [number(ev.groups.get(g, {}).get("auc", float("nan"))) for g in groups]
        rows.append("| " + " | ".join(cells) + " |")
    return rows


def write_evaluation(
    result: EvaluationResult, out_dir: str | Path, command: str = "", extra: Any = None
) -> dict[str, Path]:
    """Write the evaluation's JSON, Markdown and ROC figure into ``out_dir``.

    Returns
    -------
    dict of str to pathlib.Path
        ``json``, ``markdown``, ``figure``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    data = result.to_dict()
    if extra:
        data["extra"] = extra
    if command:
        data["command"] = command
    json_path = out / "evaluation.json"
    json_path.write_text(json.dumps(data, indent=1, default=float))
    figure = roc_figure(result, out / "roc.png")
    b = result.settings["bootstrap"]
    lines = [
        "# Evaluation of descriptor distances on labelled pairs",
        "",
        f"{len(result.pairs.names)} grasps, {len(result.pairs)} pairs, "
        f"{result.pairs.n_same} of them with the highest label ('same').",
        f"Backend {result.settings['backend']}, sampler {result.settings['sampler']}.",
        f"AUC: probability that a 'different' pair is farther apart than a 'same' pair "
        f"(ties 1/2). Interval: {b['level']:.0%} percentile bootstrap, {b['n_boot']} "
        f"replicates resampling {b['unit']}s, seed {b['seed']}.",
        "",
        *auc_table(result),
        "",
        "![ROC curves](roc.png)",
        "",
    ]
    if command:
        lines += [f"Made by `{command}`.", ""]
    md_path = out / "evaluation.md"
    md_path.write_text("\n".join(lines))
    return {"json": json_path, "markdown": md_path, "figure": figure}
