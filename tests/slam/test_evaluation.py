"""Kümmerle et al.'s relation error."""

import math

import gtsam
import numpy as np
import pytest

from slam.evaluation import Relations, RelationsError, read_relations, relation_error


def path_poses(n):
    return [gtsam.Pose2(0.3 * i, 0.1 * math.sin(i), 0.05 * i) for i in range(n)]


def relations_of(stamps, poses, pairs):
    t1 = np.array([stamps[a] for a, _ in pairs])
    t2 = np.array([stamps[b] for _, b in pairs])
    d = [poses[a].between(poses[b]) for a, b in pairs]
    return Relations(t1, t2, np.array([[p.x(), p.y(), p.theta()] for p in d]))


def test_exact_trajectory_scores_zero_and_known_errors_are_measured():
    stamps = 100.0 + 0.2 * np.arange(20)
    truth = path_poses(20)
    rel = relations_of(stamps, truth, [(0, 1), (3, 5), (2, 19)])
    zero = relation_error(rel, stamps, truth)
    assert zero.translational.max() < 1e-12 and zero.rotational.max() < 1e-9
    # perturb pose 5 by 0.1 m along its own x and 2 deg: only relation (3, 5) sees it, exactly
    wrong = list(truth)
    wrong[5] = truth[5].compose(gtsam.Pose2(0.1, 0, math.radians(2)))
    e = relation_error(rel, stamps, wrong)
    assert e.translational == pytest.approx([0, 0.1, 0], abs=1e-9)
    assert e.rotational == pytest.approx([0, 2, 0], abs=1e-9)
    s = e.summary(split=1.0)
    assert s["short_lt_1s"]["n"] == 2 and s["long_ge_1s"]["n"] == 1
    assert s["all"]["trans_mean_m"] == pytest.approx(0.1 / 3)


def test_relation_times_between_poses_are_bridged_with_odometry():
    stamps = np.arange(10, dtype=float)
    truth = path_poses(10)
    # a relation at t = 4.5 (no pose within 0.1 s): the SLAM pose at 4 (or 5) moved along odometry
    step = truth[4].between(truth[5])
    mid = truth[4].compose(gtsam.Pose2(0.5 * step.x(), 0.5 * step.y(), 0.5 * step.theta()))
    rel = Relations(np.array([0.0]), np.array([4.5]), np.array([[*_xyt(truth[0].between(mid))]]))
    odometry = [gtsam.Pose2(5, 5, 1).compose(p) for p in truth]       # another frame, same motion
    e = relation_error(rel, stamps, truth, odometry)
    assert e.interpolated == 1
    assert e.translational[0] < 1e-9 and e.rotational[0] < 1e-7


def _xyt(p):
    return p.x(), p.y(), p.theta()


def test_different_time_base_is_refused(tmp_path):
    path = tmp_path / "r.relations"
    path.write_text("1134864645.9 1134864646.3 0.31 0.03 0 0 0 0.24\n")
    rel = read_relations(path)
    with pytest.raises(RelationsError, match="different time bases"):
        relation_error(rel, np.arange(10.0), path_poses(10))


def test_malformed_relations_name_the_line(tmp_path):
    path = tmp_path / "r.relations"
    path.write_text("# header\n1 2 0.1 0 0 0 0 0\n1 2 0.1 0 0 0 0\n")
    with pytest.raises(RelationsError, match=r"r\.relations:3: relation line has 7 fields"):
        read_relations(path)
