"""Writing the report: a JSON file of every summary number, a Markdown summary, an HTML page."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path
from typing import Any


def clean(value: Any) -> Any:
    """JSON-safe copy: NaN and infinities become None, numpy scalars plain numbers."""
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [clean(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, str):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(summary: dict[str, Any], path: Path) -> Path:
    """``summary.json``: strict JSON (no NaN)."""
    path.write_text(json.dumps(clean(summary), indent=1, allow_nan=False) + "\n")
    return path


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _md(text: str) -> str:
    """A Markdown table cell: pipes escaped."""
    return text.replace("|", "\\|")


#: A table of the report: its title, column headers and rows.
Table = tuple[str, list[str], list[list[Any]]]


def tables(summary: dict[str, Any]) -> list[Table]:
    """The report's tables: ``(title, header, rows)``."""
    noise = summary.get("noise", {})
    return [
        *_estimator_tables(summary.get("estimator")),
        *_descriptor_tables(summary.get("descriptors")),
        *_object_noise_tables(noise.get("object_pose", {})),
        *_joint_noise_tables(noise.get("joints", {})),
    ]


def _estimator_tables(est: dict[str, Any] | None) -> list[Table]:
    """Voxel against exact per pose, the resolution sweep and the surface weights."""
    if not est:
        return []
    cols = (
        "median_abs_rel",
        "p95_abs_rel",
        "max_abs_rel",
        "mean_signed_rel",
        "fraction_over",
        "false_positive_rate",
        "n_compared",
    )
    per_pose = [["all grasps", est["n_grasps"], *(est["overall"][c] for c in cols)]]
    per_pose += [
        [obj, v["n_grasps"], *(v[c] for c in cols)] for obj, v in est["by_object"].items()
    ]
    sweep = [
        [
            v["object_resolution"],
            v["hand_resolution"],
            v["median_abs_rel"],
            v["p95_abs_rel"],
            v["mean_signed_rel"],
            v["false_positive_rate"],
            v["seconds_per_descriptor"],
        ]
        for v in est["resolution"]["configs"].values()
    ]
    weights = [
        [
            k,
            v["median_abs_rel"],
            v["p95_abs_rel"],
            v["mean_signed_rel"],
            v["seconds_per_descriptor"],
        ]
        for k, v in est["surface_weight"].items()
    ]
    return [
        (
            "Voxel against exact, per pose (relative errors where exact > 1e-4)",
            ["grasps", "n", *cols],
            per_pose,
        ),
        (
            "Resolution sweep",
            [
                "object res.",
                "hand res.",
                "median |rel|",
                "p95 |rel|",
                "mean signed rel",
                "FP rate",
                "s / descriptor",
            ],
            sweep,
        ),
        (
            "Surface weights",
            ["weight", "median |rel|", "p95 |rel|", "mean signed rel", "s / descriptor"],
            weights,
        ),
    ]


def _descriptor_tables(desc: dict[str, Any] | None) -> list[Table]:
    """Voxel against exact at the level of descriptor distances."""
    if not desc:
        return []
    rows = [
        [k, desc[k]["spearman"], desc[k]["median_ratio"], desc[k]["nn_agreement"],
         desc[k]["topk_overlap"]]
        for k in ("l2", "l2_diff")
    ]  # fmt: skip
    return [
        (
            "Descriptor level: voxel vs exact distances",
            ["distance", "Spearman", "median voxel/exact", "NN agreement", "top-k overlap"],
            rows,
        )
    ]


def _object_noise_tables(noise: dict[str, Any]) -> list[Table]:
    """The object-pose noise test: one row per sampler, backend, distance and level."""
    rows = []
    for label in noise.get("samplers", []):
        for backend, kinds in noise[label]["backends"].items():
            for kind, levels in kinds.items():
                for level, v in levels.items():
                    rows.append(
                        [f"{label} ({noise[label]['n_paths']} paths)", backend, kind, level,
                         v["max_within"], v["min_between"], v["overlap_within"],
                         v["overlap_between"], v["auc"]]
                    )  # fmt: skip
    if not rows:
        return []
    return [
        ("Object-pose noise test: within- vs between-object distances",
         ["sampler", "backend", "distance", "level", "max within", "min between",
          "within in overlap", "between in overlap", "AUC"], rows)
    ]  # fmt: skip


def _joint_noise_tables(joints: dict[str, Any]) -> list[Table]:
    """The joint noise test: one row per backend and noise level."""
    rows = []
    for backend, entry in joints.get("backends", {}).items():
        for level, v in entry["levels"].items():
            rows.append([backend, f"{float(level) * 100:g} %", v["n"], v["mean"], v["median"],
                         v["max"]])  # fmt: skip
    if not rows:
        return []
    return [
        (f"Joint noise: L2 distance to the unperturbed {joints['grasp']} grasp "
         f"({joints['sampler']} sampler)",
         ["backend", "noise", "draws", "mean", "median", "max"], rows)
    ]  # fmt: skip


def provenance(meta: dict[str, Any]) -> str:
    """One sentence: what ran, where, and what it cost from an empty cache."""
    cost = ", ".join(
        f"{backend} {seconds / 60:.1f} min" for backend, seconds in meta["compute"].items()
    )
    return (
        f"Generated by `{meta['command']}` ({meta['config']['name']} size, exactgrasp "
        f"{meta['version']}, {meta['date']}) on {meta['cpus']} CPUs in {meta['seconds']:.0f} s "
        f"({meta['descriptors_computed']} descriptors computed, "
        f"{meta['descriptors_from_cache']} read from the cache); computing every descriptor "
        f"used from an empty cache took {cost}."
    )


def write_markdown(summary: dict[str, Any], figures: list[tuple[str, str]], path: Path) -> Path:
    """``summary.md``: the findings, the tables and the figures."""
    meta = summary["meta"]
    lines = [
        "# exactgrasp validation report",
        "",
        provenance(meta)
        + " Every number below is in `summary.json`; the figures are in `figures/`; the same "
        "content as one page: [index.html](index.html).",
        "",
        "## In short",
        "",
        summary["headline"],
        "",
        "## Findings",
        "",
    ]
    lines += [f"- {s}" for s in summary["findings"]]
    for note in meta.get("notes", []):
        lines.append(f"- Note: {note}")
    lines += ["", "## Grasps", ""]
    lines += [f"- {s}" for s in summary["grasps"]["description"]]
    for title, header, rows in tables(summary):
        lines += [
            "",
            f"## {title}",
            "",
            "| " + " | ".join(_md(h) for h in header) + " |",
            "|" + "---|" * len(header),
        ]
        lines += ["| " + " | ".join(_md(_fmt(v)) for v in row) + " |" for row in rows]
    lines += ["", "## Figures", ""]
    for file, caption in figures:
        lines += [f"![{caption}]({file})", "", f"*{caption}*", ""]
    path.write_text("\n".join(lines) + "\n")
    return path


CSS = """
body { font-family: system-ui, sans-serif; max-width: 1200px; margin: 2em auto; padding: 0 1em;
       color: #222; line-height: 1.45; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f3f3; }
td:first-child, th:first-child { text-align: left; }
img { max-width: 100%; border: 1px solid #eee; }
figure { margin: 1.5em 0; }
figcaption { font-style: italic; color: #555; }
code { background: #f5f5f5; padding: 0 0.2em; }
"""


def write_html(summary: dict[str, Any], figures: list[tuple[str, str]], path: Path) -> Path:
    """``index.html``: one page with the findings, tables and figures (PNG files beside it)."""
    esc = html.escape
    meta = summary["meta"]
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        "<title>exactgrasp validation report</title>",
        f"<style>{CSS}</style></head><body>",
        "<h1>exactgrasp validation report</h1>",
        f"<p>{esc(provenance(meta)).replace('`', '')} Numbers: "
        "<a href='summary.json'>summary.json</a>; Markdown: "
        "<a href='summary.md'>summary.md</a>.</p>",
        f"<h2>In short</h2><p>{esc(summary['headline'])}</p>",
        "<h2>Findings</h2><ul>",
    ]
    parts += [f"<li>{esc(s)}</li>" for s in summary["findings"]]
    parts += [f"<li>Note: {esc(n)}</li>" for n in meta.get("notes", [])]
    parts.append("</ul><h2>Grasps</h2><ul>")
    parts += [f"<li>{esc(s)}</li>" for s in summary["grasps"]["description"]]
    parts.append("</ul>")
    for title, header, rows in tables(summary):
        parts.append(f"<h2>{esc(title)}</h2><table><tr>")
        parts += [f"<th>{esc(h)}</th>" for h in header]
        parts.append("</tr>")
        for row in rows:
            parts.append("<tr>" + "".join(f"<td>{esc(_fmt(v))}</td>" for v in row) + "</tr>")
        parts.append("</table>")
    parts.append("<h2>Figures</h2>")
    for file, caption in figures:
        parts.append(
            f"<figure><img src='{esc(file)}' alt='{esc(caption)}'>"
            f"<figcaption>{esc(caption)}</figcaption></figure>"
        )
    parts.append("<h2>Settings</h2><pre>")
    parts.append(esc(json.dumps(clean(meta["config"]), indent=1)))
    parts.append("</pre></body></html>")
    path.write_text("\n".join(parts) + "\n")
    return path
