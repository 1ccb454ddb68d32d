"""The pose graph: GTSAM iSAM2 over ``Pose2`` keyframes, with keyframe links, robust loop
closures, marginal covariances, and the record needed to write the graph as g2o."""

from __future__ import annotations

from collections import Counter

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


#: ``PoseGraph._follow`` reads the whole estimate when more than 1 / this of the keys changed: a
#: key read alone costs about as much as this many in ``calculateEstimate``.
FOLLOWED = 8


class SlamError(RuntimeError):
    """The pose graph cannot take a keyframe even after rebuilding its solver."""


class PoseGraph:
    """Incremental smoothing of keyframe poses (keys 0, 1, 2, … in insertion order).

    When iSAM2 finds its linear system indeterminate (GTSAM's IndeterminantLinearSystemException:
    a nearly unconstrained variable), the solver is rebuilt from every factor with QR
    factorisation and counted in ``fallbacks["isam2_rebuilt"]``; a loop closure that still
    cannot be added is left out (``fallbacks["loops_dropped"]``).
    """

    def __init__(self, config: BackEndConfig | None = None):
        self.config = config or BackEndConfig()
        self.isam = gtsam.ISAM2(self._params(self.config.qr))
        self.estimate = gtsam.Values()
        self._delta = np.zeros((0, 3))       # the solver's Δ when the estimate was last read
        self.factors = gtsam.NonlinearFactorGraph()
        #: (i, j, measurement, covariance, is_loop) for every between factor, in order.
        self.edges: list[tuple[int, int, gtsam.Pose2, np.ndarray, bool]] = []
        self.fallbacks: Counter = Counter()

    def _solver(self, factors: gtsam.NonlinearFactorGraph, values: gtsam.Values, qr: bool) -> gtsam.ISAM2:
        """A new iSAM2 holding ``factors`` from ``values`` (one Gauss–Newton step taken)."""
        isam = gtsam.ISAM2(self._params(qr))
        isam.update(factors, values)
        return isam

    def _params(self, qr: bool) -> gtsam.ISAM2Params:
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(self.config.relinearize_threshold)
        params.relinearizeSkip = self.config.relinearize_skip
        if qr:
            params.setFactorization("QR")
        return params

    @property
    def estimate(self) -> gtsam.Values:
        """The current estimate of every keyframe pose."""
        return self._estimate

    @estimate.setter
    def estimate(self, values: gtsam.Values) -> None:
        self._estimate = values
        self._xytheta = None

    def _follow(self, marked=()) -> None:
        """Bring the estimate up to the solver's after updates that kept it (``marked``: the keys
        their results marked, relinearised or in a new factor). iSAM2's estimate is θ ⊕ Δ key by
        key, and an update changes Δ only where its back-substitution reached, so only the keys
        whose Δ changed, the marked ones and the new ones are read again (``calculateEstimate``
        reads all of them: with the read of x, y, θ, about 2 ms a keyframe on office_g's
        4 000 keyframes under the profiler). The poses are those ``calculateEstimate`` gives,
        bit for bit."""
        delta = self.isam.getDelta().vector().reshape(-1, 3)
        n = min(len(delta), len(self._delta))
        changed = np.flatnonzero((delta[:n] != self._delta[:n]).any(axis=1))
        keys = np.union1d(np.union1d(changed, np.arange(n, len(delta))), np.array(marked, np.int64))
        if len(keys) > len(delta) // FOLLOWED:
            self._read_whole()
            return
        xytheta = np.zeros((len(delta), 3))
        xytheta[:len(self._delta)] = self.xytheta()[:len(delta)]
        for key in keys.tolist():
            pose = self.isam.calculateEstimatePose2(key)
            if key < len(self._delta):
                self._estimate.update(key, pose)
            else:
                self._estimate.insert(key, pose)
            xytheta[key] = pose.x(), pose.y(), pose.theta()
        xytheta.flags.writeable = False
        self._xytheta, self._delta = xytheta, delta

    def _read_whole(self) -> None:
        """The whole estimate read off the solver (a new one, or most keys changed);
        ``_follow`` goes on from it."""
        self.estimate = self.isam.calculateEstimate()
        self._delta = self.isam.getDelta().vector().reshape(-1, 3)

    def xytheta(self) -> np.ndarray:
        """(n, 3) x, y (m) and θ (rad) of every keyframe, read off the estimate once per
        estimate (the loop search and the planner's trail read them at every keyframe and
        replan: 0.9 ms a read on office_g's 4 000 keyframes); read-only, and never changed
        after it is handed out."""
        if self._xytheta is None:
            self._xytheta = gtsam.utilities.extractPose2(self._estimate)
            self._xytheta.flags.writeable = False
        return self._xytheta

    def __len__(self) -> int:
        return self.estimate.size()

    def add_first(self, pose: gtsam.Pose2, sigmas=(1e-3, 1e-3, 1e-4)) -> int:
        """Anchor the first keyframe at ``pose`` with a tight prior (sigmas in m, m, rad)."""
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        graph.add(gtsam.PriorFactorPose2(0, pose, gtsam.noiseModel.Diagonal.Sigmas(np.asarray(sigmas))))
        values.insert(0, pose)
        if not self._update(graph, values):
            raise SlamError(f"the pose graph cannot take its first keyframe at {pose}")
        return 0

    def add_keyframe(self, measurement: gtsam.Pose2, covariance: np.ndarray) -> int:
        """A new keyframe linked to the previous one by a relative pose (its frame) and covariance."""
        i = len(self) - 1
        j = i + 1
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        covariance = well_conditioned(covariance)
        graph.add(gtsam.BetweenFactorPose2(i, j, measurement, gtsam.noiseModel.Gaussian.Covariance(covariance)))
        values.insert(j, self.pose(i).compose(measurement))
        if not self._update(graph, values):
            raise SlamError(f"the pose graph cannot take keyframe {j} (link {measurement}, σ "
                            f"{np.sqrt(np.diag(covariance))}) even with a rebuilt QR solver")
        self.edges.append((i, j, measurement, covariance, False))
        return j

    def add_loop(self, i: int, j: int, measurement: gtsam.Pose2, covariance: np.ndarray,
                 cauchy_k: float, extra_updates: int) -> float | None:
        """A loop closure (pose j in frame i) with a Cauchy kernel; returns the largest keyframe
        displacement it caused (m), or None when the solver could not take it (left out)."""
        before = self.positions()
        covariance = well_conditioned(covariance)
        graph = gtsam.NonlinearFactorGraph()
        noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Cauchy.Create(cauchy_k),
                                               gtsam.noiseModel.Gaussian.Covariance(covariance))
        graph.add(gtsam.BetweenFactorPose2(i, j, measurement, noise))
        if not self._update(graph, gtsam.Values()):
            self.fallbacks["loops_dropped"] += 1
            return None
        self.edges.append((i, j, measurement, covariance, True))
        results = [self.isam.update() for _ in range(extra_updates)]
        marked = [key for result in results for key in list(result.getMarkedKeys())]
        self._follow(marked)
        return float(np.max(np.linalg.norm(self.positions() - before, axis=1)))

    def _update(self, graph: gtsam.NonlinearFactorGraph, values: gtsam.Values) -> bool:
        """Add factors (and new variables) to iSAM2; on an indeterminate system, rebuild the
        solver with QR from every factor. False when even that fails (nothing was added)."""
        try:
            result = self.isam.update(graph, values)
            marked = list(result.getMarkedKeys())
        except RuntimeError:                       # GTSAM's IndeterminantLinearSystemException
            self.fallbacks["isam2_rebuilt"] += 1
            everything, start = gtsam.NonlinearFactorGraph(self.factors), gtsam.Values(self.estimate)
            everything.push_back(graph)
            start.insert(values)
            try:
                self.isam = self._solver(everything, start, qr=True)
            except RuntimeError:
                return False
            self._read_whole()
        else:
            self._follow(marked)
        self.factors.push_back(graph)
        return True

    def loop_residuals(self) -> np.ndarray:
        """(m,) squared Mahalanobis residual of each loop closure at the current estimate."""
        out = []
        for i, j, z, covariance, loop in self.edges:
            if loop:
                e = gtsam.Pose2.Logmap(z.between(self.pose(i).between(self.pose(j))))
                out.append(float(e @ np.linalg.solve(covariance, e)))
        return np.array(out)

    def chained(self, i: int, j: int) -> tuple[gtsam.Pose2, np.ndarray]:
        """Pose j in frame i (i < j) from the keyframe links alone, no loop closure, and its
        (3, 3) covariance, propagated link by link (T ← T·z, Σ ← Ad(z⁻¹) Σ Ad(z⁻¹)ᵀ + Σ_z)."""
        links = [(z, covariance) for a, _, z, covariance, loop in self.edges if not loop and i <= a < j]
        pose, sigma = gtsam.Pose2(), np.zeros((3, 3))
        for z, covariance in links:
            adjoint = z.inverse().AdjointMap()
            pose, sigma = pose.compose(z), adjoint @ sigma @ adjoint.T + covariance
        return pose, sigma

    def outlier_loops(self, probability: float) -> list[int]:
        """Indices into ``edges`` of the loop closures that graduated non-convexity rejects (Yang
        et al. 2020: a truncated least-squares loss reached from its convex surrogate, its inlier
        threshold the χ²(3) quantile at ``probability``), every keyframe link and the prior being
        known inliers. Run on the whole graph, from the current estimate."""
        graph = gtsam.NonlinearFactorGraph()
        graph.add(self.factors.at(0))
        for i, j, z, covariance, _ in self.edges:
            graph.add(gtsam.BetweenFactorPose2(i, j, z, gtsam.noiseModel.Gaussian.Covariance(covariance)))
        params = gtsam.GncLMParams()
        params.setKnownInliers([0] + [k + 1 for k, edge in enumerate(self.edges) if not edge[4]])
        optimizer = gtsam.GncLMOptimizer(graph, self.estimate, params)
        optimizer.setInlierCostThresholdsAtProbability(probability)
        optimizer.optimize()
        weights = optimizer.getWeights()
        return [k for k, edge in enumerate(self.edges) if edge[4] and weights[k + 1] < 0.5]

    def remove_edges(self, indices: list[int], iterations: int) -> None:
        """Take between factors (indices into ``edges``) out of the graph: the solver is rebuilt
        from the others, from the current estimate, and iterated ``iterations`` more times (one
        iSAM2 update is one Gauss–Newton step)."""
        drop = set(indices)
        factors = gtsam.NonlinearFactorGraph()
        factors.add(self.factors.at(0))
        for k in range(len(self.edges)):
            if k not in drop:
                factors.add(self.factors.at(k + 1))
        self.edges = [edge for k, edge in enumerate(self.edges) if k not in drop]
        self.isam = self._solver(factors, self.estimate, qr=self.config.qr)
        for _ in range(iterations):
            self.isam.update()
        self.factors = factors
        self._read_whole()

    def pose(self, key: int) -> gtsam.Pose2:
        return self.estimate.atPose2(key)

    def poses(self) -> list[gtsam.Pose2]:
        return [self.estimate.atPose2(k) for k in range(len(self))]

    def positions(self) -> np.ndarray:
        """(n, 2) keyframe positions."""
        return self.xytheta()[:, :2]

    def relative(self, i: int, j: int) -> tuple[gtsam.Pose2, np.ndarray]:
        """The predicted pose of j in frame i and its (3, 3) covariance, from the joint marginal."""
        xi, xj = self.pose(i), self.pose(j)
        rel = xi.between(xj)
        joint = self.isam.jointMarginalCovariance(gtsam.KeyVector([i, j]))
        sigma = np.block([[joint.at(i, i), joint.at(i, j)], [joint.at(j, i), joint.at(j, j)]])
        a = np.hstack([-rel.inverse().AdjointMap(), np.eye(3)])
        return rel, a @ sigma @ a.T
