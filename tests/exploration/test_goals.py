import numpy as np
import pytest

from exploration.goals import Blacklist, GoalConfig, extract_goals, utility
from exploration.paths import distance_field


def test_utility_is_eq_11():
    assert utility(2.0, 30, 120, 16.0, alpha=10.0) == pytest.approx(10 * 2.0 * 0.25 - 4.0)


def two_frontiers(n=100, res=0.1):
    """Free space everywhere; a large, strong frontier far away and a weak small one near."""
    frontier = np.zeros((n, n))
    frontier[82:91, 50:59] = 3.0  # 81 points, y in [8.2, 9] m
    frontier[20:30, 25] = 1.0  # 10 points near the robot at (2, 2)
    passable = np.ones((n, n), dtype=bool)
    dist, _ = distance_field(passable, (20, 20), res)
    return frontier, dist


def test_information_outweighs_distance_with_a_large_alpha():
    frontier, dist = two_frontiers()
    config = GoalConfig(threshold=0.5, points_per_cluster=50, min_points=5, alpha=50.0)
    clusters = extract_goals(frontier, (0.0, 0.0), 0.1, dist, config)
    assert len(clusters) == 2
    assert clusters[0].points[:, 1].min() == pytest.approx(8.2)
    assert clusters[0].utility > clusters[1].utility
    # the goal lies within reach of the cluster and is reachable
    assert np.min(np.linalg.norm(clusters[0].points - clusters[0].goal, axis=1)) <= config.reach + 1e-9


def test_distance_wins_with_a_small_alpha():
    frontier, dist = two_frontiers()
    config = GoalConfig(threshold=0.5, points_per_cluster=50, min_points=5, alpha=1.0)
    clusters = extract_goals(frontier, (0.0, 0.0), 0.1, dist, config)
    assert clusters[0].centroid[0] == pytest.approx(2.5)


def test_threshold_and_min_points_stop_exploration():
    frontier, dist = two_frontiers()
    assert extract_goals(frontier, (0, 0), 0.1, dist, GoalConfig(threshold=5.0)) == []
    weak_only = GoalConfig(threshold=0.5, min_points=200)
    assert extract_goals(frontier, (0, 0), 0.1, dist, weak_only) == []


def test_unreachable_cluster_has_no_goal_and_comes_last():
    frontier, _ = two_frontiers()
    passable = np.ones((100, 100), dtype=bool)
    passable[60, :] = False  # the far frontier is cut off
    dist, _ = distance_field(passable, (20, 20), 0.1)
    config = GoalConfig(threshold=0.5, points_per_cluster=50, min_points=5, alpha=50.0)
    clusters = extract_goals(frontier, (0, 0), 0.1, dist, config)
    assert clusters[-1].goal is None and np.isinf(clusters[-1].distance)
    assert clusters[0].goal is not None


def test_blacklist_removes_retried_goals():
    frontier, dist = two_frontiers()
    config = GoalConfig(threshold=0.5, points_per_cluster=50, min_points=5, alpha=1.0)
    first = extract_goals(frontier, (0, 0), 0.1, dist, config)[0]
    blacklist = Blacklist(radius=1.0)
    blacklist.add(first.centroid)
    again = extract_goals(frontier, (0, 0), 0.1, dist, config, blacklist)
    remaining = np.vstack([c.points for c in again])
    assert len(remaining) == 81 and not blacklist.covers(remaining).any()
