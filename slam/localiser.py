"""The localiser's interface, and the localiser that is told its poses.

A localiser turns (odometry, scan) into the scan's pose (the robot base's pose when the scan was
taken; the laser sits at ``laser_offset`` on the base, so the scan's own origin is
``pose ∘ laser_offset``), decides which scans are keyframes,
and may correct its keyframes later (loop closures). Two implement it: ``PoseSlam``
(``pose_slam.py``, the method's) and ``GivenPoses``, which takes each scan's pose from
outside: ground truth in simulation (perfect localisation, for ablations), or a corrected
log's poses when mapping it.
"""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field
from typing import Protocol

import gtsam
import numpy as np

from slam.config import KeyframeConfig
from slam.scan import LaserScan


@dataclass
class Localisation:
    """What one scan did to the localiser.

    Attributes:
        pose: the scan's current pose estimate (world frame).
        keyframe: the keyframe index if the scan became one, else None.
        loops: loop closures accepted at this scan.
        moved: largest keyframe displacement (m) caused by those loops.
        corrected: True when earlier keyframes moved more than the localiser's threshold: maps
            built from them may have drifted.
        withdrawn: loop closures accepted earlier and taken back out of the graph at this scan
            (a consistency check found them false): the corrections they made are undone, and
            a map relearnt under them is wrong wherever the robot is not.
    """

    pose: gtsam.Pose2
    keyframe: int | None = None
    loops: list = field(default_factory=list)
    moved: float = 0.0
    corrected: bool = False
    withdrawn: int = 0


class Localiser(Protocol):
    """Where each scan was taken, and which scans are keyframes."""

    keyframe_scans: list[LaserScan]
    #: the laser's pose in the base frame: scan i's points are in the frame ``pose(i) ∘ laser_offset``
    laser_offset: gtsam.Pose2

    def step(self, odometry: gtsam.Pose2 | None, scan: LaserScan,
             given: gtsam.Pose2 | None = None) -> Localisation:
        """Localise one scan; ``given`` is its known pose (read by ``GivenPoses`` only)."""

    def pose(self, i: int) -> gtsam.Pose2:
        """Scan ``i``'s current pose estimate (scans counted from 0 in ``step`` order)."""

    def positions(self, indices: np.ndarray) -> np.ndarray:
        """(k, 2) x, y (m) of the poses of scans ``indices`` (k,) int: ``pose(i)``'s position for
        each, at the cost of one array operation rather than one pose per scan."""

    def trajectory(self) -> list[gtsam.Pose2]:
        """Every scan's current pose estimate."""

    def keyframe_poses(self) -> list[gtsam.Pose2]:
        """Every keyframe's current pose estimate."""

    def loop_pairs(self) -> np.ndarray:
        """(m, 2) int: the keyframes each loop closure joins."""


class GivenPoses:
    """A localiser told every scan's pose: a scan is a keyframe when it moved enough since the
    last keyframe (``min_translation`` or ``min_rotation_deg`` of the keyframe settings). The
    given poses are the base's; the laser sits at ``laser_offset`` on it (identity by default)."""

    def __init__(self, config: KeyframeConfig | None = None, laser_offset: gtsam.Pose2 | None = None):
        self.config = config or KeyframeConfig()
        self.laser_offset = laser_offset or gtsam.Pose2()
        self.keyframe_scans: list[LaserScan] = []
        self._keyframes: list[int] = []
        self._poses: list[gtsam.Pose2] = []
        self._xy = array("d")          # x, y (m) of each pose in turn, for ``positions``

    def step(self, odometry: gtsam.Pose2 | None, scan: LaserScan,
             given: gtsam.Pose2 | None = None) -> Localisation:
        if given is None:
            raise ValueError("GivenPoses needs the scan's pose at every step (given=...)")
        self._poses.append(given)
        self._xy.extend((given.x(), given.y()))
        if self._keyframes:
            delta = self._poses[self._keyframes[-1]].between(given)
            if (np.hypot(delta.x(), delta.y()) < self.config.min_translation
                    and abs(delta.theta()) < np.radians(self.config.min_rotation_deg)):
                return Localisation(given)
        self._keyframes.append(len(self._poses) - 1)
        self.keyframe_scans.append(scan)
        return Localisation(given, len(self._keyframes) - 1)

    def pose(self, i: int) -> gtsam.Pose2:
        return self._poses[i]

    def positions(self, indices: np.ndarray) -> np.ndarray:
        # np.take copies: no view is left holding the buffer, which ``step`` keeps extending
        return np.take(np.frombuffer(self._xy).reshape(-1, 2), indices, axis=0)

    def trajectory(self) -> list[gtsam.Pose2]:
        return list(self._poses)

    def keyframe_poses(self) -> list[gtsam.Pose2]:
        return [self._poses[i] for i in self._keyframes]

    def loop_pairs(self) -> np.ndarray:
        return np.zeros((0, 2), int)
