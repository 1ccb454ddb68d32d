import math

import gtsam
import numpy as np
import pytest

from exploration.follower import PathFollower
from sim.robot import Robot, RobotConfig
from sim.world import World


@pytest.mark.parametrize("goal", [(8.0, 2.0), (2.0, 8.0), (8.0, 8.0), (1.5, 1.2)])
def test_reaches_goals_within_limits(goal):
    world = World(np.zeros((200, 200), dtype=bool), (0.05, 0.05))
    config = RobotConfig(max_speed=0.5, max_turn_rate=math.pi / 2)
    robot = Robot(world, gtsam.Pose2(2.0, 2.0, math.pi), config)
    follower = PathFollower(config.max_speed, config.max_turn_rate)
    path = np.array([[2.0, 2.0], goal])
    for _ in range(600):
        v, w, reached = follower.command(robot.pose, path)
        assert abs(v) <= config.max_speed + 1e-12 and abs(w) <= config.max_turn_rate + 1e-12
        if reached:
            break
        robot.move(v, w, 0.1)
    assert reached
    assert np.hypot(robot.pose.x() - goal[0], robot.pose.y() - goal[1]) < follower.config.tolerance
    assert robot.collisions == 0


def test_stays_close_to_a_polyline():
    world = World(np.zeros((200, 200), dtype=bool), (0.05, 0.05))
    robot = Robot(world, gtsam.Pose2(1.0, 1.0, 0.0))
    follower = PathFollower(0.5, math.pi / 2)
    path = np.array([[1.0, 1.0], [8.0, 1.0], [8.0, 8.0]])
    worst = 0.0
    for _ in range(1000):
        v, w, reached = follower.command(robot.pose, path)
        if reached:
            break
        robot.move(v, w, 0.1)
        x, y = robot.pose.x(), robot.pose.y()
        worst = max(worst, min(abs(y - 1.0) if x <= 8.0 else np.inf, abs(x - 8.0) if y >= 1.0 else np.inf))
    assert reached and worst < 0.3


def test_remaining_is_the_length_left_along_a_detour():
    """A U-shaped path: the goal is 1 m away in a straight line but 5 m along the path; walking
    the first leg brings the remaining length down while the straight-line distance grows."""
    path = np.array([[0.0, 0.0], [0.0, 2.0], [1.0, 2.0], [1.0, 0.0]])
    assert PathFollower.remaining(gtsam.Pose2(0.0, 0.0, 0.0), path) == pytest.approx(5.0)
    assert PathFollower.remaining(gtsam.Pose2(0.0, 1.5, 0.0), path) == pytest.approx(3.5)
    # off the path: the way back to it counts too
    assert PathFollower.remaining(gtsam.Pose2(-0.3, 1.0, 0.0), path) == pytest.approx(4.3)
    assert PathFollower.remaining(gtsam.Pose2(1.0, 0.0, 0.0), path) == pytest.approx(0.0)
