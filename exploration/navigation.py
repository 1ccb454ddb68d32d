"""Getting to the goal: the initial look around, path following, and the progress monitor that
says when a goal is reached or must be abandoned."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from exploration.explorer import Plan
from exploration.follower import FollowerConfig, PathFollower


class NavigationConfig(BaseModel):
    """How the robot looks around first, follows paths, and decides it is stuck."""

    model_config = ConfigDict(extra="forbid")

    follower: FollowerConfig = FollowerConfig()
    initial_spin: bool = Field(True, description="turn once on the spot before exploring (the "
                               "laser sees only 180 degrees)")
    stuck_steps: int = Field(150, ge=1, description="scans without getting stuck_progress closer to "
                             "the goal along the path before it is abandoned and blacklisted")
    stuck_progress: float = Field(0.2, gt=0, description="progress along the path (m) that restarts "
                                  "the stuck count")
    guard_clearance: float = Field(0.02, ge=0, description="the robot slows, then stops and turns "
                                   "on the spot, rather than drive its disc closer than this (m) to "
                                   "a point of the current scan (2 sigma of the range noise, as the "
                                   "planner's margin): the path may be off by more than that (pose "
                                   "error, cut corners)")
    guard_horizon: float = Field(0.5, gt=0, description="seconds of the commanded arc checked "
                                 "against the current scan")


class ProgressMonitor:
    """Is the robot still getting closer to its goal? Stuck after ``steps`` scans in which the
    path left to go never shrank by ``progress`` meters below its best so far."""

    def __init__(self, steps: int, progress: float):
        self.steps = steps
        self.progress = progress
        self.reset()

    def reset(self) -> None:
        """A new goal: nothing measured yet."""
        self.best = math.inf
        self.since_progress = 0

    def stuck(self, remaining: float) -> bool:
        """One scan with ``remaining`` meters of path left: True when the goal must be abandoned."""
        if remaining < self.best - self.progress:
            self.best, self.since_progress = remaining, 0
        else:
            self.since_progress += 1
        return self.since_progress > self.steps


@dataclass(frozen=True)
class Command:
    """Velocities for the robot (m/s, rad/s), and what happened to the goal: ``reached``,
    ``stuck`` (abandon it), or None."""

    v: float
    w: float
    event: Literal["reached", "stuck"] | None = None


def clearance_kept(obstacles: np.ndarray, radius: float, clearance: float) -> np.ndarray:
    """(k,) how near (m) a move may bring the robot's centre to each point of ``obstacles``
    (k, 2), the scan's hits in the robot frame: ``radius + clearance``; where the robot
    already stands nearer, ``clearance`` nearer than it stands, but not within ``radius``; to
    a point within ``radius`` (range noise put it there), no nearer than it is.

    The nearest of a scan's hits is as noisy as the rest (``clearance`` is 2 σ of the range
    noise), and a move sweeps past hits the robot has not had beside it, the nearest of which
    reads nearer again: a rule of "no nearer than now" refused every way into a passage 5 cm
    wider than the robot (lab_e's doors). And a point read within the radius must not lower
    what the others keep: it let a turn take the robot's disc into the opposite wall."""
    d = np.linalg.norm(obstacles, axis=1)
    touching = d < radius
    nearest = d[~touching].min() if np.any(~touching) else np.inf
    allowed = np.full(len(d), min(radius + clearance, max(nearest - clearance, radius)))
    allowed[touching] = d[touching]
    return allowed


def guarded(v: float, w: float, obstacles: np.ndarray, radius: float, clearance: float,
            horizon: float, max_turn_rate: float) -> tuple[float, float]:
    """The command nearest to (``v``, ``w``) (m/s, rad/s) whose arc over ``horizon`` seconds
    keeps the robot's centre as far from every point of ``obstacles`` (k, 2), in the robot
    frame (m), as ``clearance_kept`` allows: the speed v, v/2 or v/4 first, then the turn
    rate moved towards either side in steps of a quarter of ``max_turn_rate``; else (0, w): a
    disc turning on the spot cannot hit anything."""
    if v <= 0 or len(obstacles) == 0:
        return v, w
    allowed = clearance_kept(obstacles, radius, clearance)
    near = np.linalg.norm(obstacles, axis=1) < v * horizon + allowed
    obstacles, allowed = obstacles[near], allowed[near]
    t = np.linspace(0.0, horizon, 9)[1:]
    turns = w + max_turn_rate * np.array([0.0, 0.25, -0.25, 0.5, -0.5, 1.0, -1.0])
    for turn in turns[np.abs(turns) <= max_turn_rate + 1e-9]:
        for speed in (v, v / 2, v / 4):
            if np.isclose(turn, 0.0):
                arc = np.column_stack([speed * t, np.zeros_like(t)])
            else:
                arc = np.column_stack([np.sin(turn * t), 1.0 - np.cos(turn * t)]) * (speed / turn)
            gap = np.linalg.norm(arc[:, None] - obstacles[None], axis=2).min(axis=0, initial=np.inf)
            if np.all(gap >= allowed):
                return speed, float(turn)
    return 0.0, w


def straight_clear(to: np.ndarray, obstacles: np.ndarray, radius: float, clearance: float) -> bool:
    """Can the robot drive straight from the origin to ``to`` (2,) keeping its centre as far
    from every point of ``obstacles`` (k, 2) as ``clearance_kept`` allows (``guarded``'s
    rule)? All in the robot frame, meters."""
    if len(obstacles) == 0:
        return True
    to = np.asarray(to, dtype=float)
    t = np.clip(obstacles @ to / max(float(to @ to), 1e-12), 0.0, 1.0)
    gap = np.linalg.norm(obstacles - t[:, None] * to, axis=1)
    return bool(np.all(gap >= clearance_kept(obstacles, radius, clearance)))


class Navigator:
    """Turns the explorer's plan into velocity commands, one per scan, and keeps them off what
    the current scan shows (``guarded``).

    Args:
        config: spin, follower gains, the stuck test and the guard.
        max_speed: the robot's top speed, m/s.
        max_turn_rate: the robot's top turn rate, rad/s.
        radius: the robot's, m.
    """

    def __init__(self, config: NavigationConfig, max_speed: float, max_turn_rate: float,
                 radius: float):
        self.config = config
        self.radius = radius
        self.follower = PathFollower(max_speed, max_turn_rate, config.follower)
        self.monitor = ProgressMonitor(config.stuck_steps, config.stuck_progress)
        self._spin_until: float | None = None if config.initial_spin else -math.inf
        self._refused_since: float | None = None   # stamp since which the guard refuses to go on

    def spinning(self, stamp: float) -> bool:
        """Still turning once on the spot? The turn takes 2π / max_turn_rate seconds from the
        first scan's ``stamp``."""
        if self._spin_until is None:
            self._spin_until = stamp + 2 * math.pi / self.follower.max_turn_rate - 1e-9
        return stamp < self._spin_until

    def spin(self, stamp: float) -> None:
        """Turn once more on the spot, from scan time ``stamp`` (s)."""
        self._spin_until = stamp + 2 * math.pi / self.follower.max_turn_rate - 1e-9

    def command(self, pose: gtsam.Pose2, plan: Plan, stamp: float,
                obstacles: np.ndarray = np.zeros((0, 2))) -> Command:
        """The command at ``pose`` for ``plan`` at scan time ``stamp`` (s): turn on the spot at
        first, then follow the path, no nearer to ``obstacles`` (k, 2), the scan's hits in the
        robot frame (m), than the guard allows; none without a goal (exploration is over).
        The goal is abandoned ("stuck") after ``stuck_steps`` scans without progress, or once
        the guard has refused every way forward for as long as a full turn on the spot takes
        (2π / max_turn_rate): what lies ahead is narrower than the robot, and the monitor's
        150 scans would be spent at it."""
        if self.spinning(stamp):
            return Command(0.0, self.follower.max_turn_rate)
        if plan.goal is None:
            return Command(0.0, 0.0)
        c = self.config
        v, w, reached = self.follower.command(
            pose, plan.path, lambda carrot: straight_clear(carrot, obstacles, self.radius, c.guard_clearance))
        if reached:
            return Command(0.0, 0.0, "reached")
        if self.monitor.stuck(self.follower.remaining(pose, plan.path)):
            return Command(0.0, 0.0, "stuck")
        command = Command(*guarded(v, w, obstacles, self.radius, c.guard_clearance, c.guard_horizon,
                                   self.follower.max_turn_rate))
        if not (v > 0 and command.v == 0):
            self._refused_since = None
        elif self._refused_since is None:
            self._refused_since = stamp
        elif stamp - self._refused_since >= 2 * math.pi / self.follower.max_turn_rate - 1e-9:
            return Command(0.0, 0.0, "stuck")
        return command

    def new_goal(self) -> None:
        """The explorer chose a new goal: progress is measured afresh."""
        self.monitor.reset()
        self._refused_since = None
