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


def coverage(prob: np.ndarray, free_mask: np.ndarray, threshold: float = 0.2) -> float:
    """Fraction of the cells in ``free_mask`` (the true reachable free space, same shape as
    ``prob``) that the map knows: |Λ − 0.5| > ``threshold``."""
    prob, free_mask = np.asarray(prob, float), np.asarray(free_mask, bool)
    if prob.shape != free_mask.shape:
        raise ValueError(f"coverage: map {prob.shape} and mask {free_mask.shape} differ")
    if not free_mask.any():
        raise ValueError("coverage: the free-space mask is empty")
    return float((np.abs(prob[free_mask] - 0.5) > threshold).mean())


def map_entropy(prob: np.ndarray, resolution: float, cell: float = 0.2) -> float:
    """Map entropy in nats on a ``cell``-sized grid (the paper's metric): Σ H(p) over cells.

    ``prob`` (h, w) at ``resolution`` m is block-averaged to ``cell`` m (an integer multiple
    of the resolution, or equal to it); a trailing partial block is averaged over what it has.
    """
    prob = np.asarray(prob, float)
    f = cell / resolution
    k = int(round(f))
    if k < 1 or abs(f - k) > 1e-6:
        raise ValueError(f"map_entropy: cell {cell} m must be a multiple of the resolution {resolution} m")
    h, w = prob.shape
    H, W = -(-h // k), -(-w // k)
    padded = np.full((H * k, W * k), np.nan)
    padded[:h, :w] = prob
    coarse = np.nanmean(padded.reshape(H, k, W, k), axis=(1, 3))
    return float(binary_entropy(coarse).sum())
