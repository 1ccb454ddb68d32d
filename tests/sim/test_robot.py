import math

import gtsam
import numpy as np
import pytest

from sim.robot import Robot, RobotConfig, arc
from sim.world import World


@pytest.fixture
def room():
    """10 m x 10 m, with a one-cell (5 cm) wall at x in [6, 6.05)."""
    grid = np.zeros((200, 200), dtype=bool)
    grid[:, 120] = True
    return World(grid, (0.05, 0.05))


def test_arc_is_exact():
    p = arc(0.5, math.pi / 2, 1.0)  # a quarter of a circle of radius 1/pi
    r = 0.5 / (math.pi / 2)
    assert (p.x(), p.y(), p.theta()) == pytest.approx((r, r, math.pi / 2))
    s = arc(0.5, 0.0, 2.0)
    assert (s.x(), s.y(), s.theta()) == pytest.approx((1.0, 0.0, 0.0))


def test_limits_are_enforced(room):
    robot = Robot(room, gtsam.Pose2(2.0, 5.0, 0.0), RobotConfig(max_speed=0.5, max_turn_rate=1.0))
    motion = robot.move(3.0, 0.0, 1.0)
    assert motion.x() == pytest.approx(0.5)
    motion = robot.move(0.0, -5.0, 0.5)
    assert motion.theta() == pytest.approx(-0.5)
    assert robot.distance == pytest.approx(0.5)


def test_collision_is_refused_and_counted(room):
    robot = Robot(room, gtsam.Pose2(5.5, 5.0, 0.0))  # disc edge 0.25 m from the wall face
    motion = robot.move(0.5, 0.0, 1.0)  # would end 0.25 m past the face
    assert robot.collisions == 1
    assert motion.equals(gtsam.Pose2(), 1e-12)
    assert robot.pose.equals(gtsam.Pose2(5.5, 5.0, 0.0), 1e-12)
    robot.move(0.2, 0.0, 1.0)  # stops 0.05 m short: allowed
    assert robot.collisions == 1 and robot.pose.x() == pytest.approx(5.7)


def test_a_long_step_cannot_tunnel_through_a_thin_wall(room):
    robot = Robot(room, gtsam.Pose2(5.0, 5.0, 0.0), RobotConfig(max_speed=10.0))
    robot.move(10.0, 0.0, 0.2)  # 2 m in one step, across the 5 cm wall
    assert robot.collisions == 1 and robot.pose.x() == 5.0


def test_start_in_collision_is_rejected(room):
    with pytest.raises(ValueError, match="collides"):
        Robot(room, gtsam.Pose2(6.1, 5.0, 0.0))
    with pytest.raises(ValueError, match="collides"):
        Robot(room, gtsam.Pose2(0.1, 5.0, 0.0))  # overlaps the grid's edge
