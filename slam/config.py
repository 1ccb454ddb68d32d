"""Typed configuration of Pose SLAM, grouped the way the code is grouped; defaults work on
the MIT CSAIL log and on the simulator's 8 m / 180° Stage-like laser."""

from __future__ import annotations

import warnings

import gtsam
from pydantic import BaseModel, ConfigDict, Field, FiniteFloat, PositiveFloat, model_validator


class _Config(BaseModel):
    model_config = ConfigDict(extra="forbid")


class RegistrationConfig(_Config):
    """Scan matching: KISS-ICP coarse-to-fine, then point-to-line refinement."""

    voxel_sizes: list[float] = Field([1.0, 0.5, 0.2, 0.1], min_length=1,
                                     description="KISS-ICP voxel sizes (m), coarse to fine")
    max_points_per_voxel: int = Field(20, ge=1, description="KISS-ICP map points kept per voxel")
    icp_iterations: int = Field(100, ge=1, description="KISS-ICP iterations per voxel level")
    icp_convergence: float = Field(1e-4, gt=0, description="KISS-ICP stops below this step")
    refine_iterations: int = Field(3, ge=0, description="point-to-line Gauss-Newton iterations")
    convergence: float = Field(1e-4, gt=0, description="stop when a step is below this (m, rad)")
    max_correspondence: float = Field(0.3, gt=0, description="point-to-line gate (m)")
    inlier_distance: float = Field(0.1, gt=0, description="a point within this of the map is an inlier (m)")
    normal_max_gap: float = Field(0.3, gt=0, description="neighbouring beams farther apart give no normal (m)")
    normal_min_incidence_deg: float = Field(
        5.0, ge=0, lt=90, description="when above 0 (λ, deg), neighbouring beams Δφ apart may also be "
        "farther apart by r·sin Δφ / sin(λ − Δφ), their spacing on a surface seen at incidence λ from "
        "range r (an adaptive breakpoint, Borges & Aldon 2004): walls seen obliquely far down a "
        "corridor keep their normals and observe the heading (the Infinite Corridor log: 43 m "
        "from GMapping with 0, 0.71 m with 5); 0: the fixed normal_max_gap alone")
    normal_radius: float = Field(0.15, ge=0, description="a normal is the line fitted to the hits "
                                 "within this of a point along its surface, at least ±2 beams (m)")
    min_sigma: float = Field(0.01, gt=0, description="floor of the residual standard deviation (m)")
    degenerate_eigenvalue: float = Field(0.03, ge=0, le=0.5,
                                         description="translation directions whose normalised point-to-line "
                                                     "information is below this are degenerate")
    min_points: int = Field(20, ge=3, description="fewer hit points: no scan matching")


class CorrelativeConfig(_Config):
    """Correlative scan matching: the likelihood grid, the search window, and acceptance."""

    resolution: float = Field(0.05, gt=0, description="cell size of the likelihood grid and the "
                                                      "translation step of the search (m)")
    likelihood_sigma: float = Field(0.075, gt=0, description="σ of the likelihood field exp(-d²/2σ²), d the "
                                                             "distance to the nearest reference point (m)")
    levels: int = Field(6, ge=1, le=12, description="precomputation grids: level h bounds blocks of 2^h × 2^h "
                                                    "cells, the coarsest 2^(levels-1) cells (count)")
    window_xy: float = Field(2.0, ge=0, description="translations searched: ± this around the guess, "
                                                    "along x and along y (m)")
    window_deg: float = Field(30.0, ge=0, le=180, description="rotations searched: ± this around the "
                                                              "guess (deg)")
    min_score: float = Field(0.5, ge=0, le=1, description="mean likelihood per point below which the "
                                                          "match is rejected (unitless, in [0, 1])")
    max_points: int = Field(400, ge=1, description="more scan points than this are thinned by an "
                                                   "adaptive voxel filter (count)")
    max_range: float = Field(30.0, gt=0, description="scan points farther from the sensor are dropped; "
                                                     "the farthest kept sets the angular step (m)")
    min_points: int = Field(20, ge=1, description="fewer scan points than this: no match (count)")
    covariance_cells: int = Field(3, ge=1, description="half-width of the neighbourhood of the optimum "
                                                       "whose score surface gives the covariance, in "
                                                       "cells and in angular steps (count)")


class OdometryModel(_Config):
    """How much the wheel odometry's prediction is trusted (its σ grows with the motion)."""

    translation_fraction: float = Field(0.02, gt=0, description="σ_xy per metre moved")
    translation_floor: float = Field(0.002, gt=0, description="m")
    rotation_fraction: float = Field(0.1, gt=0, description="σ_θ per radian turned")
    rotation_per_meter: float = Field(0.05, ge=0, description="σ_θ per metre moved (rad/m)")
    rotation_floor: float = Field(0.005, gt=0, description="rad")


class FrontEndConfig(_Config):
    """Scan-to-submap odometry."""

    registration: RegistrationConfig = RegistrationConfig()
    start_level: int = Field(2, ge=0, description="first KISS-ICP voxel level when tracking; past the last "
                                                   "level, only the point-to-line refinement runs (the "
                                                   "prediction is good; the full schedule runs on a poor fit, "
                                                   "and also where a pose within the wheels' χ²(3) gate at "
                                                   "wheel_gate_probability moves a point at the scan's median "
                                                   "range by more than this level's voxel, which is about what "
                                                   "it corrects: a turn of tens of degrees; its match wins "
                                                   "there only in another optimum explaining far more)")
    retry_inlier_fraction: float = Field(0.7, ge=0, le=1,
                                         description="below this, track again from the coarsest level")
    wheel_gate_probability: float = Field(0.999, gt=0, lt=1, description="a retried match beyond the χ²(3) "
                                          "quantile at this probability of the wheels' prediction replaces a "
                                          "nearer one only if it leaves at most half as many points unexplained")
    submap_keyframes: int = Field(10, ge=1, description="recent keyframes in the local submap")
    odometry: OdometryModel = OdometryModel()
    correlative: CorrelativeConfig = Field(
        CorrelativeConfig(window_xy=3.0, window_deg=60.0),
        description="the search when tracking still fits poorly after the KISS-ICP retries: from the "
        "prediction, ± 3 m and ± 60 degrees without wheel odometry; with it, 3 σ of the wheels' "
        "prediction, at least correlative_min_window (an alias metres away must not beat the wheels)")
    correlative_min_window: list[PositiveFloat] = Field(
        [0.3, 15.0], min_length=2, max_length=2,
        description="smallest correlative window with wheel odometry: ± m, ± degrees")


class KeyframeConfig(_Config):
    """Information-based keyframes: a pose enters the graph only when it adds information."""

    min_translation: float = Field(0.3, gt=0, description="m")
    min_rotation_deg: float = Field(10.0, gt=0, description="deg")
    min_novelty: float = Field(0.3, gt=0, le=1,
                               description="share of scan points the submap does not explain (new information)")
    between_sigma_floor: list[float] = Field([0.01, 0.01, 0.003], min_length=3, max_length=3,
                                             description="floor of keyframe-link σ (m, m, rad)")
    motion_prior_sigma: list[PositiveFloat] = Field([1.0, 1.0, 0.5], min_length=3, max_length=3,
                                            description="σ (m, m, rad) of the motion prior on a keyframe link: "
                                            "it constrains a direction that neither the scan match nor the "
                                            "wheel odometry observed, so that every link has full rank")


class LoopClosureConfig(_Config):
    """Candidate search, Pose SLAM gates, and verification of loop closures."""

    enabled: bool = Field(True, description="search for loop closures at all")
    search_radius: float = Field(8.0, gt=0, description="Euclidean pre-gate (m); with match_radius "
                                 "it bounds the correlative window_xy a candidate needs")
    min_keyframe_gap: int = Field(30, ge=1, description="skip the most recent keyframes")
    match_radius: float = Field(3.0, gt=0, description="scans match if poses closer than this (m)")
    max_yaw_difference_deg: float = Field(180.0, gt=0, le=180,
                                          description="predicted heading difference for scans to overlap")
    min_probability: float = Field(0.05, ge=0, le=1, description="P(|Δx|,|Δy| < match_radius)")
    min_information_gain: float = Field(1.0, ge=0, description="nats, against the nominal loop σ")
    nominal_sigma: list[float] = Field([0.05, 0.05, 0.02], min_length=3, max_length=3,
                                       description="σ of a loop measurement for the gain test (m, m, rad)")
    max_candidates: int = Field(2, ge=1, description="verified per keyframe, most probable first")
    neighbour_keyframes: int = Field(5, ge=0, description="± keyframes around a candidate in its submap")
    yaw_offsets_deg: list[float] = Field([0.0, 7.5, -7.5, 15.0, -15.0], min_length=1,
                                          description="heading offsets (deg) of the coarse registration starts")
    coarse_levels: int = Field(2, ge=0, description="voxel levels run from every yaw offset")
    coarse_inlier_distance: float = Field(0.3, gt=0, description="m: scoring the coarse starts")
    coarse_accept: float = Field(0.85, gt=0, le=1, description="a coarse start scoring this stops the search")
    correlative: CorrelativeConfig = Field(
        CorrelativeConfig(window_xy=11.0, window_deg=180.0, levels=7, min_score=0.6),
        description="the search where the graph's guess is poor (after metres of drift): its window is "
        "3 σ of the predicted relative pose, at least poor_guess_sigma, at most these windows. ± 11 m "
        "is search_radius + match_radius, the farthest a candidate the gates admit can be from its "
        "prediction: a window short of it misses the loops the gates let through (the Infinite "
        "Corridor's first return to its start, 5.2-5.9 m off after 700 m: with ± 5 m, 1 mm of range "
        "noise decided whether it closed, and replays ended 0.2-1.8 m apart)")
    poor_guess_sigma: list[PositiveFloat] = Field(
        [0.25, 0.25, 0.087], min_length=3, max_length=3,
        description="σ (m, m, rad) of the predicted relative pose beyond which the guess is poor: the "
        "correlative search runs (also when no coarse start scores coarse_accept)")
    min_inlier_fraction: float = Field(0.6, gt=0, le=1, description="a registration with fewer "
                                       "inliers is no loop closure")
    symmetry_translation: float = Field(0.1, gt=0, description="m: forward ∘ reverse registration gate")
    symmetry_rotation_deg: float = Field(1.0, gt=0, description="deg: forward ∘ reverse registration gate")
    mahalanobis_gate: float = Field(16.27, gt=0, description="χ²(3) gate (0.999) against the graph's prediction:"
                                                              " a loop beyond it, or one the correlative search"
                                                              " found, needs a consistent partner")
    mahalanobis_reject: float = Field(
        200.0, gt=0, description="beyond this a verified loop is rejected outright, unless the keyframe "
        "links alone predict it within mahalanobis_gate: true loops that contradict a false one lie far "
        "from the bent graph's prediction but agree with the links (lab_f_scan: 17 loops at d² 490-1310, "
        "within 1 cm of the truth); periodic aliases along a corridor come in consistent pairs and agree "
        "with neither (office_a: 2.3 m along its top corridor, d² 169-191 against the links)")
    pair_window: int = Field(15, ge=1, description="keyframes a loop waits for a consistent partner")
    pair_translation: float = Field(0.1, gt=0, description="m: pairwise consistency tolerance")
    pair_rotation_deg: float = Field(2.0, gt=0, description="deg: pairwise consistency tolerance")
    sigma_floor: list[float] = Field([0.02, 0.02, 0.005], min_length=3, max_length=3,
                                     description="floor of a loop factor's σ (m, m, rad)")
    cauchy_k: float = Field(3.0, gt=0, description="Cauchy kernel width on whitened loop residuals")
    consistency_probability: float = Field(
        0.999999999, gt=0, lt=1, description="a loop whose residual after optimisation is beyond the "
        "χ²(3) quantile at this probability (46: 6.8 σ) sends every loop through graduated "
        "non-convexity, which takes out the outliers. The keyframe links are its known inliers and "
        "are overconfident: at 0.999 (16.3) it took true loops out in the simulated office")
    extra_updates: int = Field(4, ge=0, description="iSAM2 iterations after a loop closure")
    moved_threshold: float = Field(0.05, ge=0, description="m: a loop moving a keyframe more fires the event")

    @model_validator(mode="after")
    def _window_reaches_the_gates(self) -> LoopClosureConfig:
        """Warn when the correlative window is shorter than search_radius + match_radius: the
        gates then admit loops the search cannot reach. A warning, not an error: a configuration
        written before the window was widened (± 5 m) still runs as it ran."""
        reach = self.search_radius + self.match_radius
        if self.enabled and self.correlative.window_xy < reach:
            warnings.warn(f"loop_closure.correlative.window_xy = {self.correlative.window_xy} m is "
                          f"shorter than search_radius + match_radius = {reach} m: loops the gates "
                          f"admit farther than that from the graph's guess are not found",
                          UserWarning, stacklevel=2)
        return self


class BackEndConfig(_Config):
    """The iSAM2 pose graph."""

    relinearize_threshold: float = Field(0.01, gt=0, description="iSAM2 relinearises "
                                         "a variable whose update exceeds this")
    relinearize_skip: int = Field(1, ge=1, description="iSAM2 checks relinearisation "
                                  "every this many updates")
    qr: bool = Field(False, description="QR instead of Cholesky (ill-conditioned graphs)")


class SlamConfig(_Config):
    """Pose SLAM: front end, keyframes, loop closures, back end."""

    front_end: FrontEndConfig = FrontEndConfig()
    keyframes: KeyframeConfig = KeyframeConfig()
    loop_closure: LoopClosureConfig = LoopClosureConfig()
    back_end: BackEndConfig = BackEndConfig()
    laser_offset: list[FiniteFloat] = Field(
        [0.0, 0.0, 0.0], min_length=3, max_length=3,
        description="the laser's pose in the robot's base frame (the odometry's frame): x (m), y (m), "
        "θ (rad); scans are taken at base ∘ offset. Used where the log does not state it (a bag's "
        "/tf_static, a CARMEN log's laser and robot poses)")

    def laser_mount(self) -> gtsam.Pose2:
        """``laser_offset`` as a pose: the laser's pose in the base frame."""
        return gtsam.Pose2(*self.laser_offset)
