"""What every recorded laser log is to the rest of the stack: its records in time order."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import gtsam
import numpy as np

from slam.poses import pose_array

#: How far (m, rad) a log's poses must move away from its odometry, relative to the first
#: record, to be corrected poses: a raw log's poses are its odometry (or within one odometry
#: message of it); a corrected log's drift meters away (Intel 62 m, Belgioioso 7.8 m).
CORRECTED_POSE_TOLERANCE = (0.25, 0.1)


class LaserLog:
    """A sequence of records, each with ``.scan`` (a LaserScan) and ``.pose`` (the robot base's
    pose at it); subclasses read a file format and fill ``records``.

    Attributes:
        laser_offset: the laser's pose in the base frame as the log states it (a CARMEN log's
            laser and robot poses, a bag's /tf_static), or None when it states none.
        laser_offset_source: where ``laser_offset`` was read ("log", "/tf_static"), or None.
    """

    records: list
    laser_offset: gtsam.Pose2 | None = None
    laser_offset_source: str | None = None

    def __len__(self) -> int:
        return len(self.records)

    def __getitem__(self, i: int):
        return self.records[i]

    def __iter__(self):
        return iter(self.records)

    def has_corrected_poses(self) -> bool:
        """Whether the logged poses are corrected poses (a SLAM result, as GMapping's
        ``*-corrected.log``) rather than the wheel odometry: relative to the first record, they
        move farther than ``CORRECTED_POSE_TOLERANCE`` from where the odometry moves. A raw log
        (CSAIL's) and a bag (its poses are its odometry) have none."""
        pairs = [(r.pose, r.odometry) for r in self.records if r.odometry is not None]
        if len(pairs) < 2:
            return False
        pose, odometry = (pose_array(p) for p in zip(*pairs))
        a, b = _relative(pose[0], pose), _relative(odometry[0], odometry)
        c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
        dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
        distance = np.hypot(c * dx + s * dy, -s * dx + c * dy)
        angle = np.abs(np.angle(np.exp(1j * (b[:, 2] - a[:, 2]))))
        meters, radians = CORRECTED_POSE_TOLERANCE
        return bool(np.any(distance > meters) or np.any(angle > radians))

    @property
    def duration(self) -> float | None:
        """Seconds between the first and last scan; None when the stamps are broken (some logs'
        are all 0, all equal, or take a handful of values): fewer than 90 % of consecutive
        scans have increasing stamps."""
        stamps = np.array([r.scan.timestamp for r in self.records])
        if len(stamps) < 2 or np.mean(np.diff(stamps) > 0) < 0.9:
            return None
        return float(stamps[-1] - stamps[0])


@dataclass(frozen=True)
class LaserMount:
    """The laser's pose in the base frame that a replay of a log uses, and where it came from:
    the log's own statement ("log", "/tf_static") or the configuration ("configuration").
    ``warning`` says when the log and a non-zero configured offset disagree (the log wins);
    ``note``, why a bag states none (its ``laser_offset_note``)."""

    pose: gtsam.Pose2
    source: str
    warning: str | None = None
    note: str | None = None

    @property
    def offset(self) -> list[float]:
        """x (m), y (m), θ (rad): the value of ``SlamConfig.laser_offset``."""
        return [self.pose.x(), self.pose.y(), self.pose.theta()]

    def metrics(self) -> dict:
        """What a replay's metrics.json says of the mount."""
        return {"laser_offset": self.offset, "laser_offset_source": self.source,
                **({"laser_offset_note": self.note} if self.note else {})}


def laser_mount(log: LaserLog, configured: Sequence[float]) -> LaserMount:
    """The mount to replay ``log`` with: the log's ``laser_offset`` when it states one, else the
    ``configured`` offset (x m, y m, θ rad; ``SlamConfig.laser_offset``)."""
    config = gtsam.Pose2(*configured)
    if log.laser_offset is None:
        return LaserMount(config, "configuration", note=getattr(log, "laser_offset_note", None))
    warning = None
    stated = log.laser_offset
    if any(configured) and not config.equals(stated, 1e-3):
        warning = (f"{log.path}: the configured laser_offset ({_xyt(config)}) differs from the one "
                   f"the log states in {log.laser_offset_source} ({_xyt(stated)}); using the log's")
    return LaserMount(stated, log.laser_offset_source or "log", warning)


def _xyt(pose: gtsam.Pose2) -> str:
    return f"{pose.x():.3f} m, {pose.y():.3f} m, {pose.theta():.3f} rad"


def _relative(origin: np.ndarray, xyt: np.ndarray) -> np.ndarray:
    """(n, 3) poses ``xyt`` in the frame of the pose ``origin`` (3,)."""
    c, s = np.cos(origin[2]), np.sin(origin[2])
    dx, dy = xyt[:, 0] - origin[0], xyt[:, 1] - origin[1]
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, xyt[:, 2] - origin[2]])
