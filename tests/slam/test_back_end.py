"""The pose graph's estimate, kept up to date key by key (``PoseGraph._follow``)."""

import gtsam
import numpy as np

from slam.back_end import PoseGraph

LINK = np.diag([0.02, 0.02, 0.01]) ** 2
LOOP = np.diag([0.01, 0.01, 0.005]) ** 2


def _solver_estimate(graph: PoseGraph) -> np.ndarray:
    return gtsam.utilities.extractPose2(graph.isam.calculateEstimate())


def test_the_followed_estimate_is_the_solver_s_bit_for_bit(monkeypatch):
    """A drifting tour with loop closures (each moving most keys, extra updates after it) and a
    loop taken out again: after every change, the estimate and its x, y, θ are what iSAM2's
    whole ``calculateEstimate`` gives, to the bit, and both ways of reading them (the changed
    keys alone, the whole estimate) were taken."""
    reads = {"whole": 0}
    read_whole = PoseGraph._read_whole

    def counted(self):
        reads["whole"] += 1
        read_whole(self)

    monkeypatch.setattr(PoseGraph, "_read_whole", counted)
    rng = np.random.default_rng(3)
    graph = PoseGraph()
    graph.add_first(gtsam.Pose2())
    truth = [gtsam.Pose2()]
    for j in range(1, 400):
        step = gtsam.Pose2(0.5, 0.0, 0.1 if (j // 40) % 2 else -0.08)
        truth.append(truth[-1].compose(step))
        graph.add_keyframe(step.compose(gtsam.Pose2(*rng.normal(0, [0.02, 0.02, 0.01]))), LINK)
        if j % 37 == 0:
            i = int(rng.integers(0, j - 30))
            graph.add_loop(i, j, truth[i].between(truth[j]), LOOP, 1.0, 2)
        if j == 300:
            graph.remove_edges([max(k for k, edge in enumerate(graph.edges) if edge[4])], 2)
        expected = _solver_estimate(graph)
        assert np.array_equal(graph.xytheta(), expected)
        assert np.array_equal(gtsam.utilities.extractPose2(graph.estimate), expected)
    assert 0 < reads["whole"] < 200          # most updates read only the keys that changed


def test_positions_handed_out_stay_as_they_were():
    """A loop closure reports the largest displacement it caused from positions read before it:
    positions handed out are never changed by a later update."""
    graph = PoseGraph()
    graph.add_first(gtsam.Pose2())
    for _ in range(40):
        graph.add_keyframe(gtsam.Pose2(0.5, 0.0, np.pi / 20), LINK)
    before = graph.positions()
    kept = before.copy()
    moved = graph.add_loop(0, 40, gtsam.Pose2(0.3, 0.0, 0.0), LOOP, 1.0, 2)
    assert np.array_equal(before, kept)
    assert moved == np.max(np.linalg.norm(graph.positions() - before, axis=1)) > 0.1
