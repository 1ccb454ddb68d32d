"""Map drift: the generalised Jensen-Shannon divergence between maps (eqs. 12-13), cumulated."""

from __future__ import annotations

import numpy as np

EPS = 1e-12


def binary_entropy(p: np.ndarray) -> np.ndarray:
    """H(p) = −p log p − (1−p) log(1−p) in nats (eq. 13 for an occupied/free cell)."""
    p = np.clip(np.asarray(p, float), EPS, 1 - EPS)
    return -(p * np.log(p) + (1 - p) * np.log1p(-p))


def js_divergence(maps: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Generalised Jensen-Shannon divergence per cell (eq. 12) of n occupancy maps.

    Each cell of each map is a Bernoulli distribution (occupied with probability p).
    JS_π = H(Σ πᵢ pᵢ) − Σ πᵢ H(pᵢ). The paper sets all weights equal; they are normalised to
    sum to one, so JS ∈ [0, log 2] nats: 0 for identical maps, log 2 for maps that disagree
    with certainty (p = 0 against p = 1).

    Args:
        maps: (n, ...) probabilities.
        weights: (n,) πᵢ ≥ 0, default equal.

    Returns:
        (...) divergence in nats.
    """
    maps = np.asarray(maps, float)
    n = maps.shape[0]
    w = np.full(n, 1.0 / n) if weights is None else np.asarray(weights, float)
    if w.shape != (n,) or np.any(w < 0) or not w.sum() > 0:
        raise ValueError(f"js_divergence: need {n} non-negative weights, got {weights}")
    w = w / w.sum()
    wb = w.reshape((n,) + (1,) * (maps.ndim - 1))
    return np.maximum(binary_entropy((wb * maps).sum(0)) - (wb * binary_entropy(maps)).sum(0), 0.0)


class DriftMonitor:
    """Cumulates the JS divergence over iterations (Section VII) and says when to regenerate.

    Consistent scans disagree a little with the map too (sensor noise, discretisation), and
    summing that would call for a regeneration sooner or later on any long run. So only the
    part of each iteration's divergence above a tolerance is cumulated: ``factor`` times the
    median of the last ``window`` divergences (at least ``floor``); nothing is cumulated until
    ``warmup`` divergences have been seen.

    Args:
        threshold: cumulated excess divergence (nats per compared cell) past which the map
            must be regenerated.
    """

    def __init__(self, threshold: float, factor: float = 4.0, window: int = 50,
                 floor: float = 0.0, warmup: int = 10):
        if not threshold > 0:
            raise ValueError(f"drift threshold must be positive, got {threshold}")
        if not (factor >= 1 and window >= 1 and floor >= 0 and warmup >= 1):
            raise ValueError(f"drift monitor needs factor >= 1, window >= 1, floor >= 0, warmup >= 1; "
                             f"got {factor}, {window}, {floor}, {warmup}")
        self.threshold = threshold
        self.factor, self.window, self.floor, self.warmup = factor, window, floor, warmup
        self.cumulated = 0.0
        self.history: list[float] = []

    def tolerance(self) -> float:
        """The divergence an iteration may have without adding to the drift."""
        recent = [v for v in self.history[-self.window:] if np.isfinite(v)]
        if len(recent) < self.warmup:
            return np.inf
        return max(self.floor, self.factor * float(np.median(recent)))

    def add(self, divergence: float) -> bool:
        """Add one iteration's divergence; True when the cumulated excess passes the threshold."""
        if np.isfinite(divergence):
            self.cumulated += max(float(divergence) - self.tolerance(), 0.0)
        self.history.append(float(divergence))
        return self.exceeded

    @property
    def exceeded(self) -> bool:
        return self.cumulated > self.threshold

    def reset(self) -> None:
        """Forget the cumulated drift (after a regeneration); the baseline history is kept."""
        self.cumulated = 0.0
