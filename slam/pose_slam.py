"""Pose SLAM: scan-matching odometry → informative keyframes → loop closures → iSAM2."""

from __future__ import annotations

from array import array
from collections import Counter

import gtsam
import numpy as np
from scipy.stats import chi2

from slam.back_end import PoseGraph
from slam.config import SlamConfig
from slam.front_end import ScanOdometry
from slam.g2o import write_g2o
from slam.localiser import Localisation
from slam.loop_closure import LoopClosure, LoopClosureDetector, mahalanobis
from slam.registration import scan_normals, transform
from slam.scan import LaserScan


class PoseSlam:
    """The SLAM half of the stack, one ``step(odometry, scan)`` per laser scan.

    Attributes:
        graph: the iSAM2 pose graph of keyframes.
        keyframe_scans: per keyframe, the scan, its sensor-frame points and normals.
        keyframe_stamps: per keyframe, the scan timestamp.
        loops: every accepted loop closure.

    A ``slam.localiser.Localiser``: its ``step`` returns a ``Localisation`` whose ``corrected``
    is True when loops moved keyframes more than ``loop_closure.moved_threshold``.

    Every pose is the robot base's (the odometry's frame); the laser sits at ``laser_offset``
    (the configuration's ``laser_offset``) on the base, so a scan's points enter the base frame
    once, in ``step``, and everything after (front end, keyframes, loop closures) works there.
    """

    def __init__(self, config: SlamConfig | None = None):
        self.config = config or SlamConfig()
        #: the laser's pose in the base frame: a scan is taken at pose ∘ laser_offset
        self.laser_offset = self.config.laser_mount()
        self.front_end = ScanOdometry(self.config.front_end)
        self.graph = PoseGraph(self.config.back_end)
        self.detector = LoopClosureDetector(self.config.loop_closure, self.config.front_end.registration)
        self.keyframe_scans: list[LaserScan] = []
        self.keyframe_stamps: list[float] = []
        self._features: list[tuple[np.ndarray, np.ndarray]] = []
        self._keyframe_front_pose: list[gtsam.Pose2] = []
        self.scan_anchor: list[tuple[int, gtsam.Pose2]] = []
        # scan_anchor's keyframes and offsets' x, y (m) again, as flat arrays for ``positions``
        self._anchors = array("q")
        self._offsets = array("d")
        self.scan_stamps: list[float] = []
        self.loops: list[LoopClosure] = []
        self._pending: list[LoopClosure] = []  # verified loops beyond the Mahalanobis gate
        #: what the system did instead of the normal path, by kind (reported in metrics.json)
        self.fallbacks: Counter = Counter()
        #: loop candidates proposed by the gates and verified by registration
        self.loop_counts: Counter = Counter()
        #: the largest keyframe displacement a loop closure caused (m)
        self.largest_correction = 0.0
        #: front-end matches that could not observe some direction (a featureless corridor)
        self.degenerate_matches = 0

    def step(self, odometry: gtsam.Pose2 | None, scan: LaserScan,
             given: gtsam.Pose2 | None = None) -> Localisation:
        """Track the scan, make it a keyframe if it is informative, then close loops from it
        (``given``, a known pose, is not used: Pose SLAM localises by itself)."""
        points = scan.points()
        normals = scan_normals(points, self.config.front_end.registration)
        if any(self.config.laser_offset):                    # sensor frame → base frame
            points = transform(self.laser_offset, points)
            normals = transform(gtsam.Pose2(0.0, 0.0, self.laser_offset.theta()), normals)
        tracked = self.front_end.track(points, odometry)
        self.degenerate_matches += tracked.match is not None and len(tracked.match.degenerate) > 0
        keyframe = None
        if not self._keyframe_front_pose:
            keyframe = self.graph.add_first(tracked.pose)
        elif self._is_informative(tracked):
            link = self._keyframe_front_pose[-1].between(tracked.pose)
            keyframe = self.graph.add_keyframe(link, self._link_covariance(tracked.information))
        if keyframe is not None:
            self._keyframe_front_pose.append(tracked.pose)
            self.keyframe_scans.append(scan)
            self.keyframe_stamps.append(scan.timestamp)
            self._features.append((points, normals))
            self.front_end.add_keyframe(tracked.pose, points, normals)
        anchor = len(self._keyframe_front_pose) - 1
        offset = self._keyframe_front_pose[anchor].between(tracked.pose)
        self.scan_anchor.append((anchor, offset))
        self._anchors.append(anchor)
        self._offsets.extend((offset.x(), offset.y()))
        self.scan_stamps.append(scan.timestamp)
        result = Localisation(self.pose(len(self.scan_anchor) - 1), keyframe)
        if keyframe is not None and self.config.loop_closure.enabled:
            self._close_loops(keyframe, result)
        return result

    def _link_covariance(self, information: np.ndarray) -> np.ndarray:
        """(3, 3) covariance of a keyframe link from the front end's ``information``, halved (the
        submap it was matched to is uncertain too), plus the motion prior, which constrains any
        direction neither the scan nor the wheels observed: the link always has full rank. A link
        whose evidence is weaker than the prior in some direction is counted as a fallback."""
        c = self.config.keyframes
        prior = np.diag(1.0 / np.square(c.motion_prior_sigma))
        evidence = 0.5 * information
        scale = np.asarray(c.motion_prior_sigma)
        if np.linalg.eigvalsh(scale[:, None] * evidence * scale[None, :]).min() < 1.0:
            self.fallbacks["motion_prior_links"] += 1
        return np.linalg.inv(evidence + prior) + np.diag(np.square(c.between_sigma_floor))

    def _is_informative(self, tracked) -> bool:
        """A keyframe when the robot moved enough or the scan sees enough that the submap lacks."""
        c = self.config.keyframes
        delta = self._keyframe_front_pose[-1].between(tracked.pose)
        return (np.hypot(delta.x(), delta.y()) >= c.min_translation
                or abs(delta.theta()) >= np.radians(c.min_rotation_deg)
                or (tracked.match is not None and tracked.novelty >= c.min_novelty))

    def _close_loops(self, k: int, result: Localisation) -> None:
        c = self.config.loop_closure
        floor = np.diag(np.square(c.sigma_floor))
        self._pending = [p for p in self._pending if p.candidate.k >= k - c.pair_window]
        for candidate in self.detector.candidates(self.graph, k):
            self.loop_counts["proposed"] += 1
            loop = self.detector.verify(candidate, self.graph, self._features)
            if loop is None:
                continue
            self.loop_counts["verified"] += 1
            if loop.mahalanobis > c.mahalanobis_reject and not self._fits_the_links(loop):
                self.detector.rejected["mahalanobis"] += 1
                continue
            if loop.mahalanobis <= c.mahalanobis_gate and not loop.searched:
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
                if moved is None:                  # the solver could not take it: left out
                    continue
                self.loops.append(accept)
                result.loops.append(accept)
                result.moved = max(result.moved, moved)
                self.largest_correction = max(self.largest_correction, moved)
        if result.loops:
            self._check_consistency(result)
        if result.loops or result.withdrawn:
            result.pose = self.pose(len(self.scan_anchor) - 1)
            result.corrected = result.moved > c.moved_threshold

    def _fits_the_links(self, loop: LoopClosure) -> bool:
        """Is ``loop`` within ``mahalanobis_gate`` of what the keyframe links alone, without any
        loop closure, predict between its keyframes? A loop far beyond the graph's prediction
        (``mahalanobis_reject``) is either one a false loop put there, by bending the graph
        (lab_f_scan: true loops at d² 490-1310, within 1 cm of the truth and of what the links
        say), or an alias: periodic aliases along a corridor come in consistent pairs (office_a:
        loops 2.3 m along its top corridor, d² 169-191 against the links)."""
        predicted, covariance = self.graph.chained(loop.candidate.j, loop.candidate.k)
        return mahalanobis(predicted, covariance, loop.match) <= self.config.loop_closure.mahalanobis_gate

    def _check_consistency(self, result: Localisation) -> None:
        """The consistency layer over every accepted loop: when a loop disagrees with the map
        after optimisation (its residual beyond the χ²(3) quantile at ``consistency_probability``),
        graduated non-convexity over all loops decides which are outliers; they leave the graph
        (counted as rejected by "consistency"), so a false loop cannot hold the map bent. Those
        accepted at earlier scans are ``withdrawn``: a map relearnt under them must be relearnt."""
        c = self.config.loop_closure
        residuals = self.graph.loop_residuals()
        if residuals.size == 0 or residuals.max() <= chi2.ppf(c.consistency_probability, 3):
            return
        loop_edges = [k for k, edge in enumerate(self.graph.edges) if edge[4]]
        outliers = self.graph.outlier_loops(c.consistency_probability)
        if not outliers:
            return
        before = self.graph.positions()
        self.graph.remove_edges(outliers, c.extra_updates)
        out = {loop_edges.index(k) for k in outliers}
        dropped = {id(loop) for m, loop in enumerate(self.loops) if m in out}
        self.loops = [loop for m, loop in enumerate(self.loops) if m not in out]
        result.withdrawn += len(dropped - {id(loop) for loop in result.loops})
        result.loops = [loop for loop in result.loops if id(loop) not in dropped]
        self.detector.rejected["consistency"] += len(outliers)
        moved = float(np.max(np.linalg.norm(self.graph.positions() - before, axis=1)))
        result.moved = max(result.moved, moved)

    def pose(self, i: int) -> gtsam.Pose2:
        """Scan i's current SLAM pose."""
        anchor, offset = self.scan_anchor[i]
        return self.graph.pose(anchor).compose(offset)

    def positions(self, indices: np.ndarray) -> np.ndarray:
        """(k, 2) x, y (m) of scans ``indices`` (k,) int from the current graph, all at once:
        each scan's offset rotated and moved by its keyframe's estimate, as ``pose`` composes
        them. The rotation is the cosine and sine of the keyframe's angle, where gtsam rotates
        by those it stores: a scan between keyframes may land a last bit (1e-15 m) away from
        ``pose``'s position; a keyframe's own scan (offset zero) lands exactly on it."""
        # np.take copies: no view is left holding the buffers, which ``step`` keeps extending
        anchors = np.take(np.frombuffer(self._anchors, np.int64), indices)
        offsets = np.take(np.frombuffer(self._offsets).reshape(-1, 2), indices, axis=0)
        x, y, theta = self.graph.xytheta()[anchors].T
        c, s = np.cos(theta), np.sin(theta)
        return np.column_stack([x + (c * offsets[:, 0] - s * offsets[:, 1]),
                                y + (s * offsets[:, 0] + c * offsets[:, 1])])

    def trajectory(self) -> list[gtsam.Pose2]:
        """Every scan's pose from the current graph."""
        poses = self.graph.poses()
        return [poses[a].compose(o) for a, o in self.scan_anchor]

    def keyframe_poses(self) -> list[gtsam.Pose2]:
        return self.graph.poses()

    def loop_pairs(self) -> np.ndarray:
        """(m, 2) int: the keyframes (j, k) each accepted loop joins."""
        return np.array([[loop.candidate.j, loop.candidate.k] for loop in self.loops], int).reshape(-1, 2)

    def write_g2o(self, path) -> None:
        """The keyframe graph as g2o: optimised poses, odometry and loop edges (information)."""
        edges = [(i, j, z, np.linalg.inv(cov)) for i, j, z, cov, _ in self.graph.edges]
        write_g2o(path, dict(enumerate(self.keyframe_poses())), edges)
