"""Correlative scan matching: a 1.5 m / 20° offset recovered on a real Intel scan pair and in a
noiseless L-shaped room, branch and bound equal to brute force, unrelated references and too small
windows rejected, and the precomputation grids equal to the block maxima they stand for."""

import math

import gtsam
import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view

from slam.carmen import CarmenLog
from slam.config import CorrelativeConfig
from slam.correlative import (CorrelativeGrid, angular_step, match, match_exhaustive,
                              precompute, score, thin)
from slam.registration import transform
from wall_scans import cast

# L-shaped room, corners (0, 0) (8, 0) (8, 4) (4, 4) (4, 8) (0, 8): walls (axis, value, lo, hi)
L_ROOM = [(1, 0.0, 0, 8), (0, 8.0, 0, 4), (1, 4.0, 4, 8), (0, 4.0, 4, 8), (1, 8.0, 0, 4), (0, 0.0, 0, 8)]
CORRIDOR = [(1, 0.0, -50, 50), (1, 2.0, -50, 50)]
# 1.5 m and ±20° off the truth, in four directions
OFFSETS = [(1.5, 0.0, 20.0), (0.0, -1.5, -20.0), (-1.5 / math.sqrt(2), 1.5 / math.sqrt(2), 20.0),
           (1.5 / math.sqrt(2), 1.5 / math.sqrt(2), -20.0)]


def off(truth: gtsam.Pose2, dx: float, dy: float, ddeg: float) -> gtsam.Pose2:
    return gtsam.Pose2(truth.x() + dx, truth.y() + dy, truth.theta() + math.radians(ddeg))


@pytest.fixture(scope="module")
def intel(shared_data):
    return CarmenLog(shared_data / "logs" / "intel-corrected.log.gz")


@pytest.mark.parametrize("offset", OFFSETS)
def test_recovers_a_large_offset_on_an_intel_scan_pair(intel, offset):
    # Scan 156 against scan 155 placed by GMapping's corrected poses (0.51 m, -0.9° apart). On this
    # pair GMapping and point-to-line registration agree to 8 mm / 0.03°, so the truth is good to
    # well under a cell. Tolerance: 1.5 cells per axis (½ cell from the lattice, ½ from rounding each
    # point to its cell, ½ for the truth) and 1.5 angular steps (½ step from the lattice, one step
    # over which rounding leaves the score nearly flat).
    config = CorrelativeConfig()
    reference, scan = intel[155], intel[156]
    truth = reference.pose.between(scan.pose)
    grid = CorrelativeGrid(reference.scan.points(), config)
    result = match(grid, scan.scan.points(), off(truth, *offset), config)
    assert result is not None and result.score >= config.min_score
    assert abs(result.pose.x() - truth.x()) <= 1.5 * config.resolution
    assert abs(result.pose.y() - truth.y()) <= 1.5 * config.resolution
    assert abs(result.pose.theta() - truth.theta()) <= 1.5 * result.angular_step
    assert result.angular_step == angular_step(np.hypot(*scan.scan.points().T).max(), config.resolution)


@pytest.mark.parametrize("offset", OFFSETS)
def test_recovers_a_large_offset_exactly_in_a_noiseless_l_shaped_room(offset):
    # The guess is off by whole cells and whole angular steps, so the truth is on the search lattice;
    # the optimum is within one cell and one step of it.
    config = CorrelativeConfig()
    first, truth = gtsam.Pose2(2.0, 2.0, 0.3), gtsam.Pose2(2.6, 2.5, 0.6)
    grid = CorrelativeGrid(cast(first, L_ROOM).points(), config)
    points = cast(truth, L_ROOM).points()
    relative = first.between(truth)
    step = angular_step(np.hypot(*points.T).max(), config.resolution)
    cells = np.round(np.array(offset[:2]) / config.resolution)
    guess = gtsam.Pose2(relative.x() + cells[0] * config.resolution, relative.y() + cells[1] * config.resolution,
                        relative.theta() + round(math.radians(offset[2]) / step) * step)
    result = match(grid, points, guess, config)
    assert result is not None and result.angular_step == step
    assert abs(result.pose.x() - relative.x()) <= config.resolution + 1e-9
    assert abs(result.pose.y() - relative.y()) <= config.resolution + 1e-9
    assert abs(result.pose.theta() - relative.theta()) <= step + 1e-9
    assert result.score >= score(grid, points, relative, config)          # the truth is a candidate


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_branch_and_bound_equals_the_exhaustive_search(seed):
    # Random segments as reference, a noisy transformed subset as scan; 3 levels so the top blocks
    # (4 cells) do not tile the 21-cell window and nodes are clipped at its edge.
    rng = np.random.default_rng(seed)
    config = CorrelativeConfig(levels=3, window_xy=0.5, window_deg=10.0, min_score=0.0)
    ends = rng.uniform(-4, 4, (12, 2, 2))
    t = rng.uniform(0, 1, (12, 40, 1))
    reference = (ends[:, :1] + t * (ends[:, 1:] - ends[:, :1])).reshape(-1, 2)
    truth = gtsam.Pose2(0.2, -0.1, 0.1)
    points = transform(truth.inverse(), reference[rng.choice(len(reference), 150, replace=False)])
    points += rng.normal(0, 0.02, points.shape)
    grid = CorrelativeGrid(reference, config)
    guess = gtsam.Pose2(0.4, 0.15, 0.05)
    fast = match(grid, points, guess, config)
    slow = match_exhaustive(grid, points, guess, config)
    assert fast.pose.equals(slow.pose, 1e-12)
    assert abs(fast.score - slow.score) < 1e-9
    assert fast.nodes < slow.nodes


def test_rejects_an_unrelated_reference(intel):
    config = CorrelativeConfig()
    scan = intel[156].scan.points()
    # a featureless circular room, 4 m radius, around the scan's guess
    angles = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    circle = CorrelativeGrid(4.0 * np.column_stack([np.cos(angles), np.sin(angles)]), config)
    assert match(circle, scan, gtsam.Pose2(), config) is None
    # scan 600, 17 m away in another part of the building
    assert math.hypot(*(intel[600].pose.translation() - intel[156].pose.translation())) > 10
    elsewhere = CorrelativeGrid(intel[600].scan.points(), config)
    assert match(elsewhere, scan, gtsam.Pose2(), config) is None
    best = match(elsewhere, scan, gtsam.Pose2(), config.model_copy(update={"min_score": 0.0}))
    assert best.score < config.min_score


def test_a_window_too_small_does_not_return_the_truth(intel):
    config = CorrelativeConfig(min_score=0.0)
    reference, scan = intel[155], intel[156]
    truth = reference.pose.between(scan.pose)
    grid = CorrelativeGrid(reference.scan.points(), config)
    guess = off(truth, *OFFSETS[0])
    right = match(grid, scan.scan.points(), guess, config)
    small = match(grid, scan.scan.points(), guess, config.model_copy(update={"window_xy": 0.5}))
    # the small window holds only poses within 0.5 m of the guess, at least 1 m from the truth
    assert small.pose.x() - truth.x() >= 1.0 - 1e-9
    assert small.score < right.score
    assert match(grid, scan.scan.points(), guess, config.model_copy(update={"window_xy": 0.5, "min_score": 0.5})) \
        is None


@pytest.mark.parametrize("levels", [1, 3, 5])
def test_precomputation_level_is_the_maximum_over_each_block(levels):
    rng = np.random.default_rng(levels)
    fine = rng.uniform(0, 1, (23, 37)).astype(np.float32)
    grids = precompute(fine, levels)
    pad = (1 << (levels - 1)) - 1
    assert grids.shape == (levels, 23 + pad, 37 + pad)
    for level in range(levels):
        width = 1 << level
        padded = np.zeros((23 + pad + width - 1, 37 + pad + width - 1), np.float32)
        padded[pad:pad + 23, pad:pad + 37] = fine
        block_max = sliding_window_view(padded, (width, width)).max(axis=(2, 3))
        assert np.array_equal(grids[level], block_max)            # ≥ the block maximum, and no looser
        if level:
            assert np.all(grids[level] >= grids[level - 1])       # a parent bounds its children


def test_likelihood_grid_and_angular_step():
    config = CorrelativeConfig()
    grid = CorrelativeGrid(np.array([[1.0, 2.0], [3.0, 2.0]]), config)
    cells = np.rint((np.array([[1.0, 2.0], [3.0, 2.0]]) - grid.origin) / config.resolution).astype(int)
    assert np.all(grid.likelihood[cells[:, 1], cells[:, 0]] == 1.0)
    one_cell = grid.likelihood[cells[0, 1] + 1, cells[0, 0]]      # a cell away from the first point
    assert one_cell == np.float32(math.exp(-0.5 * (config.resolution / config.likelihood_sigma) ** 2))
    step = angular_step(10.0, config.resolution)
    assert 2 * 10.0 * math.sin(step / 2) == pytest.approx(config.resolution, rel=1e-9)   # chord = one cell


def test_covariance_is_long_along_a_corridor():
    # Walls y = 0 and y = 2 densely sampled along the grid's x axis, seen from a robot heading 0.6 rad:
    # shifting the scan by whole cells along x leaves every point on its wall, so the score surface is
    # flat along x (unobservable) and its exp-weights uniform over the ±n cells: variance
    # (Σ a² / (2n + 1)) r² plus the quantisation r² / 12. Across the walls one cell costs every point
    # 1 - exp(-r²/2σ²) = 0.2, a weight of e^(-0.2 m) ≈ 0 for the m points, so the variance is the
    # quantisation alone. In the body frame the long axis is the grid's x axis turned by -heading.
    config = CorrelativeConfig()
    xs = np.arange(-20.0, 20.0, 0.01)
    walls = np.concatenate([np.column_stack([xs, np.zeros_like(xs)]), np.column_stack([xs, np.full_like(xs, 2.0)])])
    grid = CorrelativeGrid(walls, config)
    truth = gtsam.Pose2(0.5, 1.0, 0.6)
    result = match(grid, cast(truth, CORRIDOR).points(), off(truth, 1.5, 0.0, 20.0), config)
    n, r = config.covariance_cells, config.resolution
    offsets = np.arange(-n, n + 1)
    world = np.diag([np.mean(offsets**2) * r**2 + r**2 / 12, r**2 / 12])
    c, s = math.cos(result.pose.theta()), math.sin(result.pose.theta())
    turn = np.array([[c, s], [-s, c]])
    np.testing.assert_allclose(result.covariance[:2, :2], turn @ world @ turn.T, rtol=0, atol=1e-9)
    assert result.covariance[2, 2] >= result.angular_step**2 / 12


def test_thin_keeps_at_most_max_points_in_input_order():
    points = np.random.default_rng(0).uniform(-5, 5, (2000, 2))
    kept = thin(points, 400, 0.05)
    assert 300 < len(kept) <= 400
    index = [int(np.flatnonzero((points == p).all(axis=1))[0]) for p in kept]
    assert index == sorted(index)
    assert np.array_equal(thin(points, 400, 0.05), kept)
    few = points[:100]
    assert thin(few, 400, 0.05) is few                                  # nothing to thin


def test_config_mismatch_is_named():
    grid = CorrelativeGrid(np.zeros((1, 2)), CorrelativeConfig())
    with pytest.raises(ValueError, match="resolution = 0.1 but the grid was built with resolution = 0.05"):
        match(grid, np.ones((30, 2)), gtsam.Pose2(), CorrelativeConfig(resolution=0.1))
    assert match(grid, np.ones((5, 2)), gtsam.Pose2()) is None        # fewer than min_points


def test_scans_that_hold_no_point_make_no_grid():
    """Keyframes that saw nothing (a room wider than the laser's range) give no grid to search,
    for the front end and for loop closing alike, rather than an error."""
    assert CorrelativeGrid.from_scans([gtsam.Pose2(), gtsam.Pose2(1.0, 0.0, 0.0)],
                                      [np.zeros((0, 2)), np.zeros((0, 2))]) is None
    grid = CorrelativeGrid.from_scans([gtsam.Pose2(1.0, 0.0, 0.0)], [np.array([[1.0, 0.5]])])
    assert grid is not None and grid.likelihood.max() == 1.0
