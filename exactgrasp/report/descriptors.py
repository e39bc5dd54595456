"""Descriptor level: do the two backends agree on which grasps look alike?"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.stats import spearmanr

from exactgrasp.descriptor import DISTANCE_KINDS, Descriptor, pairwise_distances


def nearest_neighbours(matrix: np.ndarray) -> np.ndarray:
    """Index of each row's nearest other row of a distance matrix.

    Parameters
    ----------
    matrix : numpy.ndarray, shape (n, n)

    Returns
    -------
    numpy.ndarray, shape (n,), int
    """
    masked = np.array(matrix, dtype=np.float64)
    np.fill_diagonal(masked, np.inf)
    return np.argmin(masked, axis=1)


def neighbour_agreement(a: np.ndarray, b: np.ndarray, k: int = 3) -> dict[str, float]:
    """How often two distance matrices pick the same neighbours.

    Parameters
    ----------
    a, b : numpy.ndarray, shape (n, n)
    k : int
        Size of the neighbour sets compared in ``topk_overlap``.

    Returns
    -------
    dict
        ``nn_agreement``: share of grasps whose nearest neighbour is the same under both;
        ``topk_overlap``: mean share of the k nearest neighbours in common.
    """
    n = a.shape[0]
    if n < 2:
        return {"nn_agreement": float("nan"), "topk_overlap": float("nan"), "k": k}
    same = nearest_neighbours(a) == nearest_neighbours(b)
    k = min(k, n - 1)
    overlaps = []
    for i in range(n):
        order_a = [j for j in np.argsort(a[i], kind="stable") if j != i][:k]
        order_b = [j for j in np.argsort(b[i], kind="stable") if j != i][:k]
        overlaps.append(len(set(order_a) & set(order_b)) / k)
    return {"nn_agreement": float(same.mean()), "topk_overlap": float(np.mean(overlaps)), "k": k}


def descriptor_report(
    names: Sequence[str],
    voxel: Sequence[Descriptor],
    exact: Sequence[Descriptor],
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Distance matrices of the same grasps from each backend, and how they agree.

    Parameters
    ----------
    names : sequence of str
    voxel, exact : sequence of Descriptor
        Same grasps, same order, same sampler.

    Returns
    -------
    summary : dict
        Per distance kind: ``spearman`` (rank correlation of the pairwise distances),
        ``pearson``, ``nn_agreement``, ``topk_overlap``, ``median_ratio`` (voxel distance over
        exact distance, over pairs), and the nearest neighbour of each grasp under each backend.
    matrices : dict
        ``"<kind>_<backend>"`` -> (n, n) distance matrix.
    """
    summary: dict[str, Any] = {"n_grasps": len(names)}
    matrices: dict[str, np.ndarray] = {}
    upper = np.triu_indices(len(names), k=1)
    for kind in DISTANCE_KINDS:
        dv = pairwise_distances(voxel, kind=kind)
        de = pairwise_distances(exact, kind=kind)
        matrices[f"{kind}_voxel"], matrices[f"{kind}_exact"] = dv, de
        pv, pe = dv[upper], de[upper]
        entry: dict[str, Any] = {}
        if pv.size >= 2 and pv.std() > 0 and pe.std() > 0:
            entry["spearman"] = float(spearmanr(pv, pe).statistic)
            entry["pearson"] = float(np.corrcoef(pv, pe)[0, 1])
        else:
            entry["spearman"] = entry["pearson"] = float("nan")
        positive = pe > 0
        entry["median_ratio"] = (
            float(np.median(pv[positive] / pe[positive])) if positive.any() else float("nan")
        )
        entry.update(neighbour_agreement(dv, de))
        nn_v, nn_e = nearest_neighbours(dv), nearest_neighbours(de)
        entry["nearest"] = {
            name: {"voxel": names[nn_v[i]], "exact": names[nn_e[i]]}
            for i, name in enumerate(names)
        }
        summary[kind] = entry
    return summary, matrices
