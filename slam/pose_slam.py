"""Pose SLAM: scan-matching odometry → informative keyframes → loop closures → iSAM2."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import gtsam
import numpy as np

from slam.back_end import PoseGraph
from slam.config import SlamConfig
from slam.front_end import ScanOdometry
from slam.g2o import write_g2o
from slam.loop_closure import LoopClosure, LoopClosureDetector
from slam.registration import scan_normals
from slam.scan import LaserScan


@dataclass
class StepResult:
    """What one scan did.

    Attributes:
        pose: the scan's current SLAM pose (keyframe estimate ∘ front-end offset).
        keyframe: the keyframe index if the scan became one, else None.
        loops: loop closures accepted at this scan.
        moved: largest keyframe displacement (m) caused by those loops.
        corrected: True when loops moved keyframes more than ``moved_threshold`` (the mapping
            layer regenerates its map on this event).
    """

    pose: gtsam.Pose2
    keyframe: int | None = None
    loops: list[LoopClosure] = field(default_factory=list)
    moved: float = 0.0
    corrected: bool = False


class PoseSlam:
    """The SLAM half of the stack, one ``step(odometry, scan)`` per laser scan.

    Attributes:
        graph: the iSAM2 pose graph of keyframes.
        keyframe_scans: per keyframe, the scan, its sensor-frame points and normals.
        keyframe_stamps: per keyframe, the scan timestamp.
        loops: every accepted loop closure.
        on_correction: callables ``f(result)`` run when loops moved the keyframes.
    """

    def __init__(self, config: SlamConfig | None = None):
        self.config = config or SlamConfig()
        self.front_end = ScanOdometry(self.config.front_end)
        self.graph = PoseGraph(self.config.back_end)
        self.detector = LoopClosureDetector(self.config.loop_closure, self.config.front_end.registration)
        self.keyframe_scans: list[LaserScan] = []
        self.keyframe_stamps: list[float] = []
        self._features: list[tuple[np.ndarray, np.ndarray]] = []
        self._keyframe_front_pose: list[gtsam.Pose2] = []
        self.scan_anchor: list[tuple[int, gtsam.Pose2]] = []
        self.scan_stamps: list[float] = []
        self.loops: list[LoopClosure] = []
        self._pending: list[LoopClosure] = []  # verified loops beyond the Mahalanobis gate
        self.on_correction: list[Callable[[StepResult], None]] = []

    def step(self, odometry: gtsam.Pose2 | None, scan: LaserScan) -> StepResult:
        """Track the scan, make it a keyframe if it is informative, then close loops from it."""
        points = scan.points()
        normals = scan_normals(points, self.config.front_end.registration.normal_max_gap)
        tracked = self.front_end.track(points, odometry)
        keyframe = None
        if not self._keyframe_front_pose:
            keyframe = self.graph.add_first(tracked.pose)
        elif self._is_informative(tracked):
            link = self._keyframe_front_pose[-1].between(tracked.pose)
            floor = np.diag(np.square(self.config.keyframes.between_sigma_floor))
            keyframe = self.graph.add_keyframe(link, 2.0 * tracked.covariance + floor)
        if keyframe is not None:
            self._keyframe_front_pose.append(tracked.pose)
            self.keyframe_scans.append(scan)
            self.keyframe_stamps.append(scan.timestamp)
            self._features.append((points, normals))
            self.front_end.add_keyframe(tracked.pose, points, normals)
        anchor = len(self._keyframe_front_pose) - 1
        self.scan_anchor.append((anchor, self._keyframe_front_pose[anchor].between(tracked.pose)))
        self.scan_stamps.append(scan.timestamp)
        result = StepResult(self.pose(len(self.scan_anchor) - 1), keyframe)
        if keyframe is not None and self.config.loop_closure.enabled:
            self._close_loops(keyframe, result)
        return result

    def _is_informative(self, tracked) -> bool:
        """A keyframe when the robot moved enough or the scan sees enough that the submap lacks."""
        c = self.config.keyframes
        delta = self._keyframe_front_pose[-1].between(tracked.pose)
        return (np.hypot(delta.x(), delta.y()) >= c.min_translation
                or abs(delta.theta()) >= np.radians(c.min_rotation_deg)
                or (tracked.match is not None and tracked.novelty >= c.min_novelty))

    def _close_loops(self, k: int, result: StepResult) -> None:
        c = self.config.loop_closure
        floor = np.diag(np.square(c.sigma_floor))
        self._pending = [p for p in self._pending if p.candidate.k >= k - c.pair_window]
        for candidate in self.detector.candidates(self.graph, k):
            loop = self.detector.verify(candidate, self.graph, self._features)
            if loop is None:
                continue
            if loop.mahalanobis > c.mahalanobis_reject:
                self.detector.rejected["mahalanobis"] += 1
                continue
            if loop.mahalanobis <= c.mahalanobis_gate:
                accepted = [loop]
            else:
                partners = [p for p in self._pending if self.detector.consistent(p, loop, self.graph)]
                if not partners:
                    self._pending.append(loop)
                    self.detector.rejected["pending"] += 1
                    continue
                accepted = partners + [loop]
                self._pending = [p for p in self._pending if p not in partners]
            for accept in accepted:
                covariance = accept.match.covariance + floor
                moved = self.graph.add_loop(accept.candidate.j, accept.candidate.k, accept.match.pose,
                                            covariance, c.cauchy_k, c.extra_updates)
                self.loops.append(accept)
                result.loops.append(accept)
                result.moved = max(result.moved, moved)
        if result.loops:
            result.pose = self.pose(len(self.scan_anchor) - 1)
            result.corrected = result.moved > c.moved_threshold
            if result.corrected:
                for callback in self.on_correction:
                    callback(result)

    def pose(self, i: int) -> gtsam.Pose2:
        """Scan i's current SLAM pose."""
        anchor, offset = self.scan_anchor[i]
        return self.graph.pose(anchor).compose(offset)

    def trajectory(self) -> list[gtsam.Pose2]:
        """Every scan's pose from the current graph."""
        poses = self.graph.poses()
        return [poses[a].compose(o) for a, o in self.scan_anchor]

    def keyframe_poses(self) -> list[gtsam.Pose2]:
        return self.graph.poses()

    def write_g2o(self, path) -> None:
        """The keyframe graph as g2o: optimised poses, odometry and loop edges (information)."""
        edges = [(i, j, z, np.linalg.inv(cov)) for i, j, z, cov, _ in self.graph.edges]
        write_g2o(path, dict(enumerate(self.keyframe_poses())), edges)
