"""Robot-sized passability: a 0.25 m robot explores two rooms joined by a 0.8 m door in a
one-pixel (5 cm) wall, the narrowest door the floor-plan suite's buildings have to be passed."""

import gtsam
import numpy as np
import pytest

from sim.episode import EpisodeConfig, run_episode
from sim.world import World

RES = 0.05


def rooms_with_a_door(door: float) -> World:
    """Two 4 m x 4 m rooms (x 0-4 m and 4.05-8.05 m, y 0-4 m) inside 0.1 m outer walls; the
    dividing wall is one 5 cm pixel, with a door ``door`` m wide centred at y = 2 m."""
    grid = np.zeros((84, 165), dtype=bool)
    grid[:2], grid[-2:], grid[:, :2], grid[:, -2:] = True, True, True, True
    grid[:, 82] = True
    half = round(door / RES / 2)
    grid[42 - half:42 + half, 82] = False
    return World(grid, (RES, RES), name="door")


@pytest.mark.parametrize("method", ["gp", "grid"])
def test_a_door_of_0_8_m_is_passed_and_both_rooms_are_explored(method):
    world = rooms_with_a_door(0.8)
    config = EpisodeConfig().overridden(method=method, poses="truth", max_steps=3000)
    m = run_episode(world, gtsam.Pose2(1.5, 1.0, 0.0), config, seed=1).metrics
    assert m["collisions"] == 0
    assert m["coverage"] >= 0.99, m
    assert m["termination_reason"] == "frontiers_exhausted"
