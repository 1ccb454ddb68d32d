"""The log-odds grid baseline and the hold-out protocols."""

import gtsam
import numpy as np
import pytest

from mapping.config import TrainingConfig
from mapping.holdout import split
from mapping.grid import cell_key, key_cells
from mapping.logodds import _AROUND, TILE, LogOddsConfig, LogOddsGrid
from mapping.training import beam_samples
from slam.scan import LaserScan

from simworlds import corridor_pass, room_tour, scans_at


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


def test_a_trace_marks_the_cells_of_its_half_cell_samples_and_a_hit_cell_only_as_hit():
    """Rays from a point in a negative cell: each frees the cells holding its samples every
    half cell or less (i / n of it, n = ceil(length / 0.05)), not its hit cell, which another
    ray crosses; the tiles are those of both, the bounds their box."""
    grid = LogOddsGrid(LogOddsConfig(resolution=0.1))
    origin = np.array([-0.37, 0.21])
    ends = origin + np.array([[1.23, 0.0], [0.4, 0.3], [-2.1, -1.7], [0.61, 0.0], [0.0, 0.0]])
    is_hit = np.array([True, True, False, True, True])
    traced, free, hit = grid._trace(origin, ends, is_hit, None)
    samples = []
    for end in ends:
        n = max(int(np.ceil(np.linalg.norm(end - origin) / 0.05)), 1)
        samples += [origin + i / n * (end - origin) for i in range(n)]
    hit_cells = {tuple(c) for c in np.floor(ends[is_hit] / 0.1).astype(int)}
    sampled = {tuple(c) for c in np.floor(np.array(samples) / 0.1).astype(int)}
    assert (2, 2) in sampled & hit_cells                     # the 0.61 m ray's end, crossed by the first
    assert {tuple(c) for c in key_cells(hit)} == hit_cells
    assert {tuple(c) for c in key_cells(free)} == sampled - hit_cells
    assert np.all(np.diff(free) > 0) and np.all(np.diff(hit) > 0)
    every = np.array(sorted(sampled | hit_cells))
    assert {tuple(c) for c in key_cells(traced.tiles)} == {tuple(c) for c in every // TILE}
    assert np.all(np.diff(traced.tiles) > 0)
    assert np.array_equal(traced.bounds[0], every.min(axis=0)) and np.array_equal(traced.bounds[1], every.max(axis=0))


def test_grid_hits_are_every_update_s_hit_one_per_half_cell_in_views_that_never_change():
    """Each update marks its hits one per half cell (0.05 m voxel): 360 beams ending 5.2 cm
    apart on a circle of radius 3 m (18.8 m long; a voxel spans at most 7.1 cm of it) give
    between 266 and 360. ``hits`` hands out read-only
    views of a buffer: an earlier view keeps its points through later updates (past the
    buffer's growth) and a reset, and the latest holds every update's in order."""
    grid = LogOddsGrid(LogOddsConfig())
    angles = np.deg2rad(np.arange(360.0))
    scan = LaserScan(np.full(360, 3.0), angles, 8.0)
    views, poses = [], [gtsam.Pose2(0.4 * k, 0.0, 0.0) for k in range(5)]
    for pose in poses:
        grid.update(pose, scan)
        views.append(grid.hits())
    first = views[0].copy()
    sizes = np.array([0] + [len(v) for v in views])
    assert np.all(np.diff(sizes) >= 266) and np.all(np.diff(sizes) <= 360) and sizes[-1] > 1024
    for k, pose in enumerate(poses):
        ring = views[-1][sizes[k]:sizes[k + 1]] - [pose.x(), pose.y()]
        assert np.allclose(np.hypot(ring[:, 0], ring[:, 1]), 3.0, atol=1e-9)
    assert all(not v.flags.writeable for v in views)
    with pytest.raises(ValueError):
        views[-1][0] = 0.0
    grid.reset()
    grid.update(gtsam.Pose2(9.0, 9.0, 0.0), scan)
    assert np.array_equal(views[0], first) and np.array_equal(views[-1][:len(first)], first)
    ring = grid.hits() - [9.0, 9.0]
    assert 266 <= len(ring) <= 360 and np.allclose(np.hypot(ring[:, 0], ring[:, 1]), 3.0, atol=1e-9)


def _traced_rays(grid):
    """A list that gathers how many rays each trace of ``grid`` casts from now on."""
    rays, trace = [], grid._trace
    grid._trace = lambda origin, ends, *rest: rays.append(len(ends)) or trace(origin, ends, *rest)
    return rays


def _assert_same_grid(grid, fresh):
    assert (grid.frame.ix0, grid.frame.iy0, grid.frame.shape) == (
        fresh.frame.ix0, fresh.frame.iy0, fresh.frame.shape)
    np.testing.assert_array_equal(grid.logodds, fresh.logodds)
    np.testing.assert_array_equal(grid.hits(), fresh.hits())


def test_grid_regeneration_retraces_what_moved_and_gives_the_grid_rebuilt_from_scratch(room):
    poses = room_tour()
    scans = scans_at(room, poses, seed=4)
    error = gtsam.Pose2(0.35, -0.25, 0.06)
    wrong = poses[:5] + [error.compose(p) for p in poses[5:9]] + poses[9:]
    fresh = LogOddsGrid()
    for p, s in zip(poses, scans):
        fresh.update(p, s)
    grid = LogOddsGrid()
    for p, s in zip(wrong[:-3], scans[:-3]):          # keyframes 5-8 off, the last 3 not traced
        grid.update(p, s)
    grid.regenerate(zip(poses, scans))
    _assert_same_grid(grid, fresh)
    rays = _traced_rays(grid)
    grid.regenerate(zip(poses, scans))                # nothing moved: nothing retraced
    assert rays == []
    _assert_same_grid(grid, fresh)


def test_grid_regeneration_leaves_the_tiles_only_unmoved_keyframes_reach(corridor):
    poses, wrong = corridor_pass()
    scans = scans_at(corridor, poses, seed=5)
    fresh = LogOddsGrid()
    for p, s in zip(poses, scans):
        fresh.update(p, s)
    grid = LogOddsGrid()
    for p, s in zip(wrong, scans):
        grid.update(p, s)
    rays = _traced_rays(grid)
    grid.regenerate(zip(poses, scans))
    _assert_same_grid(grid, fresh)
    # the last keyframes (x >= 11.5 m) reach back 10 m: the first ones' tiles at x < 1.5 m stand
    assert 3 * len(scans[0]) <= sum(rays) < len(poses) * len(scans[0])


def test_grid_regeneration_keeps_keyframes_whose_rays_moved_less_than_the_tolerance(room):
    poses = room_tour()[:8]
    scans = scans_at(room, poses, seed=6)
    grid = LogOddsGrid(LogOddsConfig(unmoved=0.01))
    for p, s in zip(poses, scans):
        grid.update(p, s)
    before = grid.logodds.copy()
    rays = _traced_rays(grid)
    grid.regenerate((gtsam.Pose2(0.004, 0.0, 0.0).compose(p), s) for p, s in zip(poses, scans))
    assert rays == [] and np.array_equal(grid.logodds, before)
    grid.regenerate((gtsam.Pose2(0.012, 0.0, 0.0).compose(p), s) for p, s in zip(poses, scans))
    assert len(rays) >= len(poses) and not np.array_equal(grid.logodds, before)


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


def test_grid_regeneration_retraces_every_ray_that_crosses_a_cleared_tile():
    """``_crossing`` keeps every ray one of whose points (sampled every millimetre) lies in a
    cleared tile, from its samples a tile's side apart and the tiles beside the cleared ones."""
    rng = np.random.default_rng(10)
    grid = LogOddsGrid()
    side = TILE * grid.config.resolution
    cleared = np.unique(cell_key(rng.integers(-10, 10, size=(6, 2))))
    beside = np.unique(cell_key((key_cells(cleared)[:, None, :] + _AROUND).reshape(-1, 2)))
    origin = rng.uniform(-3 * side, 3 * side, 2)
    ends = origin + rng.uniform(-10.0, 10.0, size=(2000, 2))
    kept = grid._crossing(origin, ends, beside)
    for end, keep in zip(ends, kept):
        t = np.linspace(0.0, 1.0, int(np.hypot(*(end - origin)) / 0.001) + 2)
        cells = np.floor((origin + t[:, None] * (end - origin)) / grid.config.resolution).astype(np.int64)
        assert keep or not np.isin(cell_key(np.floor_divide(cells, TILE)), cleared).any()
    assert 0 < kept.sum() < len(ends)
