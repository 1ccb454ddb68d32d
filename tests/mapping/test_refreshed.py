"""Map products kept between reads: each read is the product computed over the whole map."""

import gtsam
import numpy as np

from mapping.com import ContinuousOccupancyMap
from mapping.logodds import LogOddsConfig, LogOddsGrid
from mapping.refreshed import Refreshed

from simworlds import room_tour, scans_at


def _com_products(com):
    """Λ and Λo from the BCM sums, over every cell (eqs. 8-9), as the map held them."""
    o, f = com._occ, com._free
    with np.errstate(invalid="ignore", divide="ignore"):
        prob = np.where(o.precision + f.precision > 0,
                        (o.weighted + f.weighted) / (o.precision + f.precision), 0.5)
        prob_occ = np.where(o.precision > 0, o.weighted / o.precision, 0.5)
    return prob, prob_occ


def test_the_com_read_between_updates_is_the_one_computed_over_the_whole_map(room):
    poses = room_tour()
    scans = scans_at(room, poses, seed=3)
    com = ContinuousOccupancyMap()
    read = []
    for k, (p, s) in enumerate(zip(poses, scans)):
        com.update(p, s)                             # the map grows as the robot goes round
        if k % 3 == 0:
            read.append((com.prob(), com.prob_occ(), _com_products(com)))
    moved = [gtsam.Pose2(0.05, 0.0, 0.0).compose(p) for p in poses]
    com.regenerate(zip(moved, scans))
    read.append((com.prob(), com.prob_occ(), _com_products(com)))
    assert len({r[0].shape for r in read}) > 1       # the grid grew between reads
    for prob, prob_occ, (want, want_occ) in read:
        np.testing.assert_array_equal(prob, want)
        np.testing.assert_array_equal(prob_occ, want_occ)
    first = read[0][0].copy()
    com.update(poses[0], scans[0])
    np.testing.assert_array_equal(read[0][0], first)  # a copy read earlier does not change


def test_the_grid_read_between_updates_is_the_one_computed_over_the_whole_grid(room):
    poses = room_tour()
    scans = scans_at(room, poses, seed=4)
    grid = LogOddsGrid(LogOddsConfig(resolution=0.1))
    for k, (p, s) in enumerate(zip(poses, scans)):
        grid.update(p, s)
        if k % 4 == 0:
            np.testing.assert_array_equal(grid.prob(), 1.0 / (1.0 + np.exp(-grid.logodds)))
    grid.regenerate(zip([gtsam.Pose2(0.0, 0.07, 0.01).compose(p) for p in poses], scans))
    np.testing.assert_array_equal(grid.prob(), 1.0 / (1.0 + np.exp(-grid.logodds)))


def test_a_read_computes_again_only_the_box_of_the_cells_touched():
    source = np.arange(48.0).reshape(6, 8)
    boxes = []
    product = Refreshed(lambda box: boxes.append(box) or 2 * source[box])
    np.testing.assert_array_equal(product.read(source.shape), 2 * source)
    source[1, 2] = source[4, 5] = -1.0
    product.touch_flat(np.array([1 * 8 + 2, 4 * 8 + 5]), 8)
    np.testing.assert_array_equal(product.read(source.shape), 2 * source)
    assert boxes[-1] == np.s_[1:5, 2:6]
    product.read(source.shape)                       # nothing touched: nothing computed
    assert len(boxes) == 2
