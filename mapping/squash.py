"""Logistic squashing of a GP's output into an occupancy probability (eq. 7)."""

from __future__ import annotations

import numpy as np


def squash(mean: np.ndarray, var: np.ndarray, sigma2_min: float, gamma: float,
           sign: float = 1.0) -> np.ndarray:
    """p = 1 / (1 + exp(−w·μ)), w = sign·γ·√λ, λ = σ²min/σ² bounded to [0, 1] (eq. 7).

    The obstacle map uses ``sign=+1`` on μo (occupancy rises with the obstacle GP); the free
    map uses ``sign=-1`` on μf (occupancy falls where the free GP is confident).

    Args:
        mean, var: GP posterior mean and variance, same shape.
        sigma2_min: the smallest variance the GP reaches (λ = 1 there).
        gamma: γ > 0.

    Returns:
        probabilities in (0, 1), same shape; exactly 0.5 where μ = 0 or σ² is infinite.
    """
    if not gamma > 0:
        raise ValueError(f"squash: gamma must be positive, got {gamma}")
    if not sigma2_min > 0:
        raise ValueError(f"squash: sigma2_min must be positive, got {sigma2_min}")
    var = np.maximum(np.asarray(var, float), sigma2_min)
    lam = sigma2_min / var
    z = sign * gamma * np.sqrt(lam) * np.asarray(mean, float)
    # clip the exponent: exp overflows past ~709 and a probability of exactly 0/1 would make
    # the log-odds and entropy infinite downstream
    return 1.0 / (1.0 + np.exp(-np.clip(z, -30.0, 30.0)))
