"""Drive a robot along a scripted tour of waypoints, recording truth, odometry and scans."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import gtsam
import numpy as np
from tqdm import tqdm

from exploration.follower import PathFollower
from sim.lidar import Lidar
from sim.odometry import Odometry
from sim.robot import Robot
from sim.worlds import BuiltinWorld
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


def odometry_drift(log: TourLog) -> np.ndarray:
    """(n,) distance in m from the true position to the odometry's at each scan, the odometry
    taken from the true start (its own frame starts wherever it was reset)."""
    start, origin = log.truth[0], log.odometry[0]
    return np.array([np.hypot(*(start.compose(origin.between(o)).translation() - t.translation()))
                     for o, t in zip(log.odometry, log.truth)])


def demo_tour(builtin: BuiltinWorld, seed: int = 0, progress: bool = False) -> tuple[TourLog, dict]:
    """The built-in world's scripted tour with the lidar's and the odometry's noise drawn from
    ``seed``; the log and its metrics: steps, travel (m), robot and wall time (s), collisions,
    and the odometry drift (m) at the end and at its largest."""
    lidar_seed, odometry_seed = np.random.SeedSequence(seed).spawn(2)
    robot = Robot(builtin.world, builtin.start)
    tic = time.perf_counter()
    log = drive_tour(robot, Lidar(seed=lidar_seed), Odometry(seed=odometry_seed), builtin.tour,
                     progress=progress)
    wall = time.perf_counter() - tic
    drift = odometry_drift(log)
    start = log.truth[0]
    return log, {
        "world": builtin.world.name,
        "seed": seed,
        "start": [start.x(), start.y(), start.theta()],
        "steps": len(log.scans),
        "travel_distance_m": robot.distance,
        "sim_time_s": log.stamps[-1],
        "wall_time_s": wall,
        "collisions": robot.collisions,
        "final_odometry_drift_m": float(drift[-1]),
        "max_odometry_drift_m": float(drift.max()),
    }
