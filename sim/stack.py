"""The whole stack as one object: (odometry, scan) in; poses, map and goal out (Algorithm 1).

A simulated run and a log replay use it the same way; they differ only in where scans come from
and whether anything moves the robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from exploration.explorer import Explorer, ExplorerConfig, Plan
from mapping.com import ContinuousOccupancyMap
from mapping.config import COMConfig
from mapping.logodds import LogOddsConfig, LogOddsGrid
from slam.config import KeyframeConfig, SlamConfig
from slam.pose_slam import PoseSlam
from slam.scan import LaserScan


class StackConfig(BaseModel):
    """Everything the stack needs, grouped the way the code is grouped."""

    model_config = ConfigDict(extra="forbid")

    poses: Literal["slam", "truth"] = Field("slam", description="Pose SLAM, or ground truth "
                                            "(perfect localisation, for ablations)")
    slam: SlamConfig = SlamConfig()
    com: COMConfig = COMConfig()
    grid: LogOddsConfig = Field(
        LogOddsConfig(resolution=0.2, l_occ=2.5, l_free=-0.85, max_range=8.0),
        description="the baseline's grid: 0.2 m cells as in the paper's Fig. 6; one free "
        "observation makes a cell free, a hit outweighs two free passes")
    explorer: ExplorerConfig = ExplorerConfig()
    plan_every: int = Field(3, ge=1, description="re-check the goal every this many keyframes")


@dataclass
class StackStep:
    """What one scan did to the stack."""

    pose: gtsam.Pose2
    keyframe: int | None = None
    loops: int = 0
    regenerated: bool = False
    plan: Plan | None = None


@dataclass
class _Keyframes:
    """Keyframes by ground truth: a pose enters when it moved enough (``poses="truth"``)."""

    config: KeyframeConfig
    poses: list[gtsam.Pose2] = field(default_factory=list)
    scans: list[LaserScan] = field(default_factory=list)

    def offer(self, pose: gtsam.Pose2, scan: LaserScan) -> int | None:
        if self.poses:
            delta = self.poses[-1].between(pose)
            if (np.hypot(delta.x(), delta.y()) < self.config.min_translation
                    and abs(delta.theta()) < np.radians(self.config.min_rotation_deg)):
                return None
        self.poses.append(pose)
        self.scans.append(scan)
        return len(self.poses) - 1


class Stack:
    """Pose SLAM → map (COM, or a log-odds grid for the baseline) → explorer, one scan at a time."""

    def __init__(self, config: StackConfig | None = None, seed: int = 0):
        self.config = config or StackConfig()
        c = self.config
        self.slam = PoseSlam(c.slam) if c.poses == "slam" else None
        self._truth_keyframes = _Keyframes(c.slam.keyframes)
        self.map = self._new_map()
        self.explorer = Explorer(c.explorer, seed=seed)
        self.plan: Plan | None = None
        self.regenerations = 0
        self._since_plan = 0

    @property
    def method(self) -> str:
        return self.config.explorer.method

    def step(self, odometry: gtsam.Pose2 | None, scan: LaserScan,
             truth: gtsam.Pose2 | None = None, replan: bool = False) -> StackStep:
        """One scan: localise; on a keyframe, update the map (and regenerate it when a SLAM
        correction made it drift); then re-plan when a goal is needed.

        Args:
            odometry: the wheel odometry pose (None when there is none).
            scan: the laser scan.
            truth: the true pose, used only when ``poses="truth"``.
            replan: ask the explorer for a goal now (the goal was reached or abandoned).
        """
        if self.slam is not None:
            result = self.slam.step(odometry, scan)
            out = StackStep(result.pose, result.keyframe, len(result.loops))
            corrected = result.corrected
        else:
            if truth is None:
                raise ValueError("Stack with poses='truth' needs the true pose at every step")
            out = StackStep(truth, self._truth_keyframes.offer(truth, scan))
            corrected = False
        if out.keyframe is not None:
            self.map.update(self.keyframe_poses()[out.keyframe], scan)
            if corrected and self._drifted():
                self.regenerate()
                out.regenerated = True
            self._since_plan += 1
        if replan or self.plan is None or (out.keyframe is not None
                                           and self._since_plan >= self.config.plan_every):
            out.plan = self.replan(out.pose)
        return out

    def replan(self, pose: gtsam.Pose2) -> Plan:
        """Ask the explorer where to go from ``pose`` on the current map."""
        self._since_plan = 0
        prob = self.map.prob()
        prob_occ = self.map.prob_occ() if self.method == "gp" else None
        self.plan = self.explorer.plan(prob, prob_occ, self.map.origin, self.map_resolution, pose)
        return self.plan

    def regenerate(self) -> None:
        """Relearn the map from every keyframe at its corrected pose (Section VII)."""
        keyframes = list(zip(self.keyframe_poses(), self.keyframe_scans()))
        if self.method == "gp":
            self.map.regenerate(keyframes)
        else:
            self.map = self._new_map()
            for pose, scan in keyframes:
                self.map.update(pose, scan)
        self.regenerations += 1

    def keyframe_poses(self) -> list[gtsam.Pose2]:
        return self.slam.keyframe_poses() if self.slam is not None else self._truth_keyframes.poses

    def loop_segments(self) -> np.ndarray:
        """(m, 2, 2) the loop closures as segments between their keyframes' current estimates
        (none without SLAM)."""
        if self.slam is None or not self.slam.loops:
            return np.zeros((0, 2, 2))
        xy = np.array([[p.x(), p.y()] for p in self.keyframe_poses()])
        return xy[[[loop.candidate.j, loop.candidate.k] for loop in self.slam.loops]]

    def keyframe_scans(self) -> list[LaserScan]:
        return self.slam.keyframe_scans if self.slam is not None else self._truth_keyframes.scans

    @property
    def map_resolution(self) -> float:
        return self.map.frame.resolution

    def _drifted(self) -> bool:
        """Did the map drift past its threshold (Jensen–Shannon, eqs. 12–13)? The log-odds grid
        has no drift measure: it is rebuilt on every correction."""
        return self.map.needs_regeneration if self.method == "gp" else True

    def _new_map(self):
        if self.method == "gp":
            return ContinuousOccupancyMap(self.config.com)
        return LogOddsGrid(self.config.grid)
