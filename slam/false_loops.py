"""A robustness test: wrong loop closures injected after verification, as a place-recognition
failure would produce them, to see whether the consistency layers keep them from bending the map.

Each time the detector turns a candidate of keyframe k down, with probability ``rate`` a false loop
is returned instead (true loops are left alone): keyframe k joined to a random keyframe j at
least ``min_gap`` keyframes earlier and ``min_distance`` meters away, with a plausible relative pose
(the graph's prediction moved by 0.3-1 m and 3-10°) and a confident match (σ 2 cm, 0.3°).
"""

from __future__ import annotations

import gtsam
import numpy as np

from slam.loop_closure import Candidate, LoopClosure, mahalanobis
from slam.pose_slam import PoseSlam
from slam.registration import Match


def inject_false_loops(slam: PoseSlam, rate: float, seed: int = 0, min_gap: int = 50,
                       min_distance: float = 5.0) -> list[LoopClosure]:
    """Make ``slam``'s detector return false loops; returns the (growing) list of those injected."""
    rng = np.random.default_rng(seed)
    injected: list[LoopClosure] = []
    verify = slam.detector.verify

    def verify_and_inject(candidate: Candidate, graph, scans) -> LoopClosure | None:
        loop = verify(candidate, graph, scans)
        k = candidate.k
        if loop is not None or k <= min_gap or rng.random() >= rate:
            return loop
        positions = graph.positions()
        far = np.flatnonzero(np.linalg.norm(positions[:k - min_gap] - positions[k], axis=1) > min_distance)
        if far.size == 0:
            return loop
        j = int(rng.choice(far))
        predicted, covariance = graph.relative(j, k)
        angle = rng.uniform(-np.pi, np.pi)
        offset = gtsam.Pose2(rng.uniform(0.3, 1.0) * np.cos(angle), rng.uniform(0.3, 1.0) * np.sin(angle),
                             np.radians(rng.uniform(3.0, 10.0) * rng.choice([-1, 1])))
        information = np.diag(1.0 / np.square([0.02, 0.02, np.radians(0.3)]))
        match = Match(predicted.compose(offset), information, 0.9, np.zeros((0, 3)), 0.01)
        false = LoopClosure(Candidate(j, k, predicted, covariance, 1.0, 10.0), match,
                            mahalanobis(predicted, covariance, match))
        injected.append(false)
        return false

    slam.detector.verify = verify_and_inject
    return injected
