"""Scan registration: known transforms recovered, corridors detected as degenerate."""

import math

import gtsam
import numpy as np
import pytest

from slam.config import RegistrationConfig
from slam.registration import Registration, Submap, scan_normals
from slam.scan import LaserScan, fov_angles


def room_scan(pose: gtsam.Pose2, walls, n=361, max_range=8.0) -> LaserScan:
    """Exact ranges from ``pose`` to axis-aligned walls [(axis, value, lo, hi)], vectorised."""
    angles = fov_angles(n, math.pi, include_end=True)
    world = angles + pose.theta()
    d = np.column_stack([np.cos(world), np.sin(world)])
    origin = np.array([pose.x(), pose.y()])
    best = np.full(n, np.inf)
    for axis, value, lo, hi in walls:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (value - origin[axis]) / d[:, axis]
        other = origin[1 - axis] + t * d[:, 1 - axis]
        ok = (t > 0) & (other >= lo) & (other <= hi)
        best = np.where(ok & (t < best), t, best)
    return LaserScan(np.where(best < max_range, best, np.inf), angles, max_range)


ROOM = [(0, 0.0, 0, 6), (0, 7.0, 0, 6), (1, 0.0, 0, 7), (1, 6.0, 0, 7), (0, 3.0, 2, 4), (1, 2.0, 3, 5)]
CORRIDOR = [(1, 0.0, -50, 50), (1, 2.0, -50, 50)]


def submap_from(scan: LaserScan, pose: gtsam.Pose2, config):
    pts = scan.points()
    return Submap.from_scans([pose], [pts], [scan_normals(pts, config.normal_max_gap)], config)


@pytest.mark.parametrize("offset", [(0.05, -0.03, 2.0), (0.4, 0.3, 8.0), (-0.8, 0.5, -12.0)])
def test_coarse_to_fine_recovers_a_known_offset(offset):
    config = RegistrationConfig()
    reference = gtsam.Pose2(1.5, 1.0, 0.6)
    truth = reference.compose(gtsam.Pose2(0.5, 0.2, 0.1))
    submap = submap_from(room_scan(reference, ROOM), reference, config)
    points = room_scan(truth, ROOM).points()
    guess = truth.compose(gtsam.Pose2(offset[0], offset[1], math.radians(offset[2])))
    match = Registration(config).register(points, submap, guess)
    error = truth.between(match.pose)
    assert math.hypot(error.x(), error.y()) < 0.01 and abs(error.theta()) < math.radians(0.2)
    assert match.inlier_fraction > 0.9 and len(match.degenerate) == 0
    assert np.all(np.sqrt(np.diag(match.covariance)) < 0.01)


def test_corridor_is_degenerate_and_follows_the_odometry_prior():
    config = RegistrationConfig()
    reference = gtsam.Pose2(0.0, 1.0, 0.0)
    truth = gtsam.Pose2(0.7, 1.05, 0.02)
    submap = submap_from(room_scan(reference, CORRIDOR), reference, config)
    points = room_scan(truth, CORRIDOR).points()
    odometry = gtsam.Pose2(0.68, 1.0, 0.0)          # wheel odometry: 2 cm short, 5 cm to the side
    prior_info = np.diag([1 / 0.02**2, 1 / 0.02**2, 1 / 0.02**2])
    match = Registration(config).register(points, submap, odometry, prior=(odometry, prior_info))
    assert len(match.degenerate) == 1
    assert abs(match.degenerate[0][0]) > 0.99                  # the unobservable direction is along x
    assert match.pose.x() == pytest.approx(0.68, abs=0.01)     # x comes from odometry...
    assert match.pose.y() == pytest.approx(1.05, abs=0.005)    # ...y and θ from the walls
    assert match.pose.theta() == pytest.approx(0.02, abs=0.003)
    assert math.sqrt(match.covariance[0, 0]) > 5 * math.sqrt(match.covariance[1, 1])
