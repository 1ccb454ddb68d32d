"""Drive a robot along a scripted tour of waypoints, recording truth, odometry and scans."""

from __future__ import annotations

from dataclasses import dataclass, field

import gtsam
import numpy as np
from tqdm import tqdm

from exploration.follower import PathFollower
from sim.lidar import Lidar
from sim.odometry import Odometry
from sim.robot import Robot
from slam.scan import LaserScan


@dataclass
class TourLog:
    """What a robot saw and believed along its way, one entry per scan."""

    stamps: list[float] = field(default_factory=list)
    truth: list[gtsam.Pose2] = field(default_factory=list)
    odometry: list[gtsam.Pose2] = field(default_factory=list)
    scans: list[LaserScan] = field(default_factory=list)


def drive_tour(robot: Robot, lidar: Lidar, odometry: Odometry, tour: np.ndarray,
               max_steps: int = 20000, progress: bool = False) -> TourLog:
    """Follow ``tour`` (k, 2) waypoint by waypoint, one scan per lidar period.

    Stops at the last waypoint or after ``max_steps`` scans.
    """
    dt = 1.0 / lidar.config.rate_hz
    c = robot.config
    follower = PathFollower(c.max_speed, c.max_turn_rate)
    log = TourLog()

    def record(t: float) -> None:
        log.stamps.append(t)
        log.truth.append(robot.pose)
        log.odometry.append(odometry.pose)
        log.scans.append(lidar.scan(robot.world, robot.pose, t))

    record(0.0)
    bar = tqdm(total=len(tour) - 1, desc="tour", unit="waypoint", disable=not progress)
    leg = 1
    while leg < len(tour) and len(log.stamps) < max_steps:
        v, w, reached = follower.command(robot.pose, tour[leg - 1:leg + 1])
        if reached:
            leg += 1
            bar.update()
            continue
        odometry.update(robot.move(v, w, dt))
        record(len(log.stamps) * dt)
    bar.close()
    return log
