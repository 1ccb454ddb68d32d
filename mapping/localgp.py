"""Many small local GPs answered in one compiled pass (eqs. 3-4), the COM's hot path.

Each block of the query set has its own GP trained on the few training points nearest to it;
the kernel (Matérn, optionally × squared exponential), the Cholesky factorisation and the
triangular solves are fused in one numba loop, with no temporaries per block.
"""

from __future__ import annotations

import numba
import numpy as np

from mapping.kernels import Kernel

_NU_CODE = {0.5: 0, 1.5: 1, 2.5: 2}
_JITTERS = (0.0, 1e-8, 1e-6, 1e-4)


@numba.njit(cache=True, inline="always")
def _k(r, signal, lm, nu, lse):
    e = -0.5 * (r / lse) ** 2 if lse > 0 else 0.0      # the SE factor shares one exp
    if nu == 0:
        return signal * np.exp(e - r / lm)
    if nu == 1:
        s = np.sqrt(3.0) * r / lm
        return signal * (1.0 + s) * np.exp(e - s)
    s = np.sqrt(5.0) * r / lm
    return signal * (1.0 + s + s * s / 3.0) * np.exp(e - s)


@numba.njit(cache=True)
def _cholesky_inplace(A, k, jitter):
    """Lower Cholesky factor of A[:k, :k] (+ jitter·I) in place; False if not positive definite."""
    for j in range(k):
        s = A[j, j] + jitter
        for p in range(j):
            s -= A[j, p] * A[j, p]
        if s <= 0.0:
            return False
        d = np.sqrt(s)
        A[j, j] = d
        for i in range(j + 1, k):
            t = A[i, j]
            for p in range(j):
                t -= A[i, p] * A[j, p]
            A[i, j] = t / d
    return True


@numba.njit(cache=True)
def _local_gps(pts, idx, qxy, start, signal, lm, nu, lse, noise, jitters, mean, var):
    N = pts.shape[0]
    n = idx.shape[1]
    A = np.empty((n, n))
    xs = np.empty((n, 2))
    alpha = np.empty(n)
    v = np.empty(n)
    failed = 0
    for b in range(idx.shape[0]):
        k = 0
        for j in range(n):
            i = idx[b, j]
            if i < N:
                xs[k, 0] = pts[i, 0]
                xs[k, 1] = pts[i, 1]
                k += 1
        if k == 0:
            for q in range(start[b], start[b + 1]):
                mean[q] = 0.0
                var[q] = signal
            continue
        ok = False
        for jit in jitters:
            for a in range(k):
                for c in range(a + 1):
                    r = np.sqrt((xs[a, 0] - xs[c, 0]) ** 2 + (xs[a, 1] - xs[c, 1]) ** 2)
                    A[a, c] = _k(r, signal, lm, nu, lse)
                A[a, a] += noise
            if _cholesky_inplace(A, k, jit * signal):
                ok = True
                break
        if not ok:
            failed += 1
            for q in range(start[b], start[b + 1]):
                mean[q] = 0.0
                var[q] = signal
            continue
        # alpha = K⁻¹ 1 (targets are +1): forward then backward substitution
        for a in range(k):
            t = 1.0
            for p in range(a):
                t -= A[a, p] * alpha[p]
            alpha[a] = t / A[a, a]
        for a in range(k - 1, -1, -1):
            t = alpha[a]
            for p in range(a + 1, k):
                t -= A[p, a] * alpha[p]
            alpha[a] = t / A[a, a]
        for q in range(start[b], start[b + 1]):
            m = 0.0
            for a in range(k):
                r = np.sqrt((qxy[q, 0] - xs[a, 0]) ** 2 + (qxy[q, 1] - xs[a, 1]) ** 2)
                kx = _k(r, signal, lm, nu, lse)
                v[a] = kx
                m += kx * alpha[a]
            ss = 0.0
            for a in range(k):  # v = L⁻¹ k(x, x')
                t = v[a]
                for p in range(a):
                    t -= A[a, p] * v[p]
                t /= A[a, a]
                v[a] = t
                ss += t * t
            mean[q] = m
            var[q] = max(signal - ss, 0.0)
    return failed


def predict_blocks(kernel: Kernel, noise_var: float, pts: np.ndarray, idx: np.ndarray,
                   qxy: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Posterior mean and variance of B local GPs with targets +1 (eqs. 3-4).

    Args:
        pts: (N, 2) training points shared by all blocks.
        idx: (B, n) indices into ``pts`` of each block's training points; N marks padding.
        qxy: (M, 2) query points, grouped by block: block b owns ``qxy[start[b]:start[b+1]]``.
        start: (B + 1,) offsets.

    Returns:
        mean, var: (M,) each. A block without training points returns the prior (0, k(x, x)).
    """
    if noise_var <= 0:
        raise ValueError(f"local GP noise variance must be positive, got {noise_var}")
    mean = np.empty(len(qxy))
    var = np.empty(len(qxy))
    _local_gps(np.ascontiguousarray(pts, np.float64), np.ascontiguousarray(idx, np.int64),
               np.ascontiguousarray(qxy, np.float64), np.ascontiguousarray(start, np.int64),
               float(kernel.signal_var), float(kernel.matern_length), _NU_CODE[kernel.nu],
               float(kernel.se_length or 0.0), float(noise_var), np.array(_JITTERS), mean, var)
    return mean, var
