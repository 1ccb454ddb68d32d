import numpy as np
import pytest
from pydantic import ValidationError

from exploration.costmap import CostmapConfig, classify, passable
from exploration.grid_frontier import grid_frontiers, nearest_frontier
from exploration.paths import distance_field, near_distance, path_to


def room(n=100):
    """0.1 m cells: known free square [2, 8] m x [2, 8] m, a wall at x = 5 with a door, unknown elsewhere."""
    prob = np.full((n, n), 0.5)
    prob[20:80, 20:80] = 0.1
    prob[20:80, 50] = 0.9
    prob[45:55, 50] = 0.1
    return prob


def test_planner_never_enters_occupied_or_unknown_space():
    prob = room()
    config = CostmapConfig()
    ok, _ = passable(prob, 0.1, 0.25, config)
    free, occupied = classify(prob, config)
    dist, parent = distance_field(ok, (30, 50), 0.1)
    path = path_to(parent, (70, 50))
    assert np.isfinite(dist[50, 70])
    # every cell within the robot's radius of the path is known free
    for ix, iy in path:
        window = free[iy - 3:iy + 4, ix - 3:ix + 4]
        assert window.all()
    assert not (ok & ~free).any()


def test_door_narrower_than_the_robot_blocks_the_path():
    prob = room()
    prob[45:55, 50] = 0.9
    prob[49:51, 50] = 0.1  # a 0.2 m door
    ok, _ = passable(prob, 0.1, 0.25, CostmapConfig())
    dist, _ = distance_field(ok, (30, 50), 0.1)
    assert np.isinf(dist[50, 70])


def test_obstacle_map_marks_weak_walls():
    prob = np.full((10, 10), 0.1)
    prob_occ = np.full((10, 10), 0.5)
    prob_occ[5, 5] = 0.8  # a wall the fused map missed
    _, occupied = classify(prob, CostmapConfig(), prob_occ)
    assert occupied[5, 5] and occupied.sum() == 1


def test_bad_thresholds_are_rejected():
    with pytest.raises(ValidationError, match="free_below"):
        CostmapConfig(free_below=0.7, occupied_above=0.6)


def test_grid_frontiers_and_nearest():
    prob = room()
    regions = grid_frontiers(prob, CostmapConfig(), min_size=10)
    cells = np.vstack(regions)
    # frontier cells are free and touch unknown space: the room's outline minus walls
    assert set(np.unique(cells[:, 0])) >= {20, 79}
    assert all(prob[iy, ix] < 0.35 for ix, iy in cells)
    ok, _ = passable(prob, 0.1, 0.25, CostmapConfig())
    dist, _ = distance_field(ok, (30, 50), 0.1)
    k, cell = nearest_frontier(regions, near_distance(dist, 6))
    assert cell[0] == 20  # the left edge is nearest to a robot at x = 3 m
    # tiny regions are dropped
    speck = np.full((30, 30), 0.1)
    speck[15, 15] = 0.5
    assert grid_frontiers(speck, CostmapConfig(), min_size=10) == []
