"""Covariance functions of the two GPs: Matérn (eq. 5) and squared exponential (eq. 6).

Distances are in meters. All functions take distances ``r`` of any shape and return the
covariance with the same shape; the classes add a signal variance and evaluate on point sets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SQRT3 = np.sqrt(3.0)
SQRT5 = np.sqrt(5.0)


def _check_length(length: float, what: str) -> None:
    if not (np.isfinite(length) and length > 0):
        raise ValueError(f"{what} length scale must be positive and finite, got {length}")


def matern(r: np.ndarray, length: float, nu: float = 1.5) -> np.ndarray:
    """Matérn correlation (eq. 5) for ν ∈ {1/2, 3/2, 5/2}, in closed form; 1 at r = 0.

    Args:
        r: distances (any shape), meters, ≥ 0.
        length: characteristic length κ, meters.
        nu: smoothness ν.
    """
    _check_length(length, "Matérn")
    if nu == 0.5:
        return np.exp(-np.asarray(r) / length)
    if nu == 1.5:
        s = SQRT3 * np.asarray(r) / length
        return (1.0 + s) * np.exp(-s)
    if nu == 2.5:
        s = SQRT5 * np.asarray(r) / length
        return (1.0 + s + s * s / 3.0) * np.exp(-s)
    raise ValueError(f"Matérn nu must be 0.5, 1.5 or 2.5 for the closed form, got {nu}")


def squared_exponential(r: np.ndarray, length: float) -> np.ndarray:
    """Squared exponential correlation exp(−r²/(2κ²)) (eq. 6; the paper's text drops the minus
    sign and writes κ for κ²); 1 at r = 0."""
    _check_length(length, "squared-exponential")
    r = np.asarray(r)
    return np.exp(-0.5 * (r / length) ** 2)


def pairwise_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., n, 2) and (..., m, 2) points -> (..., n, m) Euclidean distances."""
    d = a[..., :, None, :] - b[..., None, :, :]
    return np.sqrt(np.einsum("...k,...k->...", d, d))


@dataclass(frozen=True)
class Kernel:
    """k(x, x') = signal_var · Matérn(r; matern_length, nu) · [SE(r; se_length) if se_length].

    The obstacle GP uses ``se_length=None`` (Matérn only); the free GP uses SE × Matérn.
    """

    signal_var: float
    matern_length: float
    nu: float = 1.5
    se_length: float | None = None

    def __post_init__(self):
        if not (np.isfinite(self.signal_var) and self.signal_var > 0):
            raise ValueError(f"kernel signal variance must be positive, got {self.signal_var}")
        _check_length(self.matern_length, "Matérn")
        if self.se_length is not None:
            _check_length(self.se_length, "squared-exponential")
        if self.nu not in (0.5, 1.5, 2.5):
            raise ValueError(f"Matérn nu must be 0.5, 1.5 or 2.5, got {self.nu}")

    def of_distance(self, r: np.ndarray) -> np.ndarray:
        """Covariance at distances ``r`` (any shape)."""
        k = self.signal_var * matern(r, self.matern_length, self.nu)
        if self.se_length is not None:
            k = k * squared_exponential(r, self.se_length)
        return k

    def __call__(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(..., n, 2), (..., m, 2) -> (..., n, m) covariance."""
        return self.of_distance(pairwise_distances(np.asarray(a, float), np.asarray(b, float)))

    @property
    def prior_var(self) -> float:
        """k(x, x): the prior variance of the latent function."""
        return float(self.signal_var)
