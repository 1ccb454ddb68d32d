"""Exact laser scans into axis-aligned walls, for registration and loop-closure tests."""

import math

import gtsam
import numpy as np

from slam.scan import LaserScan, fov_angles


def cast(pose: gtsam.Pose2, walls, n=361, max_range=8.0) -> LaserScan:
    """Exact 180° scan of ``n`` beams from ``pose`` into axis-aligned walls
    [(axis, value, lo, hi)]: the wall ``x = value`` (axis 0) or ``y = value`` (axis 1) spanning
    [lo, hi] along the other axis. Vectorised over beams."""
    angles = fov_angles(n, math.pi, include_end=True)
    world = angles + pose.theta()
    d = np.column_stack([np.cos(world), np.sin(world)])
    origin = np.array([pose.x(), pose.y()])
    best = np.full(n, np.inf)
    for axis, value, lo, hi in walls:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (value - origin[axis]) / d[:, axis]
        other = origin[1 - axis] + t * d[:, 1 - axis]
        best = np.where((t > 0) & (other >= lo) & (other <= hi) & (t < best), t, best)
    return LaserScan(np.where(best < max_range, best, np.inf), angles, max_range)
