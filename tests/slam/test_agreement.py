"""Agreement with a reference trajectory after SE(2) alignment."""

import math

import gtsam
import numpy as np
import pytest

from slam.agreement import agreement


def test_a_rigidly_moved_trajectory_agrees_exactly():
    rng = np.random.default_rng(0)
    reference = [gtsam.Pose2(*p) for p in rng.uniform([-10, -10, -3], [10, 10, 3], (50, 3))]
    frame = gtsam.Pose2(3.0, -7.0, 1.1)                 # the estimate lives in another frame
    estimate = [frame.compose(p) for p in reference]
    a = agreement(estimate, reference)
    assert a["rmse_m"] < 1e-9 and a["max_m"] < 1e-9 and a["rot_max_deg"] < 1e-9


def test_one_displaced_pose_is_the_maximum():
    """Four poses on a square's corners and one displaced by d at the centre: aligning moves
    nothing by symmetry when d points along a diagonal... so use the closed form: the best
    translation shifts every pose by d/n, leaving errors d(n-1)/n at the displaced pose and d/n
    at the others (no rotation helps, the displaced pose being at the centroid)."""
    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    reference = [gtsam.Pose2(x, y, 0.0) for x, y in corners] + [gtsam.Pose2(0.0, 0.0, 0.0)]
    d = 0.5
    estimate = reference[:4] + [gtsam.Pose2(d, 0.0, 0.0)]
    a = agreement(estimate, reference)
    n = 5
    assert a["max_m"] == pytest.approx(d * (n - 1) / n, abs=1e-9)
    assert a["rmse_m"] == pytest.approx(math.sqrt(((d * (n - 1) / n) ** 2 + 4 * (d / n) ** 2) / n), abs=1e-9)
    assert a["rot_max_deg"] == pytest.approx(0.0, abs=1e-9)


def test_lengths_must_match():
    with pytest.raises(ValueError, match="3 estimated poses for 2"):
        agreement([gtsam.Pose2()] * 3, [gtsam.Pose2()] * 2)


def test_a_scaled_trajectory_differs_in_scale_alone():
    """The reference shrunk by k about a point, then moved rigidly: the similarity's scale is
    1 / k and it leaves nothing; the rigid alignment leaves each pose (1 - k) times its distance
    from the centroid, which no rotation or shift reduces."""
    rng = np.random.default_rng(1)
    xy = rng.uniform(-20, 20, (60, 2))
    reference = [gtsam.Pose2(x, y, t) for (x, y), t in zip(xy, rng.uniform(-3, 3, 60))]
    k, frame = 0.995, gtsam.Pose2(-4.0, 2.5, 0.7)
    estimate = [frame.compose(gtsam.Pose2(k * p.x(), k * p.y(), p.theta())) for p in reference]
    a = agreement(estimate, reference)
    assert a["scale"] == pytest.approx(1 / k, abs=1e-12) and a["similarity_rmse_m"] < 1e-9
    radius = np.linalg.norm(xy - xy.mean(axis=0), axis=1)
    assert a["rmse_m"] == pytest.approx((1 - k) * np.sqrt(np.mean(radius ** 2)), rel=1e-9)
    assert a["rot_max_deg"] < 1e-9
