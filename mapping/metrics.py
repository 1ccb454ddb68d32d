"""Map quality metrics: ROC AUC (and its two readings of a map), coverage and map entropy."""

from __future__ import annotations

import numpy as np
from scipy.stats import rankdata

from mapping.drift import binary_entropy


def roc_auc(labels: np.ndarray, scores: np.ndarray) -> float:
    """Area under the ROC curve of ``scores`` (n,) for binary ``labels`` (n,), ties counted
    half (the Mann-Whitney statistic). NaN when only one class is present."""
    labels = np.asarray(labels, bool).ravel()
    scores = np.asarray(scores, float).ravel()
    if labels.shape != scores.shape:
        raise ValueError(f"roc_auc: {labels.size} labels but {scores.size} scores")
    if not np.isfinite(scores).all():
        raise ValueError("roc_auc: scores must be finite")
    n_pos, n_neg = labels.sum(), (~labels).sum()
    if n_pos == 0 or n_neg == 0:
        return float("nan")
    ranks = rankdata(scores)
    return float((ranks[labels].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))


def auc_readings(labels: np.ndarray, frame, prob: np.ndarray, xy: np.ndarray) -> dict[str, float]:
    """ROC AUC of a map array ``prob`` (h, w) held in ``frame`` (a ``GridFrame``) at test
    points ``xy`` (n, 2) with binary ``labels`` (n,), read two ways:

    ``auc``: the continuous reading, bilinear between cell centres (the headline: the COM is a
    continuous map); ``auc_cell``: the value of the cell holding each point.
    """
    return {"auc": roc_auc(labels, frame.sample(prob, xy, bilinear=True)),
            "auc_cell": roc_auc(labels, frame.sample(prob, xy))}


#: A cell is known when |p − 0.5| exceeds this (the COM's free space sits at 0.2-0.36, a grid
#: cell seen free once at 0.3).
KNOWN = 0.1
#: Map entropy is measured on cells of this size (m), the paper's metric.
ENTROPY_CELL = 0.2


def coverage(prob: np.ndarray, threshold: float = KNOWN) -> float:
    """Fraction of the map values ``prob`` (read at the true free space: the cells or points to
    be explored) that the map knows: |p − 0.5| > ``threshold``."""
    prob = np.asarray(prob, float)
    if prob.size == 0:
        raise ValueError("coverage: no free space to cover")
    return float(np.mean(np.abs(prob - 0.5) > threshold))


def map_entropy(frame, prob: np.ndarray, extent: tuple[float, float, float, float],
                cell: float = ENTROPY_CELL) -> float:
    """Map entropy in nats (the paper's metric): Σ H(p) over the cells of size ``cell`` (m)
    tiling ``extent`` (xmin, xmax, ymin, ymax), the map array ``prob`` (h, w) on ``frame`` (a
    ``GridFrame``) read at each cell's centre; cells off the map count ln 2."""
    return float(binary_entropy(frame.sample(prob, entropy_cells(extent, cell))).sum())


def entropy_cells(extent: tuple[float, float, float, float], cell: float = ENTROPY_CELL) -> np.ndarray:
    """(k, 2) the centres of the cells of size ``cell`` (m) tiling ``extent`` (xmin, xmax,
    ymin, ymax) that ``map_entropy`` reads the map at."""
    xmin, xmax, ymin, ymax = extent
    gx = np.arange(xmin + cell / 2, xmax, cell)
    gy = np.arange(ymin + cell / 2, ymax, cell)
    return np.stack(np.meshgrid(gx, gy), axis=-1).reshape(-1, 2)
