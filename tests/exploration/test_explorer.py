"""The explorer's goal choice on synthetic maps (both methods)."""

import gtsam
import numpy as np

from exploration.explorer import Explorer, ExplorerConfig
from mapping.occupancy import MapSnapshot


def free_strip_beside_unknown(res=0.1):
    """A 10 m x 1.5 m free strip (y < 1.5 m) under unknown space: its top edge is one long
    frontier region, 0.25 m from a robot standing at (1, 1.25)."""
    prob = np.full((40, 100), 0.5)
    prob[:15, :] = 0.1
    prob[0, :] = 0.95                      # a wall along the bottom
    return prob, res


def test_grid_explorer_leaves_a_frontier_too_close_to_observe_for_the_rest_of_it():
    """The nearest cell of a long frontier is closer than ``min_goal_distance``: it is
    blacklisted and the next goal lies farther along the same frontier (the region is not
    discarded whole, and the choice does not spin on the same cell)."""
    prob, res = free_strip_beside_unknown()
    explorer = Explorer(ExplorerConfig(method="grid", robot_radius=0.2, min_goal_distance=0.3))
    here = np.array([1.0, 1.25])
    plan = explorer.plan(MapSnapshot(prob, None, np.zeros(2), res), gtsam.Pose2(*here, 0.0))
    assert plan.goal is not None
    assert np.linalg.norm(plan.goal - here) > 0.3
    assert explorer.blacklist.centres                   # the too-close goal was given up
    assert not explorer.blacklist.covers(explorer.target).any()   # it serves the rest
    assert plan.goal[1] < 1.5                            # on the free strip, by the frontier
