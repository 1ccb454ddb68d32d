"""Poses as numbers: the one conversion from ``gtsam.Pose2`` sequences to arrays."""

from __future__ import annotations

from collections.abc import Iterable

import gtsam
import numpy as np


def pose_array(poses: Iterable[gtsam.Pose2]) -> np.ndarray:
    """(n, 3) x (m), y (m), θ (rad) of each pose."""
    return np.array([[p.x(), p.y(), p.theta()] for p in poses], dtype=float).reshape(-1, 3)


def positions(poses: Iterable[gtsam.Pose2]) -> np.ndarray:
    """(n, 2) x, y (m) of each pose."""
    return pose_array(poses)[:, :2]
