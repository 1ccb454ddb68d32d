"""Recorded logs through the onboard stack: SLAM replay, and mapping a log at its own poses or
at the poses of the SLAM replay. A CARMEN log or a ROS bag (``slam.laser_log.LaserLog``)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from tqdm import tqdm

from exploration.stack import Stack, StackConfig
from mapping.config import COMConfig
from mapping.measured import MeasuredMap
from slam.carmen import DEFAULT_MAX_RANGE, CarmenLog
from slam.config import SlamConfig
from slam.laser_log import LaserLog, LaserMount, laser_mount
from slam.pose_slam import PoseSlam
from slam.replay import ReplayResult


def open_log(path: str | Path, max_range: float = DEFAULT_MAX_RANGE, skip_malformed: bool = False,
             scan_topic: str | None = None, odom_topic: str | None = None) -> LaserLog:
    """A CARMEN log or, by its path, a ROS bag (ROS 1 ``.bag``; ROS 2 folder, ``.db3`` or
    ``.mcap``). Raises ``LogFormatError``, ``BagError`` or ``FileNotFoundError`` naming the file
    (and line), and ``ValueError`` when topics are given for a CARMEN log."""
    from slam.rosbag import RosBag, is_bag

    path = Path(path)
    if is_bag(path):
        return RosBag(path, scan_topic, odom_topic, max_range=max_range)
    if scan_topic or odom_topic:
        raise ValueError(f"{path} is a CARMEN log: topics are for ROS bags")
    return CarmenLog(path, max_range=max_range, skip_malformed=skip_malformed)


def _drive(stack: Stack, log: LaserLog, progress: bool) -> float:
    """Every record through ``stack`` (the log's pose given with each scan); the wall time (s)."""
    tic = time.perf_counter()
    for record in tqdm(log, desc=log.path.name, unit="scan", disable=not progress):
        stack.step(record.odometry, record.scan, truth=record.pose)
    return time.perf_counter() - tic


def _counted(items: list, bar: tqdm):
    """``items``, each counted on ``bar`` once it has been processed."""
    for item in items:
        yield item
        bar.update()


def _replay_result(stack: Stack, wall: float, mount: LaserMount | None = None) -> ReplayResult:
    slam = stack.localiser
    return ReplayResult(slam, np.array(slam.scan_stamps), slam.trajectory(), wall, mount)


def _mounted(log: LaserLog, config: SlamConfig) -> tuple[SlamConfig, LaserMount]:
    """``config`` with the laser offset ``log`` states, else its own; and where it came from."""
    mount = laser_mount(log, config.laser_offset)
    return config.model_copy(update={"laser_offset": mount.offset}), mount


def replay_log(log: LaserLog, config: SlamConfig | None = None, progress: bool = False,
               slam: PoseSlam | None = None) -> ReplayResult:
    """Pose SLAM over every record of ``log``, the log's raw odometry as the prediction (the
    stack without map or planner); ``slam``: a prepared PoseSlam to use instead of a new one."""
    config, mount = _mounted(log, config or SlamConfig())
    stack = Stack(StackConfig(slam=config), mapping="off", planning=False, localiser=slam)
    return _replay_result(stack, _drive(stack, log, progress), mount)


@dataclass
class LogMap:
    """A log's COM with its measurements; ``replay`` is the SLAM replay (``poses="slam"``)."""

    map: MeasuredMap
    metrics: dict
    replay: ReplayResult | None = None


def map_log(log: LaserLog, poses: Literal["log", "slam"] = "log", com: COMConfig | None = None,
            slam: SlamConfig | None = None, every: int = 1, holdout: float = 0.0,
            progress: bool = False) -> LogMap:
    """The COM of every ``every``-th scan of ``log`` at its final pose: the log's own poses
    (``poses="log"``: a corrected log's, a bag's odometry) or those of the SLAM replay, which
    sees every scan. ``holdout`` of each scan's labelled points is kept out for the AUC."""
    if poses not in ("log", "slam"):
        raise ValueError(f"unknown pose source '{poses}' (have: log, slam)")
    measured = MeasuredMap(com, holdout)
    slam, mount = _mounted(log, slam or SlamConfig())
    config = StackConfig(poses="truth" if poses == "log" else "slam", slam=slam, map_every=every)
    stack = Stack(config, mapping="final", planning=False, occupancy=measured)
    replay_wall = _drive(stack, log, progress)
    tic = time.perf_counter()
    # stack.final_map(), the mapped scans through a progress bar: learning the COM takes most of
    # the time (Intel: 11 s of 13), then its scoring (AUC, entropy) a few seconds more
    scans = stack.mapped_scans()
    with tqdm(total=len(scans), desc="learning the map", unit="scan", disable=not progress) as bar:
        measured.regenerate(_counted(scans, bar))
        bar.set_postfix_str("scoring the map: AUC, entropy")
        metrics = {**measured.metrics(), **mount.metrics(), "wall_time_s": time.perf_counter() - tic}
    return LogMap(measured, metrics, _replay_result(stack, replay_wall, mount) if poses == "slam" else None)
