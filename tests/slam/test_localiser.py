"""The localisers' positions: every scan's position read as one array is where its pose, composed
by gtsam one scan at a time, puts it."""

import math

import gtsam
import numpy as np

from slam.localiser import GivenPoses
from slam.pose_slam import PoseSlam
from slam.poses import positions
from slam.scan import LaserScan


def test_pose_slam_positions_are_its_poses_after_a_loop_moved_the_keyframes():
    """The cave tour's first leg, then a loop that puts the last keyframe 0.3 m and 3° from
    where the graph has it: every keyframe moves, and ``positions`` places each scan where
    ``pose`` does. Bit for bit for the keyframes' own scans (the trail the explorer reads at
    every replan); within rounding for the scans between (rotated by the keyframe's angle rather
    than by the cosine and sine gtsam stores)."""
    from sim.lidar import Lidar
    from sim.odometry import Odometry
    from sim.robot import Robot
    from sim.tour import drive_tour
    from sim.worlds import cave

    builtin = cave()
    drive = drive_tour(Robot(builtin.world, builtin.start), Lidar(seed=1), Odometry(seed=2),
                       builtin.tour[:2])
    slam = PoseSlam()
    steps = [slam.step(odometry, scan) for odometry, scan in zip(drive.odometry, drive.scans)]
    scans = np.arange(len(steps))
    keyframe_scans = scans[[step.keyframe is not None for step in steps]]
    assert 10 < len(keyframe_scans) < len(scans) / 2
    last = len(slam.graph) - 1
    pulled = slam.graph.pose(0).between(slam.graph.pose(last)).compose(
        gtsam.Pose2(-0.3, 0.0, math.radians(3)))
    assert slam.graph.add_loop(0, last, pulled, np.diag([0.01, 0.01, 0.001]) ** 2, 100.0, 4) > 0.1

    one_by_one = positions([slam.pose(i) for i in scans])
    np.testing.assert_array_equal(slam.positions(keyframe_scans), one_by_one[keyframe_scans])
    np.testing.assert_allclose(slam.positions(scans[::-1]), one_by_one[::-1], rtol=0, atol=1e-12)
    assert slam.positions(np.array([], int)).shape == (0, 2)


def test_given_positions_are_the_given_poses_and_reading_them_leaves_it_stepping():
    """Keyframes or not, ``GivenPoses`` reads back each scan's given position, in the order
    asked; reading them does not stop it taking more poses."""
    localiser = GivenPoses()
    scan = LaserScan(np.full(3, 2.0), np.array([-0.5, 0.0, 0.5]), 8.0)
    poses = [gtsam.Pose2(0.05 * i, 0.01 * i * i, 0.1 * i) for i in range(20)]
    keyframes = [localiser.step(None, scan, pose).keyframe for pose in poses[:10]]
    asked = np.array([9, 0, 3, 3, 7])
    np.testing.assert_array_equal(localiser.positions(asked), positions([poses[i] for i in asked]))
    keyframes += [localiser.step(None, scan, pose).keyframe for pose in poses[10:]]
    assert None in keyframes and len(localiser.keyframe_poses()) > 1
    np.testing.assert_array_equal(localiser.positions(np.arange(20)), positions(poses))
