import math

import gtsam
import numpy as np
import pytest

from sim.odometry import Odometry, OdometryNoise


def errors(odometry, motion, n=4000):
    out = []
    for _ in range(n):
        m = odometry.sample(motion)
        out.append([m.x() - motion.x(), m.y() - motion.y(), gtsam.Rot2(m.theta() - motion.theta()).theta()])
    return np.array(out)


def test_noise_grows_in_proportion_to_the_motion():
    odometry = Odometry(OdometryNoise(), seed=3)
    short = errors(odometry, gtsam.Pose2(0.5, 0.0, 0.0))
    long = errors(odometry, gtsam.Pose2(1.0, 0.0, 0.0))
    ratio = long.std(axis=0) / short.std(axis=0)
    # along-track and heading errors scale with the distance; the lateral one, from the
    # heading error times the distance, with its square
    np.testing.assert_allclose(ratio, [2.0, 4.0, 2.0], rtol=0.1)
    # unbiased along x
    assert abs(long[:, 0].mean()) < 4 * long[:, 0].std() / math.sqrt(len(long))


def test_translation_std_matches_the_model():
    noise = OdometryNoise(alpha1=0.0, alpha2=0.0, alpha3=0.1**2, alpha4=0.0)
    e = errors(Odometry(noise, seed=5), gtsam.Pose2(2.0, 0.0, 0.0))
    assert e[:, 0].std() == pytest.approx(0.2, rel=0.05)
    assert np.abs(e[:, 1:]).max() < 1e-12


def test_rotation_only_noise():
    noise = OdometryNoise(alpha1=0.1**2, alpha2=0.0, alpha3=0.0, alpha4=0.0)
    e = errors(Odometry(noise, seed=6), gtsam.Pose2(0.0, 0.0, 1.0))
    assert e[:, 2].std() == pytest.approx(0.1, rel=0.05)


def test_standing_still_gives_no_noise():
    odometry = Odometry(seed=1)
    assert odometry.sample(gtsam.Pose2()).equals(gtsam.Pose2(), 1e-12)


def test_drift_grows_along_a_trajectory_and_is_seeded():
    step = gtsam.Pose2(0.05, 0.0, 0.01)

    def final_errors(seed, steps):
        truth, odometry = gtsam.Pose2(), Odometry(seed=seed)
        for _ in range(steps):
            truth = truth.compose(step)
            odometry.update(step)
        return np.linalg.norm(truth.translation() - odometry.pose.translation())

    assert final_errors(2, 500) == final_errors(2, 500)
    short = np.mean([final_errors(s, 200) for s in range(40)])
    long = np.mean([final_errors(s, 800) for s in range(40)])
    assert long > 2.0 * short
