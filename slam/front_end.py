"""Scan-matching odometry: each scan is registered to a submap of the recent keyframes, starting
from the wheel odometry's prediction (or, when there is no odometry, from a constant-velocity one
and from zero motion)."""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass

import gtsam
import numpy as np
from scipy.stats import chi2

from slam.config import FrontEndConfig
from slam.correlative import CorrelativeGrid
from slam.correlative import match as correlative_match
from slam.registration import Match, Registration, Submap, explains_far_more, transform


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
        #: the recent matches' inlier fractions: what a match leaves unexplained here
        self._recent_inliers: deque = deque(maxlen=self.config.submap_keyframes)
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
            match = self._register(points, guess, (guess, wheel_information) if wheels else None, delta)
            if not match.information.any():          # nothing matched: no evidence from the scan
                match = None
        if match is None:
            pose, information, novelty = guess, wheel_information, 1.0
        else:
            pose, information, novelty = match.pose, match.information, 1.0 - match.inlier_fraction
            self._recent_inliers.append(match.inlier_fraction)
        self._last_delta = self.pose.between(pose)
        self.pose = pose
        self._last_wheel = wheel
        return Tracked(pose, information, match, novelty)

    def prediction_reach(self, points: np.ndarray, delta: gtsam.Pose2) -> float:
        """How far (m) a pose the wheels allow may put the scan's (m, 2) sensor-frame points from
        where the wheels' prediction of ``delta`` puts them.

        An error ξ = (δx, δy, δθ) of the pose moves a point p by (δx − δθ·p_y, δy + δθ·p_x). Over
        the poses within the wheels' χ²(3) gate g (``wheel_gate_probability``) of their
        covariance diag(σ_t², σ_t², σ_θ²), the largest such move of a point at range r is
        √g·√(σ_t² + r²·σ_θ²); r is the scan's median range. A turn makes σ_θ large, and a
        rotation error moves far points most.
        """
        sigma = np.sqrt(np.diag(self.odometry_covariance(delta)))
        r = _median_range(points)
        return float(np.sqrt(chi2.ppf(self.config.wheel_gate_probability, 3) * (sigma[0]**2 + (r * sigma[2])**2)))

    def _start_capture(self) -> float:
        """What the fine start can correct (m): about one voxel of its first KISS-ICP level, or the
        point-to-line gate when it starts past the last level."""
        c = self.config
        sizes = c.registration.voxel_sizes
        return sizes[c.start_level] if c.start_level < len(sizes) else c.registration.max_correspondence

    def _register(self, points: np.ndarray, guess: gtsam.Pose2, prior, delta: gtsam.Pose2) -> Match:
        """Fine levels first (the prediction is usually good). On a good fit where the wheels allow
        poses that move the scan's points by more than the fine levels correct (their predicted
        motion ``delta``'s ``prediction_reach``: a turn of tens of degrees), the full
        coarse-to-fine schedule too (``_wide_start``): a fine start
        can settle in another optimum that still explains most of the scan. On a poor fit, the
        full coarse-to-fine schedule, with and without the odometry prior and from the
        constant-velocity prediction too (wheel odometry can stall or jump); if the fit is still
        poor, the correlative search over metres and tens of degrees around the prediction,
        refined. Whichever explains most points wins (``_explains_more``: one the wheels rule out
        must explain far more, on points that do not all lie on one line: ``_may_overrule``).

        The fine levels' point-to-point steps run without the wheels' prior: on a scan of
        new ground they can wander off it (office_g, turning into a big room: 52° off a 9° turn,
        on 15 of 27 points). A fine match beyond the wheels' gate that explains fewer points
        than a match may rest on (``min_points``), or on points along one line
        (``_may_overrule``), gives way to point-to-line refinement from their prediction, with
        their prior.

        Without wheels the prediction is constant velocity, which nothing vouches for: a robot
        that stops and turns in place (Örebro's log, metres and tens of degrees between scans) is
        not where it predicts. A fit worse than the recent ones (``_fits_worse_than_recent``) is
        then searched as a poor fit is, and every search also starts from zero motion."""
        c = self.config
        match = self.registration.register(points, self._submap, guess, prior, start_level=c.start_level)
        if prior is not None and not self._gated(match.pose, prior) and not (
                match.inlier_fraction * len(points) >= c.registration.min_points
                and self._may_overrule(match, points)):
            # wandered off the wheels' prediction on fewer points than a match may rest on, or
            # on one line, which lies as well along any straight stretch of the submap
            match = self.registration.register(points, self._submap, guess, prior,
                                               start_level=len(c.registration.voxel_sizes))
        unsure = prior is None and self._fits_worse_than_recent(match, len(points))
        if match.inlier_fraction >= c.retry_inlier_fraction and not unsure:
            return self._wide_start(points, guess, prior, delta, match)
        if prior is not None:
            starts = [(guess, prior), (guess, None), (self.pose.compose(self._last_delta), None)]
        else:                                      # constant velocity, and zero motion
            starts = [(guess, None), (self.pose, None)]
        for start, start_prior in starts:
            other = self.registration.register(points, self._submap, start, start_prior)
            if self._explains_more(other, match, prior, points):
                match = other
        if match.inlier_fraction < c.retry_inlier_fraction or unsure:
            window = c.correlative
            if prior is not None:                  # the wheels bound where the scan can be
                sigma = 3.0 / np.sqrt(np.diag(prior[1]))
                window = window.model_copy(update={
                    "window_xy": float(min(max(sigma[:2].max(), c.correlative_min_window[0]), window.window_xy)),
                    "window_deg": float(min(max(np.degrees(sigma[2]), c.correlative_min_window[1]),
                                            window.window_deg))})
            centres = [guess] if prior is not None else [guess, self.pose]
            grid = self._correlative_grid()
            for centre in centres if grid is not None else []:
                self.counts["correlative_searches"] += 1
                found = correlative_match(grid, points, centre, window)
                if found is not None:
                    fine = len(c.registration.voxel_sizes) - 1
                    other = self.registration.register(points, self._submap, found.pose, start_level=fine)
                    if self._explains_more(other, match, prior, points):
                        self.counts["correlative_matches"] += 1
                        match = other
        return match

    def _wide_start(self, points: np.ndarray, guess: gtsam.Pose2, prior, delta: gtsam.Pose2,
                    match: Match) -> Match:
        """The full coarse-to-fine schedule from the wheels' prediction, with their prior, where the
        fine start's ``match`` (a good fit) may have settled in the wrong optimum: the wheels allow
        poses beyond what the fine start corrects (``prediction_reach`` of their predicted motion
        ``delta`` > ``_start_capture``).

        Its match replaces ``match`` only in another optimum (``_separation`` beyond the finest
        voxel: nearer, the two are one optimum as the registration resolves it) that explains far
        more (``explains_far_more``: what a match elsewhere than a plausible one must, leaving at
        most half as many points unexplained), and beyond the wheels' gate only where the scan
        may overrule them (``_may_overrule``). Against one in the same optimum, or explaining only
        a few more points, ``match`` stands: such small differences add up to a drift (the
        Infinite Corridor: a few tenths of a degree a turn). So the schedule runs only where
        ``match`` fits worse than the recent ones (``_fits_worse_than_recent``): elsewhere nothing
        could explain far more.
        """
        c, n = self.config, len(points)
        min_points = c.registration.min_points
        if (prior is None or c.start_level == 0 or not self._fits_worse_than_recent(match, n)
                or self.prediction_reach(points, delta) <= self._start_capture()):
            return match
        self.counts["wide_starts"] += 1
        other = self.registration.register(points, self._submap, guess, prior)
        if (self._separation(points, match.pose, other.pose) > c.registration.voxel_sizes[-1]
                and explains_far_more(other, match, n, min_points)
                and (self._gated(other.pose, prior) or self._may_overrule(other, points))):
            self.counts["wide_start_wins"] += 1
            return other
        return match

    def _fits_worse_than_recent(self, match: Match, n: int) -> bool:
        """Does ``match`` leave at least ``min_points`` of the scan's ``n`` points unexplained, and
        twice the share the recent matches leave (their median: about what the right match
        leaves here)? Elsewhere no other match could explain far more."""
        unexplained = 1.0 - match.inlier_fraction
        recent = 1.0 - float(np.median(self._recent_inliers)) if self._recent_inliers else 0.0
        return unexplained * n >= self.config.registration.min_points and unexplained >= 2.0 * recent

    @staticmethod
    def _separation(points: np.ndarray, a: gtsam.Pose2, b: gtsam.Pose2) -> float:
        """How far (m) pose ``b`` puts a point at the (m, 2) scan's median range r from where ``a``
        puts it, at the farthest: |t| + r·|θ| of a⁻¹b."""
        d = a.between(b)
        return float(np.hypot(d.x(), d.y()) + _median_range(points) * abs(d.theta()))

    def _explains_more(self, other: Match, match: Match, prior, points: np.ndarray) -> bool:
        """Does ``other`` explain more of the scan's (m, 2) ``points`` than ``match``? A pose the
        wheels rule out (beyond their χ²(3) gate at ``wheel_gate_probability``) must explain far
        more (``explains_far_more``: a wheel slip leaves most of the scan unexplained), on points
        that do not all lie on one line (``_may_overrule``)."""
        if other.inlier_fraction <= match.inlier_fraction + 0.02:
            return False
        if prior is None or self._gated(other.pose, prior):
            return True
        return (explains_far_more(other, match, len(points), self.config.registration.min_points)
                and self._may_overrule(other, points))

    def _may_overrule(self, match: Match, points: np.ndarray) -> bool:
        """May ``match``, a pose the wheels rule out, stand against them? Not where the scan's
        (m, 2) ``points`` that the submap explains there lie along one straight line (their
        spread across it, a standard deviation, below half ``inlier_distance``): a line lies
        along any straight stretch of the submap, at any heading. office_g: a robot turning in
        place beside a wall it saw at grazing incidence (0.42 m median range) laid its one-line
        scan on another surface 144° off the wheels (81 % of 103 points explained, against 58 %
        at the wheels' pose, whose wall ran on beyond the submap), and the track never came back
        (ATE 114 m). Two walls fix the heading: where the wheels glitch (CSAIL's scans 1580-1588,
        8-70° off in a corridor) the scan must overrule them."""
        reg = self.config.registration
        dist, _ = self._submap.tree.query(transform(match.pose, points), distance_upper_bound=reg.inlier_distance)
        explained = points[np.isfinite(dist)]
        if len(explained) < 2:
            return False
        across = np.linalg.svd(explained - explained.mean(axis=0), compute_uv=False)[-1] / np.sqrt(len(explained))
        return bool(across >= 0.5 * reg.inlier_distance)

    def _gated(self, pose: gtsam.Pose2, prior) -> bool:
        """Is ``pose`` within the wheels' χ²(3) gate (``wheel_gate_probability``) of their
        ``prior`` (prediction, information)?"""
        error = prior[0].localCoordinates(pose)
        return bool(error @ prior[1] @ error <= chi2.ppf(self.config.wheel_gate_probability, 3))

    def _correlative_grid(self) -> CorrelativeGrid | None:
        """The submap's correlative grid, built when first needed; None when its keyframes
        hold no point."""
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


def _median_range(points: np.ndarray) -> float:
    """The median distance (m) of a scan's (m, 2) sensor-frame points from the sensor."""
    return float(np.median(np.linalg.norm(points, axis=1)))
