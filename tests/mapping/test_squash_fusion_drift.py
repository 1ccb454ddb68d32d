"""Squashing (eq. 7), BCM fusion (eqs. 8-9), Jensen-Shannon drift (eqs. 12-13)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mapping.drift import DriftMonitor, binary_entropy, js_divergence
from mapping.fusion import BCMAccumulator, bcm_fuse
from mapping.squash import squash

finite = st.floats(-1e6, 1e6, allow_nan=False)


@given(finite, st.floats(1e-9, 1e9), st.floats(1e-6, 1e3), st.sampled_from([1.0, -1.0]))
def test_squash_is_a_probability_strictly_inside_0_1(mu, var, gamma, sign):
    p = squash(np.array([mu]), np.array([var]), 1e-3, gamma, sign)
    assert np.isfinite(p).all() and 0 < p[0] < 1


def test_squash_follows_eq7():
    mu, var, s2min, gamma = np.array([0.8, 0.8, -0.5]), np.array([0.01, 0.04, 0.01]), 0.01, 10.0
    w = gamma * np.sqrt(s2min / var)
    np.testing.assert_allclose(squash(mu, var, s2min, gamma), 1 / (1 + np.exp(-w * mu)))
    # the free map squashes −μf: confident free space is unoccupied
    assert squash(np.array([1.0]), np.array([0.01]), 0.01, gamma, -1.0)[0] < 1e-4
    # less confidence (larger variance) moves the probability toward 0.5
    p = squash(np.array([1.0, 1.0]), np.array([0.01, 1.0]), 0.01, gamma)
    assert 0.5 < p[1] < p[0]
    assert squash(np.array([0.0]), np.array([0.01]), 0.01, gamma)[0] == 0.5


def test_squash_rejects_bad_parameters():
    with pytest.raises(ValueError, match="gamma"):
        squash(np.zeros(1), np.ones(1), 0.1, 0.0)
    with pytest.raises(ValueError, match="sigma2_min"):
        squash(np.zeros(1), np.ones(1), np.nan, 1.0)


def test_bcm_fusion_of_two_gaussians_is_the_product_of_gaussians():
    m, v = bcm_fuse(np.array([0.2, 0.8]), np.array([0.01, 0.04]))
    assert v == pytest.approx(1 / (1 / 0.01 + 1 / 0.04))          # 0.008
    assert m == pytest.approx((0.2 / 0.01 + 0.8 / 0.04) / (1 / 0.01 + 1 / 0.04))  # 0.32
    m, v = bcm_fuse(np.array([[0.3], [0.9]]), np.array([[np.inf], [0.5]]))  # no information
    assert m[0] == pytest.approx(0.9) and v[0] == pytest.approx(0.5)
    m, v = bcm_fuse(np.array([[0.3]]), np.array([[np.inf]]))
    assert m[0] == 0.5 and v[0] == np.inf


def test_bcm_accumulator_equals_batch_fusion():
    rng = np.random.default_rng(0)
    means, variances = rng.uniform(0, 1, (5, 6)), rng.uniform(0.01, 1, (5, 6))
    acc = BCMAccumulator((2, 3))
    for m, v in zip(means, variances):
        acc.add(np.arange(6), m, v)
    m_ref, v_ref = bcm_fuse(means, variances)
    np.testing.assert_allclose(acc.mean().ravel(), m_ref)
    np.testing.assert_allclose(acc.variance(1.0).ravel(), v_ref)
    acc.pad((1, 0), (0, 2))
    assert acc.mean().shape == (3, 5) and acc.mean()[0, 0] == 0.5 and acc.variance(1.0)[0, 0] == 1.0


def test_js_of_identical_maps_is_zero_and_of_disjoint_maps_is_log2():
    p = np.random.default_rng(0).uniform(0, 1, (20, 20))
    np.testing.assert_allclose(js_divergence(np.stack([p, p, p])), 0.0, atol=1e-12)
    disjoint = js_divergence(np.stack([np.zeros((4, 4)), np.ones((4, 4))]))
    np.testing.assert_allclose(disjoint, np.log(2), rtol=1e-9)
    # anything else lies in between, and the definition of eq. 12 holds
    q = np.clip(p + 0.3, 0, 1)
    js = js_divergence(np.stack([p, q]))
    assert np.all((js >= 0) & (js <= np.log(2)))
    np.testing.assert_allclose(js, binary_entropy((p + q) / 2) - (binary_entropy(p) + binary_entropy(q)) / 2, atol=1e-12)


def test_drift_monitor_cumulates_only_the_excess_over_the_recent_median():
    d = DriftMonitor(threshold=0.1, factor=4.0, window=20, floor=0.0, warmup=10)
    for v in [0.005] * 9:
        assert not d.add(v)
    assert d.tolerance() == np.inf                 # still warming up
    d.add(0.005)
    assert d.tolerance() == pytest.approx(0.02)
    assert not d.add(0.019)                         # below 4 x median: noise
    assert d.cumulated == 0
    assert not d.add(0.07)                          # 0.05 above the tolerance
    assert d.cumulated == pytest.approx(0.05)
    assert d.add(0.08)                              # 0.05 + 0.06 > 0.1
    d.reset()
    assert d.cumulated == 0 and not d.exceeded
    with pytest.raises(ValueError):
        DriftMonitor(0.0)
