"""Scan-to-submap registration: KISS-ICP coarse to fine, then point-to-line refinement that also
yields the covariance, the inlier fraction, and the degenerate (unobservable) directions.

KISS-ICP is reached only through ``slam.kiss_icp_adapter``; ``pose_matrix`` and ``matrix_pose``
live there and are importable from here too."""

from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np
from scipy.spatial import cKDTree

from slam.config import RegistrationConfig
from slam.kiss_icp_adapter import Icp, VoxelMap, matrix_pose, pose_matrix, voxel_down_sample


def scan_normals(points: np.ndarray, config: RegistrationConfig) -> np.ndarray:
    """(m, 2) unit normals of beam-ordered sensor-frame points, each turned towards the sensor (the
    side of the surface it was seen from); NaN where a point's ±2 neighbours are missing or one of
    the gaps between them is a jump edge.

    A normal is the line fitted (principal axis) to the point's neighbours on its surface: at
    least ±2 beams, and as many more as lie within ``normal_radius`` of it along the surface
    (measured as r·Δφ, their spacing were the surface square to the beams). Beams a fraction of a
    degree apart on a wall a metre away lie millimetres apart, within the range noise: normals
    from ±2 of them point anywhere, and the match takes them for evidence along the wall.

    Neighbouring hits farther apart than ``normal_max_gap`` (m) are a jump edge; with
    ``normal_min_incidence_deg`` (λ) above 0 the gap allowed grows by the spacing of two beams Δφ
    apart on a surface seen at incidence λ from the nearer range r, r·sin Δφ / sin(λ − Δφ) (the
    adaptive breakpoint of Borges & Aldon 2004), so a wall seen obliquely far down a corridor
    keeps its normals. Only neighbouring beams get that allowance: hits farther apart in bearing
    than 1.5 times the scan's smallest step have beams with no return between them, and as Δφ
    nears λ the allowance would join any two surfaces (office_h: a wall 7 m away to a box at 2 m).
    """
    m = len(points)
    normals = np.full((m, 2), np.nan)
    if m < 5:
        return normals
    gaps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    limit = np.full(m - 1, float(config.normal_max_gap))
    ranges = np.linalg.norm(points, axis=1)
    bearing = np.arctan2(points[:, 1], points[:, 0])
    step = np.abs(np.angle(np.exp(1j * np.diff(bearing))))
    if config.normal_min_incidence_deg > 0:
        incidence = np.radians(config.normal_min_incidence_deg)
        nearer = np.minimum(ranges[:-1], ranges[1:])
        adjacent = step < 1.5 * step.min()
        oblique = adjacent & (step < incidence)
        limit[oblique] += nearer[oblique] * np.sin(step[oblique]) / np.sin(incidence - step[oblique])
    close = gaps < limit
    ok = np.zeros(m, bool)
    ok[2:-2] = close[:-3] & close[1:-2] & close[2:-1] & close[3:]
    # the window of each point: its surface (no jump edge) within normal_radius, at least ±2 beams
    surface = np.concatenate([[0], np.cumsum(~close)])
    first = np.searchsorted(surface, surface, side="left")
    last = np.searchsorted(surface, surface, side="right") - 1
    along = np.concatenate([[0.0], np.cumsum(np.minimum(ranges[:-1], ranges[1:]) * step)])
    index = np.arange(m)
    lo = np.maximum(np.minimum(np.searchsorted(along, along - config.normal_radius, side="left"), index - 2), first)
    hi = np.minimum(np.maximum(np.searchsorted(along, along + config.normal_radius, side="right") - 1, index + 2),
                    last)
    x, y = points[:, 0], points[:, 1]
    sums = np.vstack([np.zeros(5), np.cumsum(np.column_stack([x, y, x * x, x * y, y * y]), axis=0)])
    window = sums[hi + 1] - sums[lo]
    count = (hi - lo + 1).astype(float)
    mx, my = window[:, 0] / count, window[:, 1] / count
    cxx = window[:, 2] / count - mx * mx
    cxy = window[:, 3] / count - mx * my
    cyy = window[:, 4] / count - my * my
    axis = 0.5 * np.arctan2(2.0 * cxy, cxx - cyy)         # the fitted line's direction
    normals = np.column_stack([-np.sin(axis), np.cos(axis)])
    normals[np.sum(normals * points, axis=1) > 0] *= -1.0
    ok &= cxx + cyy > 1e-12
    normals[~ok] = np.nan
    return normals


def transform(pose: gtsam.Pose2, points: np.ndarray) -> np.ndarray:
    """(n, 2) points mapped from the pose's frame to its parent frame."""
    c, s = np.cos(pose.theta()), np.sin(pose.theta())
    return points @ np.array([[c, s], [-s, c]]) + [pose.x(), pose.y()]


class Submap:
    """Points (with normals) of a few scans in one frame, as KISS-ICP voxel maps (one per voxel
    size of the coarse-to-fine schedule) and a k-d tree for point-to-line matching.

    Args:
        points: (n, 2) points in the submap frame.
        normals: (n, 2) unit normals, each on the side its surface was seen from (NaN where
            unknown).
    """

    def __init__(self, points: np.ndarray, normals: np.ndarray, config: RegistrationConfig):
        self.points = points
        self.normals = normals
        self.config = config
        self._voxel_maps: dict[float, VoxelMap] = {}
        self.tree = cKDTree(points, balanced_tree=False, compact_nodes=False)   # built per submap: fast builds
        self._seen: tuple[np.ndarray, Submap] | None = None   # the last faces seen_from kept

    def voxel_map(self, size: float) -> VoxelMap:
        """The KISS-ICP voxel map at ``size`` m, built on first use."""
        if size not in self._voxel_maps:
            voxel_map = VoxelMap(size, self.config.max_points_per_voxel)
            voxel_map.add(self.points)
            self._voxel_maps[size] = voxel_map
        return self._voxel_maps[size]

    def seen_from(self, sensor: np.ndarray) -> "Submap":
        """The points a sensor at ``sensor`` (2,) can see the faces of: those whose normal turns
        towards it, and those with no normal. A wall's far face lies a wall's thickness from its
        near face; a scan from one side matched to the other would be off by that much (a robot
        back from a room through its door, a loop closed across a thin wall)."""
        away = np.sum(self.normals * (np.asarray(sensor) - self.points), axis=1) < 0
        if not away.any():
            return self
        if self._seen is None or not np.array_equal(self._seen[0], away):   # the same faces: reused
            keep = ~away
            self._seen = (away, Submap(self.points[keep], self.normals[keep], self.config))
        return self._seen[1]

    @classmethod
    def from_scans(cls, poses: list[gtsam.Pose2], points: list[np.ndarray], normals: list[np.ndarray],
                   config: RegistrationConfig) -> "Submap":
        """Scans (sensor-frame points and normals) placed at ``poses`` in the submap frame."""
        pts = np.concatenate([transform(p, q) for p, q in zip(poses, points)])
        nrm = np.concatenate([n @ np.array([[np.cos(p.theta()), np.sin(p.theta())],
                                            [-np.sin(p.theta()), np.cos(p.theta())]])
                              for p, n in zip(poses, normals)])
        return cls(pts, nrm, config)


@dataclass
class Match:
    """The result of registering a scan to a submap.

    Attributes:
        pose: the scan's pose in the submap frame.
        information: (3, 3) in the pose's tangent space (x, y, θ): the point-to-line Hessian,
            plus the prior's information when a prior was given; near zero along a direction
            the scan cannot observe (a featureless corridor), zero when nothing matched (fewer
            than ``min_points`` correspondences with a line), prior or not.
        inlier_fraction: share of scan points within ``inlier_distance`` of the submap.
        degenerate: (k, 3) unit tangent directions the scan cannot observe (k = 0 normally).
        sigma: residual standard deviation (m).
    """

    pose: gtsam.Pose2
    information: np.ndarray
    inlier_fraction: float
    degenerate: np.ndarray
    sigma: float

    @property
    def covariance(self) -> np.ndarray:
        """(3, 3) the inverse of ``information`` (regularised by 1e-6 where it has none)."""
        return np.linalg.inv(self.information + 1e-6 * np.eye(3))


def explains_far_more(match: Match, other: Match, points: int, min_points: int) -> bool:
    """Does ``match`` leave at most half as many of the scan's ``points`` unexplained as
    ``other``, and explain at least ``min_points`` (what a match at all must rest on) that
    ``other`` does not? A match in another place than a plausible one must, to replace it: in a
    corridor or near a wall a slid match can explain a few more points than the true one, and
    a small scan a few more in proportion (office_a: 46 points of a wall 0.35 m ahead, 9 more of
    them explained with the scan turned 93° onto another wall, turned the track by 93°)."""
    gained = (match.inlier_fraction - other.inlier_fraction) * points
    return 1.0 - match.inlier_fraction <= 0.5 * (1.0 - other.inlier_fraction) and gained >= min_points


class Registration:
    """KISS-ICP registration (point-to-point, robust kernel) coarse to fine over the voxel sizes,
    then Gauss–Newton point-to-line refinement with a Cauchy kernel."""

    def __init__(self, config: RegistrationConfig | None = None):
        self.config = config or RegistrationConfig()
        self._icp = Icp(self.config.icp_iterations, self.config.icp_convergence, threads=1)

    def coarse_to_fine(self, points: np.ndarray, submap: Submap, guess: gtsam.Pose2,
                       start_level: int = 0, stop_level: int | None = None) -> gtsam.Pose2:
        """KISS-ICP at each voxel size from ``start_level`` up to (not including) ``stop_level``:
        each level corrects about one voxel."""
        estimate = pose_matrix(guess)       # 4×4 from level to level: no yaw round trip between them
        for size in self.config.voxel_sizes[start_level:stop_level]:
            estimate = self._icp.align_matrix(voxel_down_sample(points, 0.5 * size), submap.voxel_map(size),
                                              estimate, max_correspondence=2.0 * size, kernel=size / 3.0)
        return matrix_pose(estimate)

    def refine(self, points: np.ndarray, submap: Submap, pose: gtsam.Pose2,
               prior: tuple[gtsam.Pose2, np.ndarray] | None = None) -> Match:
        """Point-to-line Gauss–Newton from ``pose`` with a Cauchy kernel, on the submap's
        points whose faces the scan's sensor (at ``pose``) can see.

        ``prior`` = (predicted pose, (3, 3) information) adds the wheel odometry's prediction as a
        Gaussian prior on the pose, so directions the scene cannot constrain (a featureless
        corridor) follow the odometry. Without a prior those directions keep their initial value.

        Fewer than ``min_points`` correspondences with a line are no evidence: the match's
        information is then zero, prior or not, and its pose is where the refinement stopped,
        not fused with the prior. (Given the prior's information instead, such a match passed
        for one fused with the wheels: office_g, turning 0.4 m from a wall, 23 points, 4-7° a
        scan off the wheels for three scans.)
        """
        c = self.config
        degenerate = np.zeros((0, 3))
        hessian, sigma, inliers = np.zeros((3, 3)), c.min_sigma, 0.0
        start = pose
        submap = submap.seen_from([pose.x(), pose.y()])
        prior_info = prior[1] if prior is not None else np.zeros((3, 3))
        for iteration in range(c.refine_iterations + 1):
            world = transform(pose, points)
            dist, idx = submap.tree.query(world, distance_upper_bound=c.max_correspondence)
            found = np.isfinite(dist)
            inliers = float(np.mean(dist < c.inlier_distance)) if len(points) else 0.0
            n_world = np.full((len(points), 2), np.nan)
            n_world[found] = submap.normals[idx[found]]
            use = found & np.isfinite(n_world[:, 0])
            if use.sum() < c.min_points:
                hessian = np.zeros((3, 3))
                break
            n = n_world[use]
            r = np.sum(n * (world[use] - submap.points[idx[use]]), axis=1)
            ct, st = np.cos(pose.theta()), np.sin(pose.theta())
            n_body = np.column_stack([ct * n[:, 0] + st * n[:, 1], -st * n[:, 0] + ct * n[:, 1]])
            p = points[use]
            jac = np.column_stack([n_body, n_body[:, 0] * -p[:, 1] + n_body[:, 1] * p[:, 0]])
            k = max(3 * sigma, c.min_sigma)
            w = 1.0 / (1.0 + (r / k) ** 2)
            sigma = max(float(np.sqrt(np.sum(w * r**2) / max(w.sum() - 3, 1))), c.min_sigma)
            hessian = jac.T @ (w[:, None] * jac) / sigma**2
            if iteration == c.refine_iterations:
                break
            gradient = jac.T @ (w * r) / sigma**2
            if prior is not None:
                gradient = gradient + prior_info @ prior[0].localCoordinates(pose)
            step = -np.linalg.solve(hessian + prior_info + 1e-9 * np.eye(3), gradient)
            if prior is None:
                weak = degenerate_directions(jac[:, :2], c.degenerate_eigenvalue)
                step -= weak.T @ (weak @ step)
            pose = pose.retract(step)
            if np.abs(step).max() < c.convergence:
                break
        if hessian.any():
            degenerate = degenerate_directions(jac[:, :2], c.degenerate_eigenvalue)
        else:
            degenerate = np.eye(3)[:2]
        if prior is None and len(degenerate):
            delta = start.localCoordinates(pose)
            pose = start.retract(delta - degenerate.T @ (degenerate @ delta))
        return Match(pose, hessian + prior_info if hessian.any() else hessian, inliers, degenerate, sigma)

    def register(self, points: np.ndarray, submap: Submap, guess: gtsam.Pose2,
                 prior: tuple[gtsam.Pose2, np.ndarray] | None = None, start_level: int = 0) -> Match:
        """Coarse-to-fine KISS-ICP from ``guess`` then point-to-line refinement."""
        return self.refine(points, submap, self.coarse_to_fine(points, submap, guess, start_level), prior)


def degenerate_directions(normals: np.ndarray, threshold: float) -> np.ndarray:
    """(k, 3) translation directions whose normalised information Σ nnᵀ / N over the (N, 2)
    unit ``normals`` is below ``threshold``."""
    values, vectors = np.linalg.eigh(normals.T @ normals / len(normals))
    weak = vectors[:, values < threshold].T
    return np.column_stack([weak, np.zeros(len(weak))])
