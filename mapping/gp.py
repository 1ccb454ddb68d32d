"""Gaussian-process regression (eqs. 3-4): an exact GP, a batch of small local GPs, and the
marginal-likelihood fit of the hyperparameters."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from mapping.kernels import Kernel

#: Jitter added to the diagonal, relative to the prior variance, when a Cholesky fails.
JITTERS = (0.0, 1e-8, 1e-6, 1e-4)


def _cholesky(K: np.ndarray, scale: float) -> np.ndarray:
    """Cholesky factor of (a stack of) SPD matrices, adding jitter until it succeeds."""
    eye = np.eye(K.shape[-1])
    for jitter in JITTERS:
        try:
            return np.linalg.cholesky(K + jitter * scale * eye)
        except np.linalg.LinAlgError:
            continue
    raise np.linalg.LinAlgError(
        f"covariance matrix not positive definite even with jitter {JITTERS[-1] * scale:g}")


@dataclass
class GaussianProcess:
    """Exact GP regression with zero prior mean.

    Args:
        kernel: the covariance function k.
        noise_var: observation noise variance σn².

    After ``fit``: ``X_`` (n, 2), ``L_`` (n, n) Cholesky factor of K + σn²I, ``alpha_`` (n,).
    """

    kernel: Kernel
    noise_var: float

    def fit(self, X: np.ndarray, y: np.ndarray) -> "GaussianProcess":
        """Condition on training inputs ``X`` (n, 2) and targets ``y`` (n,)."""
        X = np.asarray(X, float).reshape(-1, 2)
        y = np.asarray(y, float).reshape(-1)
        if len(X) != len(y):
            raise ValueError(f"GP fit: {len(X)} inputs but {len(y)} targets")
        if not (np.isfinite(X).all() and np.isfinite(y).all()):
            raise ValueError("GP fit: training inputs and targets must be finite")
        K = self.kernel(X, X) + self.noise_var * np.eye(len(X))
        self.X_ = X
        self.L_ = _cholesky(K, self.kernel.prior_var)
        self.alpha_ = np.linalg.solve(self.L_.T, np.linalg.solve(self.L_, y))
        self.y_ = y
        return self

    def predict(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean (eq. 3) and variance (eq. 4) of f at query points ``Q`` (m, 2)."""
        Q = np.asarray(Q, float).reshape(-1, 2)
        if len(self.X_) == 0:
            return np.zeros(len(Q)), np.full(len(Q), self.kernel.prior_var)
        Kqx = self.kernel(Q, self.X_)
        mean = Kqx @ self.alpha_
        V = np.linalg.solve(self.L_, Kqx.T)
        var = np.maximum(self.kernel.prior_var - np.einsum("ij,ij->j", V, V), 0.0)
        return mean, var

    def log_marginal_likelihood(self) -> float:
        """log p(y | X, θ) of the fitted data."""
        n = len(self.y_)
        return float(-0.5 * self.y_ @ self.alpha_ - np.log(np.diag(self.L_)).sum()
                     - 0.5 * n * np.log(2 * np.pi))


def fit_hyperparameters(X: np.ndarray, y: np.ndarray, init: Kernel, noise_var: float,
                        length_bounds: tuple[float, float], noise_floor: float,
                        seed: int = 0, fit_signal: bool = False,
                        se_bounds: tuple[float, float] | None = None) -> tuple[Kernel, float]:
    """Maximise the log marginal likelihood over the lengths and the noise (and the signal
    variance if ``fit_signal``), from the values of ``init``.

    Uses scikit-learn's kernels and L-BFGS-B optimiser; the noise variance is kept at or above
    ``noise_floor`` (with +1-only targets the optimum otherwise drives it to zero). Lengths
    stay within ``length_bounds`` (Matérn) and ``se_bounds`` (SE).

    Args:
        X: (n, 2) inputs; y: (n,) targets.
        init: kernel with the starting values (its ``se_length`` decides SE × Matérn or not).

    Returns:
        (fitted kernel, fitted noise variance).
    """
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern, WhiteKernel

    if len(X) < 3:
        raise ValueError(f"hyperparameter fit needs at least 3 points, got {len(X)}")
    signal_bounds = (1e-2, 1e2) if fit_signal else "fixed"
    sk = ConstantKernel(init.signal_var, signal_bounds) * Matern(
        init.matern_length, length_bounds, nu=init.nu)
    if init.se_length is not None:
        sk = sk * RBF(init.se_length, se_bounds or length_bounds)
    sk = sk + WhiteKernel(max(noise_var, noise_floor), (noise_floor, 1.0))
    gpr = GaussianProcessRegressor(sk, alpha=1e-10, optimizer="fmin_l_bfgs_b",
                                   n_restarts_optimizer=0, random_state=seed)
    X, y = np.asarray(X, float), np.asarray(y, float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # bound-hitting ConvergenceWarnings are expected here
        gpr.fit(X, y)
    p = gpr.kernel_.get_params()
    product = p["k1"]
    if init.se_length is None:
        signal, mat, se = product.k1.constant_value, product.k2.length_scale, None
    else:
        signal = product.k1.k1.constant_value
        mat, se = product.k1.k2.length_scale, product.k2.length_scale
    noise = p["k2"].noise_level
    kernel = Kernel(float(signal), float(mat), init.nu, None if se is None else float(se))
    return kernel, float(max(noise, noise_floor))
