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
    width = 0
    for b in range(idx.shape[0]):
        width = max(width, start[b + 1] - start[b])
    V = np.empty((n, width))     # L⁻¹ k(X, x) of a block's queries, one column each
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
        q0, m = start[b], start[b + 1] - start[b]
        for q in range(m):
            mu = 0.0
            for a in range(k):
                r = np.sqrt((qxy[q0 + q, 0] - xs[a, 0]) ** 2 + (qxy[q0 + q, 1] - xs[a, 1]) ** 2)
                kx = _k(r, signal, lm, nu, lse)
                V[a, q] = kx
                mu += kx * alpha[a]
            mean[q0 + q] = mu
        # forward substitution for all the block's queries at once, row by row: each query's
        # sums in the same order as one at a time, but the inner loop runs over queries
        for a in range(k):
            for p in range(a):
                f = A[a, p]
                for q in range(m):
                    V[a, q] -= f * V[p, q]
            d = A[a, a]
            for q in range(m):
                V[a, q] /= d
        for q in range(m):
            ss = 0.0
            for a in range(k):
                ss += V[a, q] * V[a, q]
            var[q0 + q] = max(signal - ss, 0.0)
    return failed


@numba.njit(cache=True)
def nearest_within(pts, centres, k, reach, cell):
    """(B, k) indices of the ``k`` points of ``pts`` (N, 2) nearest to each of ``centres``
    (B, 2) and nearer than ``reach``, nearest first (ties by index), N where fewer are: a
    k-d tree query's answer (``cKDTree.query(centres, k, distance_upper_bound=reach)``).
    The points are binned in squares of side ``cell`` and searched ring by ring out from each
    centre's, until no point farther out can be nearer than the k-th found: for a block's
    few training points a tree's build and query cost 2.5 times this."""
    n = pts.shape[0]
    out = np.full((centres.shape[0], k), n, np.int64)
    if n == 0 or k == 0:
        return out
    x0, y0 = pts[:, 0].min(), pts[:, 1].min()
    nx = int((pts[:, 0].max() - x0) / cell) + 1
    ny = int((pts[:, 1].max() - y0) / cell) + 1
    first = np.zeros(nx * ny + 1, np.int64)        # bin b holds order[first[b]:first[b + 1]]
    bins = np.empty(n, np.int64)
    for i in range(n):
        bins[i] = int((pts[i, 1] - y0) / cell) * nx + int((pts[i, 0] - x0) / cell)
        first[bins[i] + 1] += 1
    for b in range(nx * ny):
        first[b + 1] += first[b]
    order = np.empty(n, np.int64)
    fill = first[:-1].copy()
    for i in range(n):
        order[fill[bins[i]]] = i
        fill[bins[i]] += 1
    bound = reach ** 2
    best_d, best_i = np.empty(k), np.empty(k, np.int64)     # the m nearest so far, sorted
    for c in range(centres.shape[0]):
        cx, cy = centres[c, 0], centres[c, 1]
        bx, by = int(np.floor((cx - x0) / cell)), int(np.floor((cy - y0) / cell))
        m = 0
        for ring in range(int(np.ceil(reach / cell)) + 1):
            for yy in range(max(by - ring, 0), min(by + ring, ny - 1) + 1):
                edge = yy == by - ring or yy == by + ring        # a whole row, else its two ends
                xx, step = bx - ring, 1 if edge else 2 * ring
                while xx <= bx + ring:
                    if 0 <= xx < nx:
                        b = yy * nx + xx
                        for o in range(first[b], first[b + 1]):
                            i = order[o]
                            d = (pts[i, 0] - cx) ** 2 + (pts[i, 1] - cy) ** 2
                            if not d < bound or (m == k and (d > best_d[k - 1] or (
                                    d == best_d[k - 1] and i > best_i[k - 1]))):
                                continue
                            j = min(m, k - 1)
                            while j > 0 and (best_d[j - 1] > d or (best_d[j - 1] == d and best_i[j - 1] > i)):
                                best_d[j], best_i[j] = best_d[j - 1], best_i[j - 1]
                                j -= 1
                            best_d[j], best_i[j] = d, i
                            m = min(m + 1, k)
                    if step == 0:
                        break
                    xx += step
            # every point of the rings beyond lies at least ring cells from the centre
            if m == k and best_d[k - 1] < (ring * cell) ** 2:
                break
        for j in range(m):
            out[c, j] = best_i[j]
    return out


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
