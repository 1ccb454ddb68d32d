"""Reader for ROS bags: ``sensor_msgs/LaserScan`` with the ``nav_msgs/Odometry`` pose at each scan.

ROS 1 (``.bag``) and ROS 2 bags (a directory holding ``metadata.yaml`` with sqlite3 or MCAP storage,
or a single ``.db3``/``.mcap`` file) are read with the pure-Python ``rosbags`` package (the
``ros`` extra: ``pip install gpexplore[ros]``).

Each scan gets the odometry pose at its header stamp, interpolated linearly (x, y and yaw along
the shorter arc) between the two odometry messages around it (by their header stamps). Scans
stamped before the first or after the last odometry message are dropped and listed in
``skipped``. The poses are the robot base's (the odometry's child frame, ``base_link``); the laser
sits at the pose of the scans' frame (their ``header.frame_id``) in that frame. A bag with a
``/tf_static`` topic states it: the static transforms chained from the child frame to the scans'
frame, projected onto the plane (x, y, yaw), are the bag's ``laser_offset``. Without them (or
without a chain between the two frames) the bag states none and the configured offset applies;
``laser_offset_note`` says why.

Ranges follow REP 117 and the CARMEN reader's conventions: a reading at or beyond the effective
maximum range (the message's ``range_max``, or the ``max_range`` argument if smaller) or +inf is
"no return" (free up to the maximum range); NaN, -inf and readings below ``range_min`` carry no
information and read NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import gtsam
import numpy as np

from slam.carmen import DEFAULT_MAX_RANGE
from slam.laser_log import LaserLog
from slam.scan import LaserScan

LASER_SCAN = "sensor_msgs/msg/LaserScan"
ODOMETRY = "nav_msgs/msg/Odometry"
TF_STATIC = "/tf_static"
#: The topic chosen when a bag has several of a type.
PREFERRED_TOPIC = {LASER_SCAN: "/scan", ODOMETRY: "/odom"}
BAG_SUFFIXES = (".bag", ".db3", ".mcap")


class BagError(ValueError):
    """A bag that cannot be read as scans with odometry; the message names the bag."""


def is_bag(path: str | Path) -> bool:
    """Whether ``path`` names a ROS bag (a ``.bag``/``.db3``/``.mcap`` file or a ROS 2 bag
    directory) rather than a CARMEN log."""
    path = Path(path)
    return path.suffix in BAG_SUFFIXES or path.is_dir()


@dataclass(frozen=True)
class BagRecord:
    """One LaserScan message of a bag with the odometry at its stamp.

    Attributes:
        index: 1-based number of the message on the scan topic, in stamp order.
        scan: the ranges, beam angles and header stamp (s).
        pose: the odometry pose at the scan (the pose a bag "logs" with it).
        odometry: the same pose; raw wheel odometry is all a bag holds.
    """

    index: int
    scan: LaserScan
    pose: gtsam.Pose2
    odometry: gtsam.Pose2


class RosBag(LaserLog):
    """The LaserScan messages of a ROS bag with odometry, in stamp order: ``len(bag)``, ``bag[i]``,
    iteration.

    Args:
        path: a ROS 1 ``.bag``, a ROS 2 bag directory, or a ROS 2 ``.db3``/``.mcap`` file.
        scan_topic: the LaserScan topic; by default the bag's only one, or ``/scan`` among several.
        odom_topic: the Odometry topic; by default the bag's only one, or ``/odom`` among several.
        max_range: readings at or beyond this many meters (or the message's ``range_max``, if
            smaller) are "no return".
    """

    def __init__(self, path: str | Path, scan_topic: str | None = None, odom_topic: str | None = None,
                 max_range: float = DEFAULT_MAX_RANGE):
        self.path = Path(path)
        if not self.path.exists():
            raise FileNotFoundError(f"{self.path}: no such bag")
        if self.path.is_dir() and not (self.path / "metadata.yaml").is_file():
            raise BagError(f"{self.path}: a directory without metadata.yaml is not a ROS 2 bag")
        if not max_range > 0:
            raise ValueError(f"max_range must be positive, got {max_range}")
        self.max_range = float(max_range)
        try:
            from rosbags.highlevel import AnyReader, AnyReaderError
        except ImportError:
            raise BagError(f"{self.path}: reading ROS bags needs the rosbags package: "
                           "pip install gpexplore[ros]") from None
        self.skipped: list[tuple[int, str]] = []
        self.base_frame = self.laser_frame = ""
        try:
            with AnyReader([self.path]) as reader:
                self.scan_topic = self._topic(reader, LASER_SCAN, scan_topic, "--scan-topic")
                self.odom_topic = self._topic(reader, ODOMETRY, odom_topic, "--odom-topic")
                stamps, poses = self._odometry(reader)
                self.records = self._scans(reader, stamps, poses)
                self._read_mount(reader)
        except (AnyReaderError, OSError) as err:
            raise BagError(f"{self.path}: cannot read bag: {err}") from None

    def _read_mount(self, reader) -> None:
        """``laser_offset``: the scans' frame in the odometry's child frame from ``/tf_static``
        (see the module docstring), or None with ``laser_offset_note`` saying why."""
        base, laser = self.base_frame, self.laser_frame
        self.laser_offset_note = None
        if not base or not laser:
            self.laser_offset_note = "the odometry's child frame or the scans' frame is not named"
        elif base == laser:
            self.laser_offset_note = f"the scans are in the odometry's child frame '{base}'"
        elif TF_STATIC not in reader.topics:
            self.laser_offset_note = f"no {TF_STATIC} topic"
        else:
            edges = {}                                        # child → (parent, pose in parent)
            for message in self._messages(reader, TF_STATIC):
                for t in message.transforms:
                    r, q = t.transform.translation, t.transform.rotation
                    edges[_frame(t.child_frame_id)] = (_frame(t.header.frame_id),
                                                       gtsam.Pose2(r.x, r.y, _yaw(q)))
            offset = _between_frames(edges, base, laser)
            if offset is None:
                self.laser_offset_note = f"{TF_STATIC} has no chain of transforms from '{base}' to '{laser}'"
            else:
                self.laser_offset, self.laser_offset_source = offset, TF_STATIC

    def _topic(self, reader, msgtype: str, wanted: str | None, option: str) -> str:
        """The topic of ``msgtype`` to read: ``wanted``, the only one, or the preferred name."""
        topics = {name: info.msgtype for name, info in reader.topics.items()}
        candidates = sorted(name for name, t in topics.items() if t == msgtype)
        kind = _short(msgtype)
        if wanted is not None:
            if wanted not in topics:
                raise BagError(f"{self.path}: no topic '{wanted}' ({option}); {kind} topics: "
                               f"{', '.join(candidates) or 'none'}")
            if topics[wanted] != msgtype:
                raise BagError(f"{self.path}: topic '{wanted}' ({option}) holds {_short(topics[wanted])}, "
                               f"not {kind}")
            return wanted
        if len(candidates) == 1:
            return candidates[0]
        if not candidates:
            listing = ", ".join(f"{name} ({_short(t)})" for name, t in sorted(topics.items())) or "none"
            raise BagError(f"{self.path}: no {kind} topic (topics: {listing})")
        if PREFERRED_TOPIC[msgtype] in candidates:
            return PREFERRED_TOPIC[msgtype]
        raise BagError(f"{self.path}: several {kind} topics ({', '.join(candidates)}): "
                       f"choose one with {option}")

    def _messages(self, reader, topic: str):
        """Every message on ``topic``, deserialised, in bag order."""
        connections = [c for c in reader.connections if c.topic == topic]
        for connection, _, raw in reader.messages(connections=connections):
            yield reader.deserialize(raw, connection.msgtype)

    def _odometry(self, reader) -> tuple[np.ndarray, np.ndarray]:
        """(n,) header stamps (s), sorted, and (n, 3) x, y, unwrapped yaw of the odometry."""
        rows = []
        for m in self._messages(reader, self.odom_topic):
            rows.append((_seconds(m.header.stamp), m.pose.pose.position.x, m.pose.pose.position.y,
                         _yaw(m.pose.pose.orientation)))
            self.base_frame = self.base_frame or _frame(m.child_frame_id)
        if not rows:
            raise BagError(f"{self.path}: no messages on the odometry topic '{self.odom_topic}'")
        table = np.array(sorted(rows))
        table[:, 3] = np.unwrap(table[:, 3])
        return table[:, 0], table[:, 1:]

    def _scans(self, reader, stamps: np.ndarray, poses: np.ndarray) -> list[BagRecord]:
        scans = sorted((_seconds(m.header.stamp), k, m)
                       for k, m in enumerate(self._messages(reader, self.scan_topic)))
        if not scans:
            raise BagError(f"{self.path}: no messages on the scan topic '{self.scan_topic}'")
        self.laser_frame = _frame(scans[0][2].header.frame_id)
        at = np.array([stamp for stamp, _, _ in scans])
        xyt = np.column_stack([np.interp(at, stamps, poses[:, i]) for i in range(3)])
        records = []
        for index, ((stamp, _, message), (x, y, yaw)) in enumerate(zip(scans, xyt), start=1):
            if not stamps[0] <= stamp <= stamps[-1]:
                side = "before the first" if stamp < stamps[0] else "after the last"
                self.skipped.append((index, f"scan at {stamp:.3f} s is {side} odometry message "
                                            f"({stamps[0]:.3f} to {stamps[-1]:.3f} s)"))
                continue
            pose = gtsam.Pose2(x, y, yaw)
            records.append(BagRecord(index, self._scan(message, stamp), pose, pose))
        if not records:
            raise BagError(f"{self.path}: none of the {len(scans)} scans on '{self.scan_topic}' lies "
                           f"within the odometry's time span ({stamps[0]:.3f} to {stamps[-1]:.3f} s)")
        return records

    def _scan(self, message, stamp: float) -> LaserScan:
        """A LaserScan message in the stack's conventions (see the module docstring)."""
        ranges = np.asarray(message.ranges, dtype=float)
        angles = message.angle_min + message.angle_increment * np.arange(len(ranges))
        sensor_max = float(message.range_max)
        max_range = min(self.max_range, sensor_max) if sensor_max > 0 else self.max_range
        with np.errstate(invalid="ignore"):
            ranges[np.isneginf(ranges) | (ranges < message.range_min)] = np.nan
        return LaserScan(ranges, angles, max_range, timestamp=stamp)


def _short(msgtype: str) -> str:
    """``sensor_msgs/LaserScan`` for ``sensor_msgs/msg/LaserScan`` (rosbags' ROS 2 style names)."""
    return msgtype.replace("/msg/", "/")


def _frame(name: str) -> str:
    """A tf frame name without ROS 1's leading slash."""
    return name.lstrip("/")


def _between_frames(edges: dict, base: str, laser: str) -> gtsam.Pose2 | None:
    """The pose of frame ``laser`` in frame ``base`` through the tree ``edges`` (child → (parent,
    pose in parent)); None when they share no root."""
    def to_root(frame):
        """{ancestor: pose of ``frame`` in it}, from ``frame`` itself up to its root."""
        chain, pose = {frame: gtsam.Pose2()}, gtsam.Pose2()
        while frame in edges and len(chain) <= len(edges):
            frame, step = edges[frame]
            pose = step.compose(pose)
            chain[frame] = pose
        return chain

    from_base, from_laser = to_root(base), to_root(laser)
    common = next((f for f in from_laser if f in from_base), None)
    if common is None:
        return None
    return from_base[common].between(from_laser[common])


def _seconds(stamp) -> float:
    return stamp.sec + 1e-9 * stamp.nanosec


def _yaw(q) -> float:
    """Rotation about z of a unit quaternion (x, y, z, w)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
