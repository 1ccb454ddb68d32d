"""Kernels against scipy's Bessel-function Matérn; GP posterior against the closed form; a local
GP's training points against every distance."""

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.special import gamma, kv

from mapping.gp import GaussianProcess, fit_hyperparameters
from mapping.kernels import Kernel, matern, squared_exponential
from mapping.localgp import nearest_within, predict_blocks


def matern_bessel(r, length, nu):
    """Eq. 5 with the modified Bessel function of the second kind."""
    s = np.sqrt(2 * nu) * r / length
    with np.errstate(invalid="ignore"):
        v = s ** nu * kv(nu, s) / (gamma(nu) * 2 ** (nu - 1))
    return np.where(r == 0, 1.0, v)


@pytest.mark.parametrize("nu", [0.5, 1.5, 2.5])
@pytest.mark.parametrize("length", [0.1, 0.7, 3.0])
def test_matern_matches_bessel_form(nu, length):
    r = np.linspace(0, 5, 101)
    np.testing.assert_allclose(matern(r, length, nu), matern_bessel(r, length, nu), rtol=1e-10, atol=1e-14)


def test_squared_exponential_decays_with_the_minus_sign():
    r = np.array([0.0, 1.0, 2.0])
    np.testing.assert_allclose(squared_exponential(r, 1.0), np.exp(-0.5 * r ** 2))


def test_product_kernel_is_signal_times_matern_times_se():
    k = Kernel(2.0, 0.5, 1.5, se_length=1.3)
    a, b = np.array([[0.0, 0.0], [1.0, 0.5]]), np.array([[0.3, -0.2]])
    r = np.hypot(*(a - b).T)
    np.testing.assert_allclose(k(a, b)[:, 0], 2.0 * matern_bessel(r, 0.5, 1.5) * np.exp(-0.5 * (r / 1.3) ** 2))


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf])
def test_non_positive_length_scale_rejected(bad):
    with pytest.raises(ValueError, match="length scale"):
        Kernel(1.0, bad)
    with pytest.raises(ValueError, match="length scale"):
        Kernel(1.0, 0.5, se_length=bad)


def closed_form(kernel, noise, X, y, Q):
    """Eqs. 3-4 with an explicit inverse."""
    Kinv = np.linalg.inv(kernel(X, X) + noise * np.eye(len(X)))
    Kq = kernel(Q, X)
    return Kq @ Kinv @ y, kernel.signal_var - np.einsum("ij,jk,ik->i", Kq, Kinv, Kq)


@pytest.mark.parametrize("kernel", [Kernel(1.0, 0.4), Kernel(0.7, 0.3, 2.5, se_length=1.1)])
def test_gp_posterior_matches_closed_form(kernel):
    rng = np.random.default_rng(1)
    X, Q = rng.uniform(-1, 1, (12, 2)), rng.uniform(-1.5, 1.5, (30, 2))
    y = rng.normal(size=12)
    gp = GaussianProcess(kernel, 0.05).fit(X, y)
    mean, var = gp.predict(Q)
    m_ref, v_ref = closed_form(kernel, 0.05, X, y, Q)
    np.testing.assert_allclose(mean, m_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(var, v_ref, rtol=1e-9, atol=1e-12)
    # the log marginal likelihood of a Gaussian: log N(y; 0, K + σn² I)
    from scipy.stats import multivariate_normal
    K = kernel(X, X) + 0.05 * np.eye(12)
    assert gp.log_marginal_likelihood() == pytest.approx(multivariate_normal(np.zeros(12), K).logpdf(y))


def test_local_gp_blocks_match_exact_gps_with_targets_one():
    rng = np.random.default_rng(2)
    kernel = Kernel(1.0, 0.3, 1.5, se_length=0.8)
    pts = rng.uniform(0, 3, (40, 2))
    idx = np.array([[0, 5, 7, 9, 40, 40], [1, 2, 3, 4, 6, 8], [40] * 6])  # 40 = padding
    Q = rng.uniform(0, 3, (9, 2))
    start = np.array([0, 4, 7, 9])
    mean, var = predict_blocks(kernel, 0.02, pts, idx, Q, start)
    for b in range(2):
        sel = idx[b][idx[b] < 40]
        m_ref, v_ref = closed_form(kernel, 0.02, pts[sel], np.ones(len(sel)), Q[start[b]:start[b + 1]])
        np.testing.assert_allclose(mean[start[b]:start[b + 1]], m_ref, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(var[start[b]:start[b + 1]], v_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(mean[7:], 0.0)            # no training points: the prior
    np.testing.assert_allclose(var[7:], 1.0)


def brute_nearest(pts, centres, k, reach):
    """The k nearest points nearer than reach, by squared distance then index, from every
    distance at once; len(pts) pads."""
    out = np.full((len(centres), k), len(pts))
    for c, centre in enumerate(centres):
        d = ((pts - centre) ** 2).sum(axis=1)
        near = np.lexsort((np.arange(len(pts)), d))
        near = near[d[near] < reach ** 2][:k]
        out[c, :len(near)] = near
    return out


@pytest.mark.parametrize("seed", range(6))
def test_a_block_trains_on_the_points_nearest_its_centre_within_reach(seed):
    rng = np.random.default_rng(seed)
    # clustered points on a 1/16 m lattice (exact ties of distance, duplicates), and scattered
    lattice = np.round(rng.uniform(-3, 3, (rng.integers(1, 300), 2)) * 16) / 16
    pts = np.concatenate([lattice, lattice[:20], rng.uniform(-8, 8, (rng.integers(0, 60), 2))])
    centres = rng.uniform(-10, 10, (200, 2))                 # some far beyond every point
    centres[:100] = np.round(centres[:100] / 3 * 16) / 16    # on the lattice: points tie
    for k, reach in ((16, 1.35), (5, 0.4), (3, 0.2), (len(pts) + 3, 2.0)):
        got = nearest_within(pts, centres, k, reach, 0.5)
        np.testing.assert_array_equal(got, brute_nearest(pts, centres, k, reach))
    smooth = rng.uniform(0, 20, (900, 2))                    # no ties: a k-d tree's answer
    _, tree = cKDTree(smooth).query(centres + 10, k=16, distance_upper_bound=1.35)
    np.testing.assert_array_equal(nearest_within(smooth, centres + 10, 16, 1.35, 0.5), tree)


def test_gp_survives_duplicate_points_and_rejects_nan():
    X = np.zeros((5, 2))                                  # singular K without noise
    gp = GaussianProcess(Kernel(1.0, 0.3), 1e-12).fit(X, np.ones(5))
    mean, var = gp.predict(np.array([[0.0, 0.0]]))
    assert np.isfinite(mean).all() and np.isfinite(var).all()
    with pytest.raises(ValueError, match="finite"):
        GaussianProcess(Kernel(1.0, 0.3), 0.1).fit(np.array([[np.nan, 0.0]]), np.ones(1))


def test_hyperparameter_fit_recovers_a_length_scale_and_keeps_the_noise_floor():
    rng = np.random.default_rng(3)
    X = rng.uniform(0, 6, (150, 2))
    true = Kernel(1.0, 0.8, 1.5)
    y = np.linalg.cholesky(true(X, X) + 1e-8 * np.eye(150)) @ rng.normal(size=150)
    k, noise = fit_hyperparameters(X, y, Kernel(1.0, 0.2, 1.5), 0.1, (0.05, 5.0), 0.01)
    assert 0.4 < k.matern_length < 1.6
    assert noise >= 0.01
