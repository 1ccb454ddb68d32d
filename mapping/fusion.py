"""Bayesian Committee Machine fusion (eqs. 8-9) of local maps into the global map.

As the paper fuses probabilities (not latent GP values), the prior term −(p−1)Σ⁻¹ of eq. 9 is
dropped: a cell's estimate is the precision-weighted mean of the local estimates, and its
precision the sum of theirs. A cell no local map has seen keeps probability 0.5 and the prior
variance.
"""

from __future__ import annotations

import numpy as np


def bcm_fuse(means: np.ndarray, variances: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fuse p estimates per point with the BCM (eqs. 8-9 without the prior term).

    Args:
        means: (p, ...) the estimates E(f'|Dᵢ).
        variances: (p, ...) their variances cov(f'|Dᵢ), > 0 (inf = no information).

    Returns:
        (mean, variance), each of shape (...): C⁻¹ Σ cov⁻¹ E and C⁻¹, C = Σ cov⁻¹.
    """
    means = np.asarray(means, float)
    precision = 1.0 / np.asarray(variances, float)
    if np.any(precision < 0) or np.isnan(precision).any():
        raise ValueError("bcm_fuse: variances must be positive (or inf for no information)")
    C = precision.sum(axis=0)
    weighted = np.where(precision > 0, precision * means, 0.0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(C > 0, weighted / C, 0.5)
        var = np.where(C > 0, 1.0 / C, np.inf)
    return mean, var


class BCMAccumulator:
    """The running BCM sums of one global map on a grid: Σ cov⁻¹ and Σ cov⁻¹·E per cell.

    Args:
        shape: (h, w) grid.
    """

    def __init__(self, shape: tuple[int, int]):
        self.precision = np.zeros(shape)
        self.weighted = np.zeros(shape)

    def add(self, flat_cells: np.ndarray, mean: np.ndarray, var: np.ndarray) -> None:
        """Fuse a local map: (k,) flat cell indices (unique), (k,) means and variances (> 0)."""
        precision = 1.0 / var
        self.precision.flat[flat_cells] += precision
        self.weighted.flat[flat_cells] += precision * mean

    def mean(self, box: tuple[slice, slice] = np.s_[:, :]) -> np.ndarray:
        """(h, w) fused probability (eq. 8), or its ``box``; 0.5 where nothing was fused."""
        precision = self.precision[box]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(precision > 0, self.weighted[box] / precision, 0.5)

    def variance(self, prior_var: float) -> np.ndarray:
        """(h, w) fused variance C⁻¹ (eq. 9); ``prior_var`` where nothing was fused."""
        with np.errstate(divide="ignore"):
            return np.where(self.precision > 0, 1.0 / self.precision, prior_var)

    def pad(self, before: tuple[int, int], after: tuple[int, int]) -> None:
        """Grow the grid by (rows, cols) ``before`` and ``after``."""
        width = ((before[0], after[0]), (before[1], after[1]))
        self.precision = np.pad(self.precision, width)
        self.weighted = np.pad(self.weighted, width)
