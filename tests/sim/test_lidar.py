import gtsam
import numpy as np
import pytest
from pydantic import ValidationError

from sim.lidar import Lidar, LidarConfig
from sim.world import World


@pytest.fixture
def box():
    """10 m x 10 m, walls on the border only (the grid edge)."""
    return World(np.zeros((200, 200), dtype=bool), (0.05, 0.05))


def test_beams_span_the_field_of_view():
    lidar = Lidar(LidarConfig(beams=361, fov_deg=180.0))
    assert lidar.angles[0] == pytest.approx(-np.pi / 2) and lidar.angles[-1] == pytest.approx(np.pi / 2)
    assert np.allclose(np.diff(lidar.angles), np.deg2rad(0.5))
    full = Lidar(LidarConfig(beams=360, fov_deg=360.0))
    assert np.allclose(np.diff(full.angles), np.deg2rad(1.0)) and full.angles[-1] < np.pi


def test_noise_statistics(box):
    sigma = 0.02
    lidar = Lidar(LidarConfig(beams=1, fov_deg=1e-6, range_sigma=sigma, max_range=8.0), seed=1)
    pose = gtsam.Pose2(5.0, 5.0, 0.0)  # facing the wall at x = 10: true range 5 m
    ranges = np.array([lidar.scan(box, pose).ranges[0] for _ in range(4000)])
    err = ranges - 5.0
    assert abs(err.mean()) < 4 * sigma / np.sqrt(err.size)
    assert err.std() == pytest.approx(sigma, rel=0.06)


def test_no_return_reads_max_range(box):
    lidar = Lidar(LidarConfig(max_range=3.0, range_sigma=0.0))
    scan = lidar.scan(box, gtsam.Pose2(5.0, 5.0, 0.0))
    assert np.all(scan.ranges == 3.0) and not scan.hit.any() and scan.no_return.all()


@pytest.mark.parametrize("value", ["max_range", "nan"])
def test_dropouts_rate_and_value(box, value):
    p = 0.2
    lidar = Lidar(LidarConfig(beams=2000, fov_deg=90.0, dropout=p, dropout_value=value,
                              range_sigma=0.0), seed=4)
    scan = lidar.scan(box, gtsam.Pose2(5.0, 5.0, 0.0))
    dropped = np.isnan(scan.ranges) if value == "nan" else scan.ranges == 8.0
    n = scan.ranges.size
    assert abs(dropped.mean() - p) < 4 * np.sqrt(p * (1 - p) / n)
    # the rest are exact hits on the wall x = 10
    kept = ~dropped
    expected = 5.0 / np.cos(scan.angles[kept])
    np.testing.assert_allclose(scan.ranges[kept], expected, atol=1e-9)


def test_pose_rotates_the_scan(box):
    lidar = Lidar(LidarConfig(beams=1, fov_deg=1e-6, range_sigma=0.0))
    r = lidar.scan(box, gtsam.Pose2(2.0, 3.0, np.pi / 2)).ranges[0]
    assert r == pytest.approx(7.0)  # facing +y: wall at y = 10


def test_seeded_determinism(box):
    config = LidarConfig(dropout=0.1, range_sigma=0.05)
    pose = gtsam.Pose2(4.0, 4.0, 0.3)
    a = [Lidar(config, seed=7).scan(box, pose).ranges for _ in range(2)]
    b = Lidar(config, seed=8).scan(box, pose).ranges
    np.testing.assert_array_equal(a[0], a[1])
    assert not np.array_equal(a[0], b)


def test_bad_config_is_rejected():
    with pytest.raises(ValidationError, match="max_range"):
        LidarConfig(max_range=-1.0)
    with pytest.raises(ValidationError, match="dropout"):
        LidarConfig(dropout=1.5)
