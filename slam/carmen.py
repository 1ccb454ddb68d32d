"""Reader for CARMEN laser logs (plain or gzipped): FLASER, ROBOTLASER1, ODOM and PARAM messages.

Field of view conventions (FLASER carries none): the scan spans 180 degrees starting at -90 degrees
(the robot's right), counter-clockwise. An odd beam count (181, 361) includes both ends, a step of
180/(n-1) degrees; an even count (180, 360) has a step of 180/n degrees. ROBOTLASER1 carries its
own start angle and angular resolution.

Raw logs hold odometry in FLASER and usually no ODOM lines; then ``LaserRecord.odometry`` is the
FLASER odometry slot. With ODOM lines it is built from them, the most recent one before the scan.

"Corrected" logs written by GMapping (``*.gfs.log``) hold SLAM poses in FLASER, and their ODOM lines
are *not* a raw odometry trajectory: right after each scan GMapping writes an ODOM line with
timestamp 0 that repeats the corrected pose, and the following ODOM lines continue from that
corrected pose (the wheel increments since the scan applied to it). The reader detects this
re-basing (an ODOM line right after a scan repeating its pose; the timestamp meant to be 0 is
sometimes garbage) and chains the increments into a proper odometry trajectory:
``odometry[k+1] = odometry[k] ∘ pose[k]⁻¹ ∘ ODOM_last_before(k+1)``, so the relative motion between
consecutive records' ``odometry`` is the wheel odometry's, as a SLAM front end needs.

Both laser messages carry two poses: the laser's (FLASER ``x y theta``, ROBOTLASER1 ``laser_pose_*``)
and the robot base's (FLASER ``odom_*``, ROBOTLASER1 ``robot_pose_*``). CARMEN's robot module writes
the laser's as the robot's composed with the laser's mount (laser = robot ∘ offset), so each line
states the mount: ``LaserRecord.laser_offset = robot⁻¹ ∘ laser``. When every line states the same
one, the log's ``laser_offset`` is that mount (None when it is the identity: the log says nothing),
and ``LaserRecord.pose`` is the robot's pose, the base pose the stack estimates. When the lines
disagree, or their mount is farther than ``MAX_MOUNT_DISTANCE`` from the robot (a localised
laser pose beside raw odometry), no mount can be read: ``laser_offset`` is
None and ``pose`` is the laser's pose, as logged. The ``robot_frontlaser_offset`` PARAM is not
applied: the GMapping-corrected Freiburg logs state -0.04 m there while their two poses are equal.

A log with ODOM lines where no (non-repeat) ODOM line came between two scans says nothing about
the motion between them: that record's ``odometry`` is None, not the stale value, which would
claim the robot stood still (Örebro's corrected log has wheel increments before 18 of its 237
scans).
"""

from __future__ import annotations

import dataclasses
import gzip
import math
from dataclasses import dataclass
from pathlib import Path

import gtsam
import numpy as np

from slam.laser_log import LaserLog
from slam.scan import LaserScan, fov_angles

#: Readings at or beyond this are "no return" in CARMEN logs (they hold 81.83 or 81.91).
DEFAULT_MAX_RANGE = 80.0
#: A laser farther than this (m) from the robot's pose is no mount: the line's two poses come from
#: different sources (a localised laser pose beside raw odometry).
MAX_MOUNT_DISTANCE = 2.0


class LogFormatError(ValueError):
    """A malformed line in a log, or a log that cannot be read; the message names the file and
    line. ``line`` is the malformed line's number (None for the whole file): such a line can be
    skipped (``skip_malformed``)."""

    def __init__(self, message: str, line: int | None = None):
        super().__init__(message)
        self.line = line


@dataclass(frozen=True)
class LaserRecord:
    """One laser message of a log.

    Attributes:
        line: 1-based line number in the file.
        scan: the ranges, beam angles and ipc timestamp.
        pose: the robot base's pose logged with the scan (odometry in raw logs, SLAM pose in
            corrected logs); the laser's pose as logged when the log states no consistent mount.
        odometry: the raw wheel odometry at the scan; None when the log's ODOM lines say nothing
            about the motion since the previous scan.
        laser_offset: the laser's pose in the robot's frame as the line states it (robot pose⁻¹
            ∘ laser pose).
    """

    line: int
    scan: LaserScan
    pose: gtsam.Pose2
    odometry: gtsam.Pose2 | None
    laser_offset: gtsam.Pose2 = gtsam.Pose2()


class CarmenLog(LaserLog):
    """The laser messages of a CARMEN log, in file order: ``len(log)``, ``log[i]``, iteration.

    Args:
        path: a ``.clf``/``.log`` file, optionally gzipped (``.gz``).
        max_range: readings at or beyond this many meters are "no return".
        skip_malformed: skip malformed laser/odometry lines (counted in ``skipped``) instead
            of raising ``LogFormatError``.
    """

    def __init__(self, path: str | Path, max_range: float = DEFAULT_MAX_RANGE,
                 skip_malformed: bool = False):
        self.path = Path(path)
        if not self.path.is_file():
            raise FileNotFoundError(f"{self.path}: no such log file")
        if not max_range > 0:
            raise ValueError(f"max_range must be positive, got {max_range}")
        self.max_range = float(max_range)
        self.params: dict[str, str] = {}
        self.skipped: list[tuple[int, str]] = []
        self.has_odom_lines = False
        self.records: list[LaserRecord] = []
        self._laser_poses: list[gtsam.Pose2] = []
        self._read(skip_malformed)
        if not self.records:
            raise LogFormatError(f"{self.path}: no laser messages (FLASER or ROBOTLASER1) found")
        self._read_mount()

    def _read_mount(self) -> None:
        """The log's ``laser_offset`` from its lines' mounts, and each record's ``pose`` (see the
        module docstring)."""
        first = self.records[0].laser_offset
        if (math.hypot(first.x(), first.y()) <= MAX_MOUNT_DISTANCE
                and all(_same(r.laser_offset, first, 1e-3) for r in self.records)):
            self.laser_offset = None if _same(first, gtsam.Pose2()) else first
            self.laser_offset_source = "log" if self.laser_offset is not None else None
        else:
            self.laser_offset = self.laser_offset_source = None
            self.records = [dataclasses.replace(r, pose=laser)
                            for r, laser in zip(self.records, self._laser_poses)]
        del self._laser_poses

    def _read(self, skip_malformed: bool) -> None:
        opener = gzip.open if self.path.suffix == ".gz" else open
        last_odom: gtsam.Pose2 | None = None
        after_laser = False
        rebase: gtsam.Pose2 | None = None  # the corrected pose the ODOM lines continue from
        chain: gtsam.Pose2 | None = None   # the chained odometry at the last scan
        fresh = False                      # an ODOM increment came since the last scan
        self.rebased_odometry = False
        try:
            with opener(self.path, "rt", errors="replace") as f:
                for number, text in enumerate(f, start=1):
                    fields = text.split()
                    if not fields or fields[0].startswith("#"):
                        continue
                    try:
                        kind = fields[0]
                        if kind == "ODOM":
                            odom, _ = _parse_odom(fields)
                            if after_laser and self.records and _same(odom, self._laser_poses[-1]):
                                # GMapping's repeat of the corrected pose (its timestamp is meant to
                                # be 0 but is sometimes garbage, e.g. 4.58e-72 in intel)
                                rebase = odom
                                self.rebased_odometry = True
                                last_odom = odom
                            else:
                                last_odom = odom
                                fresh = True
                                self.has_odom_lines = True
                        after_laser = kind in ("FLASER", "ROBOTLASER1")
                        if after_laser:
                            parse = _parse_flaser if kind == "FLASER" else _parse_robotlaser
                            scan, laser, pose = parse(fields, self.max_range)
                            if not self.has_odom_lines:
                                odometry = pose
                            else:
                                if rebase is not None and chain is not None:
                                    chain = chain.compose(rebase.between(last_odom))
                                else:
                                    chain = last_odom
                                odometry = chain if fresh or not self.records else None
                            fresh = False
                            self.records.append(LaserRecord(number, scan, pose, odometry, pose.between(laser)))
                            self._laser_poses.append(laser)
                        elif kind == "PARAM" and len(fields) >= 3:
                            self.params[fields[1]] = fields[2]
                    except (ValueError, IndexError) as err:
                        message = f"{self.path}:{number}: {err}"
                        if not skip_malformed:
                            raise LogFormatError(message, number) from None
                        self.skipped.append((number, str(err)))
        except (OSError, EOFError, gzip.BadGzipFile) as err:
            raise LogFormatError(f"{self.path}: cannot read log: {err}") from None


def _same(a: gtsam.Pose2, b: gtsam.Pose2, tol: float = 1e-4) -> bool:
    return abs(a.x() - b.x()) < tol and abs(a.y() - b.y()) < tol and abs(a.theta() - b.theta()) < tol


def _floats(fields: list[str], what: str) -> np.ndarray:
    try:
        values = np.array(fields, dtype=float)
    except ValueError:
        raise ValueError(f"{what} has a non-numeric field") from None
    return values


def _pose(values) -> gtsam.Pose2:
    x, y, theta = (float(v) for v in values)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(theta)):
        raise ValueError(f"pose ({x}, {y}, {theta}) is not finite")
    return gtsam.Pose2(x, y, theta)


def _parse_odom(fields: list[str]) -> tuple[gtsam.Pose2, float]:
    # ODOM x y theta tv rv accel ipc_timestamp ipc_hostname logger_timestamp
    if len(fields) < 8:
        raise ValueError(f"ODOM line has {len(fields)} fields, expected at least 8")
    values = _floats(fields[1:8], "ODOM line")
    return _pose(values[0:3]), float(values[6])


def _count(fields: list[str], index: int, what: str) -> int:
    """The count at ``fields[index]``; ValueError naming ``what`` when it is missing or not one."""
    if index >= len(fields):
        raise ValueError(f"{fields[0]} line ends before its {what} ({len(fields)} fields)")
    try:
        return int(fields[index])
    except ValueError:
        raise ValueError(f"{fields[0]} {what} {fields[index]!r} is not an integer") from None


def _parse_flaser(fields: list[str], max_range: float):
    # FLASER n r_1..r_n x y theta odom_x odom_y odom_theta ipc_timestamp ipc_hostname logger_ts
    n = _count(fields, 1, "beam count")
    expected = n + 11
    if n < 1 or len(fields) != expected:
        raise ValueError(f"FLASER line has {len(fields) - 11} ranges for n = {n} "
                         f"({len(fields)} fields, expected {expected})")
    ranges = _floats(fields[2:2 + n], "FLASER ranges")
    tail = _floats(fields[2 + n:2 + n + 7], "FLASER pose/timestamp")
    angles = fov_angles(n, math.pi, include_end=n % 2 == 1)
    scan = LaserScan(ranges, angles, max_range, timestamp=float(tail[6]))
    return scan, _pose(tail[0:3]), _pose(tail[3:6])


def _parse_robotlaser(fields: list[str], max_range: float):
    # ROBOTLASER1 type start_angle fov angular_res max_range accuracy remission_mode n r_1..r_n
    #   m rem_1..rem_m laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv
    #   forward_safety_dist side_safety_dist turn_axis ipc_timestamp ipc_hostname logger_ts
    # (CARMEN's logger header; laser = robot ∘ the laser's mount)
    n = _count(fields, 8, "beam count")
    if n < 1:
        raise ValueError(f"ROBOTLASER1 beam count {n} is not positive")
    m = _count(fields, 9 + n, "remission count")
    rest = fields[10 + n + m:] if m >= 0 else []
    if m < 0 or len(rest) != 14:
        raise ValueError(f"ROBOTLASER1 line has {len(fields)} fields, inconsistent with "
                         f"n = {n} ranges and m = {m} remissions (then 11 values, a timestamp, "
                         "a host name and a logger timestamp)")
    start, _, resolution, sensor_max = _floats(fields[2:6], "ROBOTLASER1 header")
    ranges = _floats(fields[9:9 + n], "ROBOTLASER1 ranges")
    tail = _floats(rest[:11], "ROBOTLASER1 poses")
    timestamp = float(_floats(rest[11:12], "ROBOTLASER1 timestamp")[0])
    angles = start + resolution * np.arange(n)
    effective_max = min(max_range, sensor_max) if sensor_max > 0 else max_range
    scan = LaserScan(ranges, angles, effective_max, timestamp=timestamp)
    return scan, _pose(tail[0:3]), _pose(tail[3:6])


def write_corrected_log(path: str | Path, log: CarmenLog, poses: list[gtsam.Pose2],
                        laser_offset: gtsam.Pose2 | None = None) -> None:
    """Write ``log``'s laser lines with their pose triples replaced, atomically: the robot's (FLASER's
    second triple, ROBOTLASER1's robot pose) by ``poses`` (the base's, one per record), the laser's
    by ``poses`` ∘ ``laser_offset`` (by default the log's own, else the identity). It is the
    "corrected log" the Freiburg metricEvaluator reads (it takes the second triple of FLASER and
    the robot pose of ROBOTLASER1). Ranges and timestamps are copied verbatim."""
    from slam.atomic import write_text_atomic

    if len(poses) != len(log):
        raise ValueError(f"{path}: {len(poses)} poses for {len(log)} laser records of {log.path}")
    mount = laser_offset or log.laser_offset or gtsam.Pose2()
    by_line = {r.line: p for r, p in zip(log.records, poses)}
    opener = gzip.open if log.path.suffix == ".gz" else open
    rows = [f"# {log.path.name} with poses from gpexplore Pose SLAM"]
    with opener(log.path, "rt", errors="replace") as f:
        for number, text in enumerate(f, start=1):
            pose = by_line.get(number)
            if pose is None:
                continue
            fields = text.split()
            both = _triple(pose.compose(mount)) + _triple(pose)
            if fields[0] == "FLASER":
                n = int(fields[1])
                fields[2 + n:2 + n + 6] = both
            else:
                n = int(fields[8])
                m = int(fields[9 + n])
                start = 10 + n + m
                fields[start:start + 6] = both
            rows.append(" ".join(fields))
    write_text_atomic(path, "".join(r + "\n" for r in rows))


def _triple(pose: gtsam.Pose2) -> list[str]:
    return [f"{pose.x():.6f}", f"{pose.y():.6f}", f"{pose.theta():.6f}"]
