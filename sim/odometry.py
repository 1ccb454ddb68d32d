"""Wheel odometry with the standard proportional noise model (Thrun et al., Probabilistic Robotics 5.4)."""

from __future__ import annotations

import math

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field


class OdometryNoise(BaseModel):
    """Wheel odometry noise, growing with the motion (Probabilistic Robotics 5.4).

    Each relative motion is split into rot1, trans, rot2 and

    var(rot)   = alpha1·rot² + alpha2·trans²   (rad²)
    var(trans) = alpha3·trans² + alpha4·(rot1² + rot2²)   (m²)

    so the standard deviations are a few percent of the motion by default.
    """

    model_config = ConfigDict(extra="forbid")

    alpha1: float = Field(0.0025, ge=0, description="rotation noise from rotation (0.05²)")
    alpha2: float = Field(0.0025, ge=0, description="rotation noise from translation (rad²/m², 0.05²)")
    alpha3: float = Field(0.0025, ge=0, description="translation noise from translation (0.05²)")
    alpha4: float = Field(0.0001, ge=0, description="translation noise from rotation (m²/rad², 0.01²)")


class Odometry:
    """A wheel encoder: integrates noisy relative motions into an odometry pose that drifts.

    ``pose`` starts at ``start`` (the odometry frame's origin, by default identity) and is
    what a robot's odometry topic reports.
    """

    def __init__(self, noise: OdometryNoise | None = None, seed: int | None = 0,
                 start: gtsam.Pose2 | None = None):
        self.noise = noise or OdometryNoise()
        self.rng = np.random.default_rng(seed)
        self.pose = start if start is not None else gtsam.Pose2()

    def sample(self, motion: gtsam.Pose2) -> gtsam.Pose2:
        """A noisy measurement of the true relative motion ``motion`` (in the previous frame)."""
        a = self.noise
        trans = math.hypot(motion.x(), motion.y())
        rot1 = math.atan2(motion.y(), motion.x()) if trans > 1e-9 else 0.0
        rot2 = gtsam.Rot2(motion.theta() - rot1).theta()
        sd_rot1 = math.sqrt(a.alpha1 * rot1**2 + a.alpha2 * trans**2)
        sd_trans = math.sqrt(a.alpha3 * trans**2 + a.alpha4 * (rot1**2 + rot2**2))
        sd_rot2 = math.sqrt(a.alpha1 * rot2**2 + a.alpha2 * trans**2)
        n1, nt, n2 = self.rng.normal(0.0, 1.0, 3)
        rot1 += sd_rot1 * n1
        trans += sd_trans * nt
        rot2 += sd_rot2 * n2
        return gtsam.Pose2(trans * math.cos(rot1), trans * math.sin(rot1), rot1 + rot2)

    def update(self, motion: gtsam.Pose2) -> gtsam.Pose2:
        """Integrate the true relative motion ``motion``; returns the new odometry pose."""
        self.pose = self.pose.compose(self.sample(motion))
        return self.pose
