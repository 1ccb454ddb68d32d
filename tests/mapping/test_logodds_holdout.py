"""The log-odds grid baseline and the hold-out protocols."""

import gtsam
import numpy as np
import pytest

from mapping.config import TrainingConfig
from mapping.holdout import split
from mapping.logodds import LogOddsConfig, LogOddsGrid
from mapping.training import beam_samples
from slam.scan import LaserScan


def test_grid_frees_the_cells_a_beam_crosses_and_occupies_its_hit_cell():
    grid = LogOddsGrid(LogOddsConfig(l_occ=2.0, l_free=-0.5))
    scan = LaserScan(np.array([2.0, np.nan, 9.0]), np.array([0.0, 0.5, np.pi / 2]), max_range=8.0)
    grid.update(gtsam.Pose2(0.05, 0.05, 0.0), scan)
    P = grid.prob()
    at = lambda x, y: grid.sample(P, np.array([[x, y]]))[0]  # noqa: E731
    assert at(2.05, 0.05) == pytest.approx(1 / (1 + np.exp(-2.0)))     # the hit cell, once
    for x in (0.15, 1.0, 1.85):
        assert at(x, 0.05) == pytest.approx(1 / (1 + np.exp(0.5)))     # crossed: freed once
    assert at(2.5, 0.05) == 0.5                                         # behind the hit: unknown
    assert at(0.05, 7.5) < 0.5 and at(0.05, 8.5) == 0.5                 # no return: free to max range
    assert at(0.5, 0.5) == 0.5                                          # the NaN beam gave nothing
    for _ in range(100):
        grid.update(gtsam.Pose2(0.05, 0.05, 0.0), scan)
    assert grid.logodds.max() == pytest.approx(10.0) and grid.logodds.min() == pytest.approx(-10.0)


@pytest.mark.parametrize("protocol", ["points", "beams"])
def test_holdout_splits_each_scan_into_disjoint_train_and_test(protocol):
    rng = np.random.default_rng(0)
    angles = np.deg2rad(np.arange(-90, 90, 1.0))
    scan = LaserScan(rng.uniform(1, 6, 180), angles, 8.0)
    s = beam_samples(gtsam.Pose2(1, 2, 0.3), scan, TrainingConfig())
    part = split(s, 180, 0.2, protocol, np.random.default_rng(1))
    n_all = len(s.hits) + len(s.free)
    n_train = len(part.train.hits) + len(part.train.free)
    assert n_train + len(part.test_xy) == n_all
    assert 0.15 < len(part.test_xy) / n_all < 0.25
    train = {tuple(p) for p in np.vstack([part.train.hits, part.train.free]).round(9)}
    assert not train & {tuple(p) for p in part.test_xy.round(9)}
    assert part.test_occ.sum() == len(s.hits) - len(part.train.hits)
    if protocol == "beams":   # no point of a held-out beam is trained on
        assert not np.isin(part.train.free_beam, np.flatnonzero(part.held_beams)).any()
        assert not np.isin(part.train.hit_beam, np.flatnonzero(part.held_beams)).any()
    with pytest.raises(ValueError, match="protocol"):
        split(s, 180, 0.2, "cells", rng)
