"""The C-frontier map (eq. 10): boundaries between known-free and unknown space on the COM."""

from __future__ import annotations

import numpy as np
from scipy import ndimage


def l1_gradient(field: np.ndarray, resolution: float) -> np.ndarray:
    """(h, w) ‖∇field‖₁ = |∂/∂x| + |∂/∂y|, per meter (central differences)."""
    gy, gx = np.gradient(field, resolution)
    return np.abs(gx) + np.abs(gy)


def frontier_map(prob: np.ndarray, prob_occ: np.ndarray, resolution: float, beta: float = 2.5,
                 smoothing: float = 0.1) -> np.ndarray:
    """C-frontier map F = ‖∇Λ‖₁ − β(‖∇Λo‖₁ + Λo − 0.5) (eq. 10).

    Args:
        prob: (h, w) fused occupancy probability Λ on a regular grid.
        prob_occ: (h, w) obstacle probability Λo on the same grid.
        resolution: cell size in meters; gradients are per meter, so β does not depend on it.
        beta: weight of the obstacle outlines (‖∇Λo‖₁) and obstacles (Λo − 0.5) removed.
        smoothing: standard deviation in meters of a Gaussian smoothing of Λ and Λo first
            (0 for none); it separates texture inside free space from real frontiers.

    Returns:
        (h, w) F; large where known free space meets unknown space, ≤ 0 on obstacles.
    """
    prob = np.asarray(prob, dtype=float)
    prob_occ = np.asarray(prob_occ, dtype=float)
    if prob.shape != prob_occ.shape or prob.ndim != 2:
        raise ValueError(f"Λ {prob.shape} and Λo {prob_occ.shape} must be grids of the same shape")
    if not resolution > 0:
        raise ValueError(f"resolution must be positive, got {resolution}")
    if smoothing > 0:
        sigma = smoothing / resolution
        prob = ndimage.gaussian_filter(prob, sigma, mode="nearest")
        prob_occ = ndimage.gaussian_filter(prob_occ, sigma, mode="nearest")
    return l1_gradient(prob, resolution) - beta * (l1_gradient(prob_occ, resolution) + prob_occ - 0.5)
