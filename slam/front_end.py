"""Scan-matching odometry: each scan is registered to a submap of the recent keyframes, starting
from the wheel odometry's prediction (or a constant-velocity one when there is no odometry)."""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass

import gtsam
import numpy as np
from scipy.stats import chi2

from slam.config import FrontEndConfig
from slam.correlative import CorrelativeGrid
from slam.correlative import match as correlative_match
from slam.registration import Match, Registration, Submap, explains_far_more


@dataclass
class Tracked:
    """The front end's belief after one scan.

    Attributes:
        pose: the scan's pose in the front end's (locally consistent) odometry frame.
        information: (3, 3) of that pose relative to the submap, from the evidence alone: the
            scan match's Hessian, with the wheel odometry's information where the match used it
            (or the wheels' alone when the scan could not be matched); near zero along a
            direction neither observes (a featureless corridor without wheels, no odometry and
            no match), so that a motion prior can be put there explicitly.
        match: the registration, None when the scan could not be matched.
        novelty: share of the scan's points the submap does not explain (1 with no match).
    """

    pose: gtsam.Pose2
    information: np.ndarray
    match: Match | None
    novelty: float


class ScanOdometry:
    """KISS-ICP scan-to-submap odometry with wheel odometry as the initial guess.

    Wheel odometry and scan matching are fused by information in one Gauss–Newton problem (the
    wheels' prediction is a Gaussian prior of the point-to-line refinement): where the scene
    leaves a direction unobservable (a featureless corridor: point-to-point ICP would report no
    motion) the wheels' value and information hold that direction; elsewhere the laser's do.
    """

    def __init__(self, config: FrontEndConfig | None = None):
        self.config = config or FrontEndConfig()
        self.registration = Registration(self.config.registration)
        self.pose: gtsam.Pose2 | None = None
        self._last_wheel: gtsam.Pose2 | None = None
        self._last_delta = gtsam.Pose2()
        self._keyframes: deque = deque(maxlen=self.config.submap_keyframes)
        self._submap: Submap | None = None
        self._grid: CorrelativeGrid | None = None     # the submap's, built when first needed
        #: how often tracking needed the correlative search, and how often it won
        self.counts: Counter = Counter()

    def odometry_covariance(self, delta: gtsam.Pose2) -> np.ndarray:
        """(3, 3) covariance of a wheel-odometry motion ``delta``: σ grows with the motion.

        σ_x = σ_y = a·|t| + b (m),  σ_θ = c·|θ| + d·|t| + e (rad).
        """
        o = self.config.odometry
        t = np.hypot(delta.x(), delta.y())
        sigma_t = o.translation_fraction * t + o.translation_floor
        sigma_r = o.rotation_fraction * abs(delta.theta()) + o.rotation_per_meter * t + o.rotation_floor
        return np.diag([sigma_t**2, sigma_t**2, sigma_r**2])

    def track(self, points: np.ndarray, wheel: gtsam.Pose2 | None) -> Tracked:
        """Register one scan's (m, 2) sensor-frame hit points; ``wheel`` is the raw odometry pose."""
        wheels = wheel is not None and self._last_wheel is not None
        delta = self._last_wheel.between(wheel) if wheels else self._last_delta   # else constant velocity
        if self.pose is None:
            self.pose = wheel if wheel is not None else gtsam.Pose2()
            self._last_wheel = wheel
            return Tracked(self.pose, np.zeros((3, 3)), None, 1.0)
        guess = self.pose.compose(delta)
        wheel_information = np.linalg.inv(self.odometry_covariance(delta)) if wheels else np.zeros((3, 3))
        match = None
        if self._submap is not None and len(points) >= self.config.registration.min_points:
            match = self._register(points, guess, (guess, wheel_information) if wheels else None)
            if not match.information.any():          # nothing matched: no evidence from the scan
                match = None
        if match is None:
            pose, information, novelty = guess, wheel_information, 1.0
        else:
            pose, information, novelty = match.pose, match.information, 1.0 - match.inlier_fraction
        self._last_delta = self.pose.between(pose)
        self.pose = pose
        self._last_wheel = wheel
        return Tracked(pose, information, match, novelty)

    def _register(self, points: np.ndarray, guess: gtsam.Pose2, prior) -> Match:
        """Fine levels first (the prediction is usually good). On a poor fit, the full
        coarse-to-fine schedule, with and without the odometry prior and from the constant-velocity
        prediction too (wheel odometry can stall or jump); if the fit is still poor, the correlative
        search over metres and tens of degrees around the prediction, refined. Whichever explains
        most points wins (``_explains_more``: one the wheels rule out must explain far more)."""
        c = self.config
        match = self.registration.register(points, self._submap, guess, prior, start_level=c.start_level)
        if match.inlier_fraction >= c.retry_inlier_fraction:
            return match
        velocity = self.pose.compose(self._last_delta)
        for start, with_prior in ((guess, True), (guess, False), (velocity, False)):
            if with_prior and prior is None:
                continue
            other = self.registration.register(points, self._submap, start, prior if with_prior else None)
            if self._explains_more(other, match, prior, len(points)):
                match = other
        if match.inlier_fraction < c.retry_inlier_fraction:
            self.counts["correlative_searches"] += 1
            window = c.correlative
            if prior is not None:                  # the wheels bound where the scan can be
                sigma = 3.0 / np.sqrt(np.diag(prior[1]))
                window = window.model_copy(update={
                    "window_xy": float(min(max(sigma[:2].max(), c.correlative_min_window[0]), window.window_xy)),
                    "window_deg": float(min(max(np.degrees(sigma[2]), c.correlative_min_window[1]),
                                            window.window_deg))})
            found = correlative_match(self._correlative_grid(), points, guess, window)
            if found is not None:
                fine = len(c.registration.voxel_sizes) - 1
                other = self.registration.register(points, self._submap, found.pose, start_level=fine)
                if self._explains_more(other, match, prior, len(points)):
                    self.counts["correlative_matches"] += 1
                    match = other
        return match

    def _explains_more(self, other: Match, match: Match, prior, points: int) -> bool:
        """Does ``other`` explain more of the scan, of ``points`` points, than ``match``? A pose
        the wheels rule out (beyond their χ²(3) gate at ``wheel_gate_probability``) must explain
        far more (``explains_far_more``): a wheel slip leaves most of the scan unexplained."""
        if other.inlier_fraction <= match.inlier_fraction + 0.02:
            return False
        if prior is None:
            return True
        error = prior[0].localCoordinates(other.pose)
        if error @ prior[1] @ error <= chi2.ppf(self.config.wheel_gate_probability, 3):
            return True
        return explains_far_more(other, match, points, self.config.registration.min_points)

    def _correlative_grid(self) -> CorrelativeGrid:
        if self._grid is None:
            poses, points, _ = zip(*self._keyframes)
            self._grid = CorrelativeGrid.from_scans(list(poses), list(points), self.config.correlative)
        return self._grid

    def add_keyframe(self, pose: gtsam.Pose2, points: np.ndarray, normals: np.ndarray) -> None:
        """Put a keyframe's scan into the submap (which keeps the most recent ones)."""
        self._keyframes.append((pose, points, normals))
        poses, pts, nrm = zip(*self._keyframes)
        self._submap = Submap.from_scans(list(poses), list(pts), list(nrm), self.config.registration)
        self._grid = None
