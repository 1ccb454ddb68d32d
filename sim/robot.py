"""A unicycle robot moving on the true map, with limits and collision checking."""

from __future__ import annotations

import math

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from sim.world import World


class RobotConfig(BaseModel):
    """A Pioneer-like disc robot (the standard benchmark setup)."""

    model_config = ConfigDict(extra="forbid")

    radius: float = Field(0.25, gt=0, description="meters")
    max_speed: float = Field(0.5, gt=0, description="m/s")
    max_turn_rate: float = Field(math.pi / 2, gt=0, description="rad/s")


class Robot:
    """A unicycle: forward speed v (m/s) and turn rate w (rad/s), both clamped to the limits.

    ``move`` integrates the motion exactly (an arc) and refuses it, counting a collision, if
    the disc would overlap an occupied cell anywhere along the way.
    """

    def __init__(self, world: World, pose: gtsam.Pose2, config: RobotConfig | None = None):
        self.world = world
        self.config = config or RobotConfig()
        if world.collides((pose.x(), pose.y()), self.config.radius):
            raise ValueError(
                f"{world.name}: start pose ({pose.x():.3f}, {pose.y():.3f}) collides with the map "
                f"for a robot of radius {self.config.radius} m"
            )
        self.pose = pose
        self.collisions = 0
        self.distance = 0.0

    def move(self, v: float, w: float, dt: float) -> gtsam.Pose2:
        """Drive for ``dt`` seconds; returns the relative motion done (identity if refused)."""
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        c = self.config
        v = float(np.clip(v, -c.max_speed, c.max_speed))
        w = float(np.clip(w, -c.max_turn_rate, c.max_turn_rate))
        # sub-steps no longer than a quarter of a cell, so the swept disc is checked densely
        step = 0.25 * min(self.world.resolution)
        n = max(1, math.ceil(abs(v) * dt / step))
        for k in range(1, n + 1):
            p = self.pose.compose(arc(v, w, dt * k / n))
            if self.world.collides((p.x(), p.y()), c.radius):
                self.collisions += 1
                return gtsam.Pose2()
        motion = arc(v, w, dt)
        self.pose = self.pose.compose(motion)
        self.distance += abs(v) * dt
        return motion


def arc(v: float, w: float, dt: float) -> gtsam.Pose2:
    """The relative pose after driving at (v, w) for dt seconds from the identity."""
    theta = w * dt
    if abs(theta) < 1e-9:
        return gtsam.Pose2(v * dt, 0.0, theta)
    r = v / w
    return gtsam.Pose2(r * math.sin(theta), r * (1 - math.cos(theta)), theta)
