"""The pose graph: GTSAM iSAM2 over ``Pose2`` keyframes, with keyframe links, robust loop
closures, marginal covariances, and the record needed to write the graph as g2o."""

from __future__ import annotations

import gtsam
import numpy as np

from slam.config import BackEndConfig


def well_conditioned(covariance: np.ndarray, min_sigma: float = 1e-4, max_sigma: float = 100.0) -> np.ndarray:
    """A symmetric (3, 3) covariance with standard deviations clipped to [min_sigma, max_sigma]:
    a near-singular or huge one (a degenerate match, a lost track) would make iSAM2's Cholesky
    factorisation indeterminate."""
    covariance = 0.5 * (covariance + covariance.T)
    values, vectors = np.linalg.eigh(covariance)
    values = np.clip(values, min_sigma**2, max_sigma**2)
    return (vectors * values) @ vectors.T


class PoseGraph:
    """Incremental smoothing of keyframe poses (keys 0, 1, 2, … in insertion order)."""

    def __init__(self, config: BackEndConfig | None = None):
        self.config = config or BackEndConfig()
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(self.config.relinearize_threshold)
        params.relinearizeSkip = self.config.relinearize_skip
        if self.config.qr:
            params.setFactorization("QR")
        self.isam = gtsam.ISAM2(params)
        self.estimate = gtsam.Values()
        #: (i, j, measurement, covariance, is_loop) for every between factor, in order.
        self.edges: list[tuple[int, int, gtsam.Pose2, np.ndarray, bool]] = []

    def __len__(self) -> int:
        return self.estimate.size()

    def add_first(self, pose: gtsam.Pose2, sigmas=(1e-3, 1e-3, 1e-4)) -> int:
        """Anchor the first keyframe at ``pose`` with a tight prior (sigmas in m, m, rad)."""
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        graph.add(gtsam.PriorFactorPose2(0, pose, gtsam.noiseModel.Diagonal.Sigmas(np.asarray(sigmas))))
        values.insert(0, pose)
        self._update(graph, values)
        return 0

    def add_keyframe(self, measurement: gtsam.Pose2, covariance: np.ndarray) -> int:
        """A new keyframe linked to the previous one by a relative pose (its frame) and covariance."""
        i = len(self) - 1
        j = i + 1
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        covariance = well_conditioned(covariance)
        graph.add(gtsam.BetweenFactorPose2(i, j, measurement, gtsam.noiseModel.Gaussian.Covariance(covariance)))
        values.insert(j, self.pose(i).compose(measurement))
        self.edges.append((i, j, measurement, covariance, False))
        self._update(graph, values)
        return j

    def add_loop(self, i: int, j: int, measurement: gtsam.Pose2, covariance: np.ndarray,
                 cauchy_k: float, extra_updates: int) -> float:
        """A loop closure (pose j in frame i) with a Cauchy kernel; returns the largest keyframe
        displacement it caused (m)."""
        before = self.positions()
        covariance = well_conditioned(covariance)
        graph = gtsam.NonlinearFactorGraph()
        noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Cauchy.Create(cauchy_k),
                                               gtsam.noiseModel.Gaussian.Covariance(covariance))
        graph.add(gtsam.BetweenFactorPose2(i, j, measurement, noise))
        self.edges.append((i, j, measurement, covariance, True))
        self._update(graph, gtsam.Values())
        for _ in range(extra_updates):
            self.isam.update()
        self.estimate = self.isam.calculateEstimate()
        return float(np.max(np.linalg.norm(self.positions() - before, axis=1)))

    def _update(self, graph, values) -> None:
        self.isam.update(graph, values)
        self.estimate = self.isam.calculateEstimate()

    def pose(self, key: int) -> gtsam.Pose2:
        return self.estimate.atPose2(key)

    def poses(self) -> list[gtsam.Pose2]:
        return [self.estimate.atPose2(k) for k in range(len(self))]

    def positions(self) -> np.ndarray:
        """(n, 2) keyframe positions."""
        return gtsam.utilities.extractPose2(self.estimate)[:, :2]

    def relative(self, i: int, j: int) -> tuple[gtsam.Pose2, np.ndarray]:
        """The predicted pose of j in frame i and its (3, 3) covariance, from the joint marginal."""
        xi, xj = self.pose(i), self.pose(j)
        rel = xi.between(xj)
        joint = self.isam.jointMarginalCovariance(gtsam.KeyVector([i, j]))
        sigma = np.block([[joint.at(i, i), joint.at(i, j)], [joint.at(j, i), joint.at(j, j)]])
        a = np.hstack([-rel.inverse().AdjointMap(), np.eye(3)])
        return rel, a @ sigma @ a.T
