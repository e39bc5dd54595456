"""The Markdown of the report "What the descriptor tells you", from its summary.

Every number in the text is read from the summary, so the words and the figures cannot drift
apart; the judgements ("within the interval", "reaches 0.90") are computed here too.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["number", "report_markdown", "smallest_within_interval"]

GOAL = 0.90


def number(x: Any, digits: int = 3) -> str:
    """``x`` with ``digits`` decimals, ``n/a`` for None or NaN."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    return f"{x:.{digits}f}"


def _ci(e: dict) -> str:
    return f"{number(e['auc'])} ({number(e['low'])} .. {number(e['high'])})"


def _table_head(*columns: str) -> list[str]:
    """The first two lines of a Markdown table: the column names and the separator."""
    return ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]


def _figures(*figures: tuple[str, str]) -> list[str]:
    """Markdown lines of figures ``(alt text, file in figures/)``, each after a blank line,
    and a blank line after the last."""
    lines = [""]
    for alt, file in figures:
        lines += [f"![{alt}](figures/{file})", ""]
    return lines


def smallest_within_interval(rows: list[dict], backend: str) -> dict[str, Any] | None:
    """The fewest-path sampler (9 steps) whose AUC reaches the largest sampler's lower bound.

    Returns
    -------
    dict or None
        ``{"smallest": row, "largest": row}``; None when the backend has no rows.
    """
    mine = sorted(
        (r for r in rows if r["backend"] == backend and r["n_steps"] == 9),
        key=lambda r: r["n_paths"],
    )
    if not mine:
        return None
    largest = mine[-1]
    for row in mine:
        if row["auc"]["auc"] >= largest["auc"]["low"]:
            return {"smallest": row, "largest": largest}
    return {"smallest": largest, "largest": largest}


def _clusters(s: dict) -> list[str]:
    default = s["default"]["default"]
    c = s["clusters"]
    vox, ex = c["backends"]["voxel"]["distances"], c["backends"]["exact"]["distances"]
    d = vox[default]
    lines = [
        f"The {c['n_grasps']} cereal-box contact grasps of the shared data carry the cluster of "
        f"the study they came from; all {c['n_pairs']} pairs, {c['n_same']} of them in one "
        "cluster. AUC: the probability that a pair from different clusters is farther apart "
        "than a pair from one cluster (ties count one half). Interval: 95 % percentile "
        f"bootstrap, {d['interval']['n_boot']} replicates that resample the *grasps* (pairs "
        "sharing a grasp are not independent), seed 0. Sampler: the balanced preset "
        "(474 paths x 9 steps).",
        "",
        *_table_head("distance", "voxel", "exact", "voxel, minus L2's AUC (paired interval)"),
    ]
    for name in vox:
        mark = " **(default)**" if name == default else ""
        v = vox[name].get("versus_l2")
        versus = f"{v['value']:+.3f} ({v['low']:+.3f} .. {v['high']:+.3f})" if v else ""
        lines.append(f"| {name}{mark} | {_ci(vox[name])} | {_ci(ex[name])} | {versus} |")
    for name, e in c["baselines"].items():
        lines.append(f"| baseline: {name} | {_ci(e)} | | |")
    best = max(c["baselines"].items(), key=lambda kv: kv[1]["auc"])
    reached = d["auc"] >= GOAL
    lines += [
        "",
        f"The default distance, **{default}**, reaches AUC {_ci(d)} with the voxel backend and "
        f"{_ci(ex[default])} with the exact one (resampling whole clusters instead of grasps, "
        f"the voxel interval widens to {number(d['group_interval'][0])} .. "
        f"{number(d['group_interval'][1])}); the best baseline, {best[0]}, "
        f"{_ci(best[1])}. The goal of {GOAL:.2f} is "
        + ("reached." if reached else "not reached with the voxel backend.")
        + " Baselines: `joints` is the L2 distance of the 8 joint values (radians); "
        "`position` the distance of the box's centre in the canonical frame; `origin` the "
        "distance of the box file's origin (a corner of the box), which also tells which way "
        "round the box is; `pose` the centre distance plus "
        "the rotation angle between the box orientations, the smallest over the box's four "
        "proper symmetries; `contacts` the Jaccard distance of the links within 1 mm of the "
        "box.",
        "",
        f"Per cluster (pairs with a grasp in the cluster), {default}, voxel:",
        "",
        *_table_head("cluster", "AUC", "same pairs", "different pairs"),
    ]
    for g, e in sorted(d["groups"].items(), key=lambda kv: int(kv[0])):
        lines.append(f"| {g} | {number(e['auc'])} | {e['n_same']} | {e['n_different']} |")
    lines += _figures(
        ("ROC curves", "roc-clusters.png"), ("AUC of every distance", "auc-clusters.png")
    )
    return lines


def _noise(s: dict) -> list[str]:
    levels = s["noise"]["levels"]
    keys = list(levels)
    names = list(levels[keys[0]])
    lines = [
        "The paper's object-pose noise test (`exactgrasp.report`): six grasps on six objects "
        f"({', '.join(s['noise']['grasps'])}), six perturbed copies each at each of the two "
        "noise levels, voxel backend, balanced preset. AUC of within-grasp against "
        "between-grasp distances, and the ratio of their medians (larger separates more).",
        "",
        *_table_head("distance", *(f"{k}: {what}" for k in keys for what in ("AUC", "ratio"))),
    ]
    for n in names:
        cells = "".join(
            f" {number(levels[k][n]['auc'])} | {number(levels[k][n]['ratio_of_medians'], 1)} |"
            for k in keys
        )
        lines.append(f"| {n} |{cells}")
    lines.append("")
    return lines


def _default(s: dict) -> list[str]:
    d = s["default"]
    lines = [
        "Rule: " + " ".join(d["rule"].split()),
        "",
        *_table_head(
            "distance",
            "noise-test AUC at least 0.99 at both levels",
            "cluster AUC, mean of backends",
        ),
    ]
    for r in d["rows"]:
        lines.append(
            f"| {r['name']} | {'yes' if r['qualifies'] else 'no'} | {number(r['cluster_auc'])} |"
        )
    lines += ["", f"Chosen: **{d['default']}**.", ""]
    return lines


def _sampling(s: dict) -> list[str]:
    sm = s["sampling"]
    lines = [
        f"Distance {sm['distance']}. Seconds: the descriptor's own recorded computation time, "
        "mean per grasp, on two cores shared with other work. They are rough: a voxel row "
        "includes whatever one-off cost (compiling, the hand's grid) fell to it, so the voxel "
        "seconds do not grow smoothly with the paths; the exact backend's include about 2 s of "
        "preparation per grasp. The number of poses (paths x steps) is the clean measure of "
        "cost. Noise ratio: median between-grasp over median within-grasp distance at the two "
        "noise levels (voxel).",
        "",
        *_table_head(
            "sampler",
            "paths",
            "steps",
            "backend",
            "s / grasp",
            "cluster AUC",
            "L2 AUC",
            "noise: AUC",
            "noise: ratio of medians",
        ),
    ]
    for r in sm["rows"]:
        noise_auc = noise = ""
        if "noise" in r:
            levels = r["noise"]["levels"].values()
            noise_auc = ", ".join(number(v[sm["distance"]]["auc"]) for v in levels)
            noise = ", ".join(number(v[sm["distance"]]["ratio_of_medians"], 1) for v in levels)
        lines.append(
            f"| {r['label']} | {r['n_paths']} | {r['n_steps']} | {r['backend']} | "
            f"{number(r['seconds_per_grasp'], 2)} | {_ci(r['auc'])} | "
            f"{number(r['auc_l2']['auc'])} | {noise_auc} | {noise} |"
        )
    lines.append("")
    for backend in ("voxel", "exact"):
        found = smallest_within_interval(sm["rows"], backend)
        if found:
            small, large = found["smallest"], found["largest"]
            lines.append(
                f"- {backend}: the largest sampler run ({large['n_paths']} paths) reaches "
                f"{_ci(large['auc'])}; the smallest whose AUC is within that interval is "
                f"**{small['label']}** ({small['n_paths']} paths, AUC "
                f"{number(small['auc']['auc'])}, {number(small['seconds_per_grasp'], 2)} s per "
                "grasp against "
                f"{number(large['seconds_per_grasp'], 2)} s)."
            )
    separating = sorted(
        (
            r
            for r in sm["rows"]
            if "noise" in r
            and all(v[sm["distance"]]["auc"] >= 0.99 for v in r["noise"]["levels"].values())
        ),
        key=lambda r: r["n_paths"],
    )
    if separating:
        r = separating[0]
        lines.append(
            f"- The noise test asks for more: the smallest sampler whose noise-test AUC stays at "
            f"0.99 or above at both levels (the default's own qualifying bar) is "
            f"**{r['label']}** ({r['n_paths']} paths, {r['n_poses']} poses per grasp)."
        )
    lines += _figures(
        ("AUC and noise separation against poses", "sampling.png"),
        ("AUC against steps per path", "steps.png"),
    )
    return lines


def _raw(s: dict) -> list[str]:
    r = s["raw"]
    a = r["adjustment"]
    vox = r["backends"]["voxel"]["distances"]
    lines = [
        "The same 34 grasps as recorded in the study (penetrating the box) instead of adjusted "
        "to contact; same clusters, same sampler, voxel backend (the exact backend's cost on "
        "two shared cores kept it to section 1).",
        "",
        *_table_head("distance", "adjusted", "raw"),
    ]
    for name in vox:
        lines.append(f"| {name} | {number(r['adjusted_reference'][name])} | {_ci(vox[name])} |")
    for name, e in r["baselines"].items():
        adjusted = s["clusters"]["baselines"][name]["auc"]
        lines.append(f"| baseline: {name} | {number(adjusted)} | {_ci(e)} |")
    lines += [
        "",
        f"L2 distance of a raw record to its own adjusted grasp: median "
        f"{number(a['l2_raw_to_adjusted_median'])}, max "
        f"{number(a['l2_raw_to_adjusted_max'])}; the median distance between two different "
        "adjusted grasps is "
        f"{number(a['l2_between_adjusted_median'])}, and "
        f"{a['fraction_of_pairs_closer_than_median_adjustment']:.0%} of those pairs are closer "
        "than a typical adjustment moves a grasp. Median of the largest descriptor value: raw "
        f"{number(a['max_value_raw_median'])}, adjusted {number(a['max_value_adjusted_median'])}.",
    ]
    return lines + _figures(("AUC of every distance, raw records", "auc-raw.png"))


def _against_chance(e: dict) -> str:
    """Where an AUC's interval lies against 0.5 (chance)."""
    if e["low"] > 0.5:
        return "above chance"
    if e["high"] < 0.5:
        return "below chance"
    return "not distinguishable from chance"


def _hands(s: dict) -> list[str]:
    h = s["hands"]
    names = {"barrett": "Barrett", "gripper": "gripper", "adroit": "Adroit"}
    groups = h["groups"]
    hows = list(next(iter(groups.values()))["normalisations"])

    def shown(group: str) -> str:
        return " / ".join(names.get(x, x) for x in group.split(" / "))

    lines = [
        "Hands: the Barrett of the shared data, the built-in parallel gripper and the built-in "
        "Adroit five-finger hand (`eg.hands.adroit()`: the model file of the package "
        "`gymnasium-robotics`, MIT licence, installed with `exactgrasp[hands]`; its "
        "collision geoms, forearm included, 22 links).",
        "",
        "The gripper and the Adroit hand hold the box at the Barrett grasps' placements relative "
        "to the palm frame (same rotation, same position in metres; the canonical frame's scale "
        "would shrink the box's distances with a smaller hand and bury it in the hand), opened, "
        "backed off the palm where needed and closed with `close_fingers`. A placement is "
        "dropped for a hand when it had to be backed off more than 20 mm or no finger touched "
        "the box. Pairs: the same placement in two hands ('same') against two placements in "
        "one hand ('different'), on the placements every hand of the group kept. AUC on the "
        "Barrett clusters: each hand's own grasps, labelled with the cluster of the Barrett "
        "grasp they copy, hand-volume normalisation.",
        "",
        *_table_head("hand", "placements kept", "hand volume", "AUC on the Barrett clusters"),
    ]
    for label in h["hands"]:
        lines.append(
            f"| {names.get(label, label)} | {h['n_placements'][label]} | "
            f"{h['hand_volume_m3'][label] * 1e6:.1f} cm^3 | {_ci(h['clusters'][label])} |"
        )
    lines += [
        "",
        "Same placement across hands closer than different placements on one hand: AUC "
        "(95 % interval, grasps resampled). Normalisations: `hand volume` is the descriptor "
        "as it is (intersection over the hand's volume); `none` the intersection volume in "
        "canonical units; `cubic metres` the intersection volume in m^3; `hull volume` over "
        "the volume of the hand's convex hull instead; `own maximum` each descriptor over its "
        "largest value.",
        "",
        *_table_head(
            "normalisation",
            *(f"{shown(g)} ({e['n_placements']} placements)" for g, e in groups.items()),
        ),
    ]
    for how in hows:
        cells = "".join(
            f" {_ci(e['normalisations'][how]['same_placement_across_hands'])} |"
            for e in groups.values()
        )
        lines.append(f"| {how} |{cells}")
    lines += [
        "",
        "Median distances (the default distance), same placement against pairs within each hand:",
        "",
        *_table_head("hands", "normalisation", "same placement", "within each hand"),
    ]
    for g, e in groups.items():
        for how in hows:
            row = e["normalisations"][how]
            within = ", ".join(
                f"{names.get(x, x)} {number(row[f'median_{x}_pairs'], 4)}" for x in g.split(" / ")
            )
            lines.append(
                f"| {shown(g)} | {how} | {number(row['median_same_placement'], 4)} | {within} |"
            )
    lines.append("")
    for g, e in groups.items():
        rows = e["normalisations"]
        best = max(hows, key=lambda n: rows[n]["same_placement_across_hands"]["auc"])
        plain = rows["hand volume"]["same_placement_across_hands"]
        top = rows[best]["same_placement_across_hands"]
        lines.append(
            f"- {shown(g)}: with the hand-volume normalisation {_ci(plain)}, "
            f"{_against_chance(plain)}; the best normalisation, {best}, {_ci(top)}, "
            f"{_against_chance(top)}."
        )
    lines += _figures(("Across-hand AUC by normalisation", "hands.png"))
    return lines


#: The report's sections in order: title, and the Markdown lines under it.
_SECTIONS = (
    ("The authors' clusters", _clusters),
    ("The noise test, for every distance", _noise),
    ("The default distance", _default),
    ("Sampling rate against cost", _sampling),
    ("Raw study records against contact-adjusted grasps", _raw),
    ("Different hand geometry", _hands),
)


def report_markdown(summary: dict[str, Any]) -> str:
    """The report as Markdown text."""
    head = [
        "# What the descriptor tells you: the report",
        "",
        f"Made by `{summary['command']}` on {summary['date']} (exactgrasp "
        f"{summary['version']}); every number and figure here comes from that one command. "
        "Descriptors are cached in `.evaluation-cache/` (not committed). The reading of these "
        "numbers is on the page [What the descriptor tells you](../../descriptor-meaning.md).",
        "",
    ]
    for name, run in summary.get("section_runs", {}).items():
        head += [
            f"Section {name} last recomputed alone by `{run['command']}` on {run['date']}; "
            "the other sections' numbers are those of the run above.",
            "",
        ]
    if summary.get("quick"):
        head += ["**Quick run: small samplers, few replicates. Not the committed numbers.**", ""]
    body = []
    for number, (title, section) in enumerate(_SECTIONS, 1):
        body += [f"## {number}. {title}", "", *section(summary)]
    return "\n".join(head + body)
