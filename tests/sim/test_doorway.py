"""Robot-sized passability: a 0.25 m robot explores two rooms joined by a door in a one-pixel
(5 cm) wall: 0.8 m, the narrowest door the issue asks to be passed, and 0.6 m, lab_e's."""

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


def rooms_with_a_door_and_a_nook(door: float) -> World:
    """``rooms_with_a_door`` with the second room 2 m longer (to x = 10.25 m) and a one-pixel
    wall across it at x = 6.5 m, from the floor to y = 2.5 m: the nook behind it is seen only
    from inside the second room, past the door."""
    grid = np.zeros((84, 205), dtype=bool)
    grid[:2], grid[-2:], grid[:, :2], grid[:, -2:] = True, True, True, True
    grid[:, 82] = True
    half = round(door / RES / 2)
    grid[42 - half:42 + half, 82] = False
    grid[:50, 130] = True
    return World(grid, (RES, RES), name="door_and_nook")


@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("method", ["gp", "grid"])
def test_a_door_of_0_6_m_is_passed_with_slam_and_the_nook_behind_it_explored(method, seed):
    """0.6 m leaves 5 cm a side to the robot. With Pose SLAM the map's jambs stand centimetres
    inside the door: the planner must still pass it (the costmap's squeeze), and the robot must
    thread it from its live scan (the carrot it can drive straight to; the robot's own disc no
    way past a jamb), or the nook is missed. Before those, the grid baseline gave up at the
    door and stopped at 65 % (seed 1)."""
    world = rooms_with_a_door_and_a_nook(0.6)
    config = EpisodeConfig().overridden(method=method, poses="slam", max_steps=3000)
    m = run_episode(world, gtsam.Pose2(1.5, 1.0, 0.0), config, seed=seed).metrics
    assert m["collisions"] == 0 and m["goals_abandoned"] == 0
    assert m["coverage"] >= 0.99, m
    assert m["termination_reason"] == "frontiers_exhausted"
