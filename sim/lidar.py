"""Simulated planar laser range finder with Gaussian range noise and random dropouts."""

from __future__ import annotations

from typing import Literal

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from sim.raycast import cast_rays
from sim.world import World
from slam.scan import LaserScan, fov_angles


class LidarConfig(BaseModel):
    """A 2-D laser scanner. Defaults: the Stage-like SICK of the standard benchmark setup."""

    model_config = ConfigDict(extra="forbid")

    beams: int = Field(361, ge=1, description="number of beams")
    fov_deg: float = Field(180.0, gt=0, le=360, description="field of view, degrees")
    max_range: float = Field(8.0, gt=0, description="meters; no return beyond")
    range_sigma: float = Field(0.01, ge=0, description="Gaussian range noise, meters")
    dropout: float = Field(0.0, ge=0, le=1, description="probability a beam returns nothing")
    dropout_value: Literal["max_range", "nan"] = Field(
        "max_range", description="what a dropped beam reads: max range (no return) or NaN"
    )
    rate_hz: float = Field(10.0, gt=0, description="scans per second")


class Lidar:
    """Casts a scan from the true world at a pose; every random draw comes from ``seed``."""

    def __init__(self, config: LidarConfig | None = None, seed: int | None = 0):
        self.config = config or LidarConfig()
        c = self.config
        fov = np.deg2rad(c.fov_deg)
        # a full circle must not repeat its first beam at the end
        self.angles = fov_angles(c.beams, fov, include_end=c.fov_deg < 360)
        self.rng = np.random.default_rng(seed)

    def scan(self, world: World, pose: gtsam.Pose2, timestamp: float = 0.0) -> LaserScan:
        """Measure the world from ``pose`` (the sensor's pose in the world frame).

        True hits get N(0, range_sigma²) noise; beams with no obstacle within range, and
        noisy readings at or past it, read ``max_range``; dropped beams read ``max_range`` or
        NaN. Negative noisy ranges are clipped to 0.
        """
        c = self.config
        true = cast_rays(world, (pose.x(), pose.y()), pose.theta() + self.angles, c.max_range)
        ranges = np.maximum(true + self.rng.normal(0.0, c.range_sigma, true.shape), 0.0)
        ranges[~(ranges < c.max_range)] = c.max_range
        dropped = self.rng.random(true.shape) < c.dropout
        ranges[dropped] = c.max_range if c.dropout_value == "max_range" else np.nan
        return LaserScan(ranges, self.angles, c.max_range, timestamp)
