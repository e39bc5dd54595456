"""Plain statements drawn from the report's numbers: what the estimator gets wrong, whether
the paper's claims hold. Every sentence is computed, none is written by hand.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: AUC at or above this for every noise level: the two distributions are "distinct" in the
#: sense the paper uses (a threshold separates nearly all pairs).
AUC_DISTINCT = 0.95


def _pct(x: float) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{100 * x:.1f} %"


def _signed_pct(x: float) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{100 * x:+.1f} %"


def estimator_findings(est: dict[str, Any]) -> list[str]:
    """What the voxel estimator gets wrong, from the estimator summary."""
    o = est["overall"]
    over = o["mean_signed_rel"] > 0
    verdict = "over-estimates" if over else "under-estimates"
    expectation = "as the authors expected" if over else "unlike what the authors expected"
    out = [
        f"Bias: at the {o['n_compared']} poses where hand and object overlap (exact > 1e-4 of "
        f"the hand volume) the voxel estimator {verdict} on average ({expectation}): mean "
        f"signed relative error {_signed_pct(o['mean_signed_rel'])}, median "
        f"{_signed_pct(o['median_signed_rel'])}; it is above the exact volume at "
        f"{_pct(o['fraction_over'])} of these poses. Size: median |relative error| "
        f"{_pct(o['median_abs_rel'])}, 95th percentile {_pct(o['p95_abs_rel'])}, maximum "
        f"{_pct(o['max_abs_rel'])}; correlation with the exact values {o['correlation']:.4f}."
    ]
    by_step = est["by_step"]
    med = np.array(by_step["median_abs_rel"], dtype=float)
    if np.isfinite(med).any():
        worst, best = int(np.nanargmax(med)), int(np.nanargmin(med))
        fp_rates = np.array(by_step["false_positive_rate"], dtype=float)
        fp_part = ""
        if est["overall"]["n_zero"] > 0:
            fp_part = (
                f"; false positives peak at t = {by_step['t'][int(np.argmax(fp_rates))]:.2f} "
                f"({_pct(float(fp_rates.max()))} of that step's zero-overlap poses)"
            )
        out.append(
            f"Along the paths: the median |relative error| is largest at t = "
            f"{by_step['t'][worst]:.2f} ({_pct(med[worst])}) and smallest at t = "
            f"{by_step['t'][best]:.2f} ({_pct(med[best])}){fp_part}."
        )
    mag = est["by_magnitude"]
    bounds = [*mag["lower"][1:], None]
    mags = [
        f"{lo:g} to {hi:g}: {_pct(m)}" if hi else f"above {lo:g}: {_pct(m)}"
        for lo, hi, m in zip(mag["lower"], bounds, mag["median_abs_rel"], strict=True)
    ]
    small, large = mag["median_abs_rel"][0], mag["median_abs_rel"][-1]
    trend = ""
    if small is not None and large is not None and np.isfinite(small) and np.isfinite(large):
        trend = (
            " Small overlaps, where the object only grazes the hand, are estimated worse than "
            "deep ones."
            if small > large
            else " Small overlaps are not estimated worse than deep ones."
        )
    out.append(
        "By overlap size (exact value, fraction of the hand): median |relative error| "
        + "; ".join(mags)
        + "."
        + trend
    )
    out.append(
        f"False positives: at {o['n_zero']} poses hand and object do not overlap at all, yet "
        f"the voxel estimate is positive at {o['false_positive_poses']} of them "
        f"({_pct(o['false_positive_rate'])}), up to {o['false_positive_max']:.2e} of the hand "
        f"volume; false negatives (overlap missed): {o['false_negative_poses']} poses."
    )
    configs = est["resolution"]["configs"]
    if configs:
        out += _resolution_findings(est, configs)
    sw = est["surface_weight"]
    out.append(
        f"Surface weight: 'paper' (V_o/32 per surface point) gives median |relative error| "
        f"{_pct(sw['paper']['median_abs_rel'])} and mean signed "
        f"{_signed_pct(sw['paper']['mean_signed_rel'])}; 'area' (the authors' code) gives "
        f"{_pct(sw['area']['median_abs_rel'])} and {_signed_pct(sw['area']['mean_signed_rel'])}."
    )
    sec = est["seconds_per_descriptor"]
    out.append(
        f"Cost: {sec['voxel']:.2f} s per descriptor with the voxel estimator, "
        f"{sec['exact']:.2f} s with the exact backend ({sec['exact'] / sec['voxel']:.1f} x)."
    )
    return out


def _resolution_findings(est: dict[str, Any], configs: dict[str, Any]) -> list[str]:
    """How error, bias, false positives and time move with each resolution."""
    rows = list(configs.values())
    obj_res = sorted({r["object_resolution"] for r in rows})
    hand_res = sorted({r["hand_resolution"] for r in rows})
    main = est["voxel_params"]
    at = {(r["object_resolution"], r["hand_resolution"]): r for r in rows}

    def sweep(kind: str, fixed: int, values: list[int]) -> str:
        keys = [(v, fixed) if kind == "object" else (fixed, v) for v in values]
        parts = [
            f"{v}: median |rel| {_pct(at[k]['median_abs_rel'])}, mean signed "
            f"{_signed_pct(at[k]['mean_signed_rel'])}, false positives "
            f"{_pct(at[k]['false_positive_rate'])}, {at[k]['seconds_per_descriptor']:.2f} s"
            for v, k in zip(values, keys, strict=True)
            if k in at
        ]
        return "; ".join(parts)

    def driver(key: str) -> str:
        spread = {}
        for kind, fixed, values in (("object", main["hand_resolution"], obj_res),
                                    ("hand", main["object_resolution"], hand_res)):  # fmt: skip
            keys = [(v, fixed) if kind == "object" else (fixed, v) for v in values]
            found = [at[k][key] for k in keys if k in at]
            spread[kind] = max(found) - min(found) if found else 0.0
        return max(spread, key=spread.get)

    best = min(rows, key=lambda r: r["median_abs_rel"])
    return [
        f"Resolution ({len(est['resolution']['grasps'])} grasps). Object resolution at hand "
        f"{main['hand_resolution']}: {sweep('object', main['hand_resolution'], obj_res)}. "
        f"Hand resolution at object {main['object_resolution']}: "
        f"{sweep('hand', main['object_resolution'], hand_res)}. The bias moves mostly with the "
        f"{driver('mean_signed_rel')} resolution, the false positives with the "
        f"{driver('false_positive_rate')} resolution; the most accurate setting "
        f"(object {best['object_resolution']}, hand {best['hand_resolution']}) has median "
        f"|relative error| {_pct(best['median_abs_rel'])}."
    ]


def descriptor_findings(desc: dict[str, Any]) -> list[str]:
    """Whether the estimator changes which grasps look alike."""
    out = []
    for kind in ("l2", "l2_diff"):
        d = desc[kind]
        out.append(
            f"{kind}: over {desc['n_grasps']} grasps the pairwise distances from the two "
            f"backends have Spearman rank correlation {d['spearman']:.3f}; voxel distances are "
            f"{d['median_ratio']:.2f} x the exact ones (median); the nearest neighbour of a "
            f"grasp is the same with both backends for {_pct(d['nn_agreement'])} of grasps "
            f"(top-{d['k']} overlap {_pct(d['topk_overlap'])})."
        )
    return out


def stability_verdict(levels: dict[str, dict[str, float]]) -> tuple[str, str]:
    """``(verdict, sentence part)`` for one backend's object-pose noise test.

    ``"holds"``: every level's within and between distances are disjoint; ``"mostly holds"``:
    they overlap but AUC >= `AUC_DISTINCT` at every level; ``"does not hold"`` otherwise.
    """
    aucs = [v["auc"] for v in levels.values()]
    gaps = [v["gap"] for v in levels.values()]
    if all(g > 0 for g in gaps):
        verdict = "holds"
    elif all(a >= AUC_DISTINCT for a in aucs):
        verdict = "mostly holds"
    else:
        verdict = "does not hold"
    parts = [
        f"{level}: largest within {v['max_within']:.3g}, smallest between "
        f"{v['min_between']:.3g} ({v['overlap_within']} of {v['n_within']} within-pairs and "
        f"{v['overlap_between']} of {v['n_between']} between-pairs in the overlap), "
        f"AUC {v['auc']:.3f}"
        for level, v in levels.items()
    ]
    return verdict, "; ".join(parts)


def noise_findings(noise: dict[str, Any], joints: dict[str, Any]) -> list[str]:
    """Whether the paper's stability and discrimination claims hold, per backend."""
    out = []
    samplers = noise["samplers"]
    main = samplers[0]
    for backend, result in noise[main]["backends"].items():
        verdict, detail = stability_verdict(result["l2"])
        out.append(
            f"Stability under object-pose noise, {backend} backend ({main} sampler, "
            f"{noise[main]['n_paths']} paths, L2): the paper's claim that within-object "
            f"distances are distinct from between-object ones {verdict.upper()}. {detail}."
        )
    both = noise[main]["backends"]
    if "voxel" in both and "exact" in both:
        v_verdict, _ = stability_verdict(both["voxel"]["l2"])
        e_verdict, _ = stability_verdict(both["exact"]["l2"])
        pairs = ", ".join(
            f"{level}: voxel {both['voxel']['l2'][level]['auc']:.3f} vs exact {e['auc']:.3f}"
            for level, e in both["exact"]["l2"].items()
        )
        same = "does not change" if v_verdict == e_verdict else "CHANGES"
        out.append(
            f"The estimator {same} the noise-test conclusion ({main} sampler; voxel: "
            f"{v_verdict}, exact: {e_verdict}); AUC per level {pairs}."
        )
    for backend in ("voxel", "exact"):
        parts = []
        for label in samplers:
            result = noise[label]["backends"].get(backend)
            if result:
                verdict, _ = stability_verdict(result["l2"])
                aucs = "/".join(f"{v['auc']:.3f}" for v in result["l2"].values())
                parts.append(f"{label} ({noise[label]['n_paths']} paths): {verdict}, AUC {aucs}")
        if len(parts) > 1:
            out.append(
                f"Samplers compared, {backend} backend, L2 per noise level: "
                + "; ".join(parts)
                + "."
            )
        diff = noise[main]["backends"].get(backend, {}).get("l2_diff")
        if diff:
            verdict, _ = stability_verdict(diff)
            aucs = "/".join(f"{v['auc']:.3f}" for v in diff.values())
            out.append(
                f"L2 of differences, {backend} backend ({main} sampler): separation {verdict} "
                f"(AUC {aucs})."
            )
    for backend, entry in joints["backends"].items():
        levels = entry["levels"]
        keys = list(levels)
        first, last = levels[keys[0]], levels[keys[-1]]
        between = noise.get(joints["sampler"], {}).get("backends", {}).get(backend, {})
        floor = min((v["min_between"] for v in between.get("l2", {}).values()), default=np.nan)
        above = ""
        if np.isfinite(floor):
            above = (
                f"; the smallest between-object distance of the pose-noise test on the same "
                f"sampler is {floor:.3g}, so joint noise up to {float(keys[-1]) * 100:g} % "
                + ("stays below it" if last["max"] < floor else "reaches it")
            )
        out.append(
            f"Joint noise, {backend} backend ({joints['grasp']}, {joints['sampler']} sampler, "
            f"{entry['draws']} draws per level): mean L2 distance to the unperturbed grasp "
            f"{first['mean']:.3g} at {float(keys[0]) * 100:g} % of the joint range, "
            f"{last['mean']:.3g} at {float(keys[-1]) * 100:g} % (max {last['max']:.3g}){above}."
        )
    return out


def headline(summary: dict[str, Any]) -> str:
    """The report in a few sentences, from its numbers."""
    parts = []
    est = summary.get("estimator")
    if est:
        o = est["overall"]
        steps = est["by_step"]
        med = np.array(steps["median_abs_rel"], dtype=float)
        worst = int(np.nanargmax(med))
        where = ("start", "middle", "end")[min(3 * worst // len(med), 2)]
        mag = [m if m is not None else np.nan for m in est["by_magnitude"]["median_abs_rel"]]
        depth = "shallow" if mag[0] > mag[-1] else "deep"
        direction = "over-estimates" if o["mean_signed_rel"] > 0 else "under-estimates"
        parts.append(
            f"The voxel estimator {direction} the intersection volume by "
            f"{_signed_pct(o['mean_signed_rel'])} on average (median |error| "
            f"{_pct(o['median_abs_rel'])}, 95th percentile {_pct(o['p95_abs_rel'])}), errs most "
            f"at the {where} of the paths (t = {steps['t'][worst]:.2f}) and for {depth} "
            "overlaps, and "
            f"reports an overlap at {_pct(o['false_positive_rate'])} of the poses where there is "
            "none."
        )
        desc = summary.get("descriptors", {}).get("l2")
        if desc:
            small = desc["spearman"] >= 0.95 and desc["nn_agreement"] >= 0.8
            parts.append(
                f"At the descriptor level this {'hardly matters' if small else 'matters'}: "
                "the L2 distances of the two "
                f"backends have rank correlation {desc['spearman']:.3f} and "
                f"{_pct(desc['nn_agreement'])} of grasps keep their nearest neighbour."
            )
    pose = summary["noise"]["object_pose"]
    main = pose["samplers"][0]
    verdicts = [
        f"{verdict} with the {backend} backend"
        for backend, result in pose[main]["backends"].items()
        for verdict in [stability_verdict(result["l2"])[0]]
    ]
    parts.append(
        "The paper's stability claim (within-object L2 distances distinct from between-object "
        f"ones, {main} sampler) "
        + " and ".join(verdicts)
        + ": "
        + ", ".join(
            f"{backend} AUC " + "/".join(f"{v['auc']:.3f}" for v in result["l2"].values())
            for backend, result in pose[main]["backends"].items()
        )
        + " at the two noise levels (1 = perfectly separated; 'holds': the two distributions "
        f"are disjoint at every level, 'mostly holds': they overlap but AUC >= {AUC_DISTINCT:g})."
    )
    return " ".join(parts)
