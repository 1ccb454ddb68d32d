"""What every recorded laser log is to the rest of the stack: its records in time order."""

from __future__ import annotations

import numpy as np

from slam.poses import pose_array

#: How far (m, rad) a log's poses must move away from its odometry, relative to the first
#: record, to be corrected poses: a raw log's poses are its odometry (or within one odometry
#: message of it); a corrected log's drift meters away (Intel 62 m, Belgioioso 7.8 m).
CORRECTED_POSE_TOLERANCE = (0.25, 0.1)


class LaserLog:
    """A sequence of records, each with ``.scan`` (a LaserScan) and ``.pose`` (the odometry at
    it); subclasses read a file format and fill ``records``."""

    records: list

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


def _relative(origin: np.ndarray, xyt: np.ndarray) -> np.ndarray:
    """(n, 3) poses ``xyt`` in the frame of the pose ``origin`` (3,)."""
    c, s = np.cos(origin[2]), np.sin(origin[2])
    dx, dy = xyt[:, 0] - origin[0], xyt[:, 1] - origin[1]
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, xyt[:, 2] - origin[2]])
