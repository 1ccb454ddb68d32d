"""The laser mount offset: scans taken by a laser mounted off the robot's base, read from the
configuration, CARMEN logs and bags, give the base's trajectory and the same map."""

import math

import gtsam
import numpy as np
import pytest

from slam.config import SlamConfig
from slam.pose_slam import PoseSlam
from slam.poses import pose_array

MOUNT = gtsam.Pose2(0.3, 0.1, 0.2)      # the laser on the base: 0.3 m ahead, 0.1 m left, 0.2 rad


@pytest.fixture(scope="module")
def tour():
    """The first legs of the cave tour with 5 % odometry noise, and the same drive's scans taken
    twice: by a laser at the base, and by one mounted at ``MOUNT``."""
    from sim.lidar import Lidar
    from sim.odometry import Odometry, OdometryNoise
    from sim.robot import Robot
    from sim.tour import drive_tour
    from sim.worlds import cave

    builtin = cave()
    noise = OdometryNoise(alpha1=0.05**2, alpha2=0.05**2, alpha3=0.05**2)
    drive = drive_tour(Robot(builtin.world, builtin.start), Lidar(seed=0), Odometry(noise, seed=0),
                       builtin.tour[:3])
    lidar = Lidar(seed=1)
    drive.mounted = [lidar.scan(builtin.world, p.compose(MOUNT), t) for p, t in zip(drive.truth, drive.stamps)]
    return drive


def replay(odometry, scans, offset=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(n, 3) Pose SLAM's trajectory of the scans with the laser at ``offset`` on the base."""
    slam = PoseSlam(SlamConfig(laser_offset=list(offset)))
    for o, s in zip(odometry, scans):
        slam.step(o, s)
    return pose_array(slam.trajectory())


def error(estimate: np.ndarray, truth: np.ndarray) -> float:
    """Largest position error (m) of ``estimate`` against ``truth``, both from the first pose."""
    def relative(xyt):
        c, s = math.cos(xyt[0, 2]), math.sin(xyt[0, 2])
        d = xyt[:, :2] - xyt[0, :2]
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])
    return float(np.max(np.linalg.norm(relative(estimate) - relative(truth), axis=1)))


def test_a_mounted_laser_with_its_offset_configured_gives_the_base_trajectory(tour):
    truth = pose_array(tour.truth)
    at_base = replay(tour.odometry, tour.scans)
    mounted = replay(tour.odometry, tour.mounted, (MOUNT.x(), MOUNT.y(), MOUNT.theta()))
    ignored = replay(tour.odometry, tour.mounted)
    assert error(at_base, truth) < 0.05
    assert error(mounted, at_base) < 0.05           # within registration accuracy (0.012 m)
    assert error(mounted, truth) < 0.05
    assert error(ignored, truth) > 0.3              # without it the base is wrong (3.4 m)


def grid_map(truth, scans, offset=(0.0, 0.0, 0.0)):
    """The Stack's log-odds grid of ``scans`` taken at the base poses ``truth`` by a laser at
    ``offset`` on the base (log mapping at given poses)."""
    from exploration.explorer import ExplorerConfig
    from exploration.stack import Stack, StackConfig

    config = StackConfig(poses="truth", slam=SlamConfig(laser_offset=list(offset)),
                         explorer=ExplorerConfig(method="grid"))
    stack = Stack(config, mapping="final", planning=False)
    for pose, scan in zip(truth, scans):
        stack.step(None, scan, truth=pose)
    return stack.final_map()


def agreement(reference, other) -> float:
    """Share of ``reference``'s known cells (p < 0.3 free, p > 0.7 occupied) that ``other``
    classifies the same at their centres."""
    p = reference.prob()
    h, w = p.shape
    yy, xx = np.mgrid[0:h, 0:w]
    centres = reference.origin + reference.resolution * np.stack([xx, yy], axis=-1)
    known = (p < 0.3) | (p > 0.7)
    q = other.sample(other.prob(), centres[known])
    return float(np.mean((q > 0.7) == (p[known] > 0.7)) * np.mean((q < 0.3) | (q > 0.7)))


def test_a_mounted_laser_with_its_offset_configured_gives_the_same_map(tour):
    every = slice(None, None, 4)
    truth = tour.truth[every]
    at_base = grid_map(truth, tour.scans[every])
    mounted = grid_map(truth, tour.mounted[every], (MOUNT.x(), MOUNT.y(), MOUNT.theta()))
    ignored = grid_map(truth, tour.mounted[every])
    assert agreement(at_base, mounted) > 0.95
    assert agreement(at_base, ignored) < 0.9
