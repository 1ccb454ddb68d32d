"""Getting to the goal: the initial look around, path following, and the progress monitor that
says when a goal is reached or must be abandoned."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import gtsam
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


class Navigator:
    """Turns the explorer's plan into velocity commands, one per scan.

    Args:
        config: spin, follower gains and the stuck test.
        max_speed: the robot's top speed, m/s.
        max_turn_rate: the robot's top turn rate, rad/s.
    """

    def __init__(self, config: NavigationConfig, max_speed: float, max_turn_rate: float):
        self.config = config
        self.follower = PathFollower(max_speed, max_turn_rate, config.follower)
        self.monitor = ProgressMonitor(config.stuck_steps, config.stuck_progress)
        self._spin_until: float | None = None if config.initial_spin else -math.inf

    def spinning(self, stamp: float) -> bool:
        """Still turning once on the spot? The turn takes 2π / max_turn_rate seconds from the
        first scan's ``stamp``."""
        if self._spin_until is None:
            self._spin_until = stamp + 2 * math.pi / self.follower.max_turn_rate - 1e-9
        return stamp < self._spin_until

    def command(self, pose: gtsam.Pose2, plan: Plan, stamp: float) -> Command:
        """The command at ``pose`` for ``plan`` at scan time ``stamp`` (s): turn on the spot at
        first, then follow the path; none without a goal (exploration is over)."""
        if self.spinning(stamp):
            return Command(0.0, self.follower.max_turn_rate)
        if plan.goal is None:
            return Command(0.0, 0.0)
        v, w, reached = self.follower.command(pose, plan.path)
        if reached:
            return Command(0.0, 0.0, "reached")
        if self.monitor.stuck(self.follower.remaining(pose, plan.path)):
            return Command(0.0, 0.0, "stuck")
        return Command(v, w)

    def new_goal(self) -> None:
        """The explorer chose a new goal: progress is measured afresh."""
        self.monitor.reset()
