"""`gpexplore map`: a small CARMEN log in, map products out; and the Intel data test."""

import json

import gtsam
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from mapping.export import write_ros_map
from mapping.grid import GridFrame
from mapping.metrics import auc_readings, coverage, map_entropy, roc_auc
from sim.cli import app
from simworlds import corridor_world


def write_flaser_log(path, poses, scans):
    lines = ["# message formats defined: FLASER"]
    for k, (p, s) in enumerate(zip(poses, scans)):
        r = " ".join(f"{v:.3f}" for v in s.ranges)
        pose = f"{p.x():.4f} {p.y():.4f} {p.theta():.5f}"
        lines.append(f"FLASER {len(s.ranges)} {r} {pose} {pose} {k * 0.5:.3f} test {k * 0.5:.3f}")
    path.write_text("\n".join(lines) + "\n")


def test_map_command_writes_com_ros_map_metrics_and_figure(tmp_path):
    from sim.lidar import Lidar, LidarConfig

    world = corridor_world()
    poses = [gtsam.Pose2(x, 2.0, 0.0) for x in np.arange(1.5, 8.0, 0.5)]
    lidar = Lidar(LidarConfig(beams=180), seed=0)
    scans = [lidar.scan(world, p) for p in poses]
    log = tmp_path / "corridor.clf"
    write_flaser_log(log, poses, scans)
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["map", str(log), "--poses", "log", "--out", str(out), "--max-range", "8"])
    assert result.exit_code == 0, result.output
    com = np.load(out / "com.npz")
    for key in ("prob", "prob_occ", "prob_free", "var", "var_occ", "var_free"):
        assert com[key].shape == com["prob"].shape and np.isfinite(com[key]).all()
    # the corridor centre (x=5, y=2) is free in the saved map
    ix, iy = np.round((np.array([5.0, 2.0]) - com["origin"]) / com["resolution"]).astype(int)
    assert com["prob"][iy, ix] < 0.3
    meta = yaml.safe_load((out / "map.yaml").read_text())
    assert meta["image"] == "map.pgm" and meta["resolution"] == pytest.approx(0.1)
    assert meta["origin"][:2] == pytest.approx(list(com["origin"] - 0.05))
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["keyframes"] == len(poses) and metrics["auc"] > 0.95
    assert (out / "figures" / "com.png").stat().st_size > 10_000


def test_map_command_says_slam_poses_are_not_available_yet(tmp_path):
    log = tmp_path / "x.clf"
    log.write_text("FLASER 2 1.0 1.0 0 0 0 0 0 0 0 h 0\n")
    result = CliRunner().invoke(app, ["map", str(log), "--poses", "slam", "--out", str(tmp_path)])
    assert result.exit_code != 0 and "SLAM" in result.output


def test_ros_map_pgm_is_trinary_top_row_first(tmp_path):
    prob = np.array([[0.9, 0.1], [0.5, 0.5]])            # row 0 at the bottom
    write_ros_map(tmp_path / "m.pgm", prob, np.array([1.05, 2.05]), 0.1)
    data = (tmp_path / "m.pgm").read_bytes()
    assert data.startswith(b"P5\n2 2\n255\n")
    assert list(data[-4:]) == [205, 205, 0, 254]            # top row (row 1) first
    assert yaml.safe_load((tmp_path / "m.yaml").read_text())["origin"] == pytest.approx([1.0, 2.0, 0.0])


def test_entropy_and_coverage_and_auc():
    assert map_entropy(np.full((10, 10), 0.5), 0.1, 0.2) == pytest.approx(25 * np.log(2))
    assert map_entropy(np.full((4, 4), 1e-9), 0.1, 0.2) < 1e-6
    prob = np.array([[0.1, 0.5], [0.9, 0.35]])
    assert coverage(prob, np.array([[True, True], [False, True]]), 0.2) == pytest.approx(1 / 3)
    assert roc_auc([0, 0, 1, 1], [0.1, 0.4, 0.35, 0.8]) == pytest.approx(0.75)
    assert roc_auc([0, 1], [0.5, 0.5]) == pytest.approx(0.5)


def test_auc_reads_the_map_continuously_and_auc_cell_per_cell():
    # two 1 m cells, Λ 0.2 and 0.8; an obstacle point and a free point in the first cell: the
    # cell reading ties them (0.2, 0.2), the bilinear one ranks them (0.44 against 0.26; off the
    # map reads 0.5)
    frame = GridFrame(1.0)
    frame.shape = (1, 2)
    readings = auc_readings([True, False], frame, np.array([[0.2, 0.8]]), np.array([[0.9, 0.5], [0.3, 0.5]]))
    assert readings == {"auc": 1.0, "auc_cell": 0.5}


@pytest.mark.slow
def test_intel_log_heldout_auc(shared_data):
    """The whole Intel log with its poses, 20 % of each scan's labelled points held out: the
    issue's target, AUC >= 0.995 read continuously."""
    from mapping.run import map_keyframes
    from slam.carmen import CarmenLog

    log = CarmenLog(shared_data / "logs" / "intel-corrected.log.gz")
    run = map_keyframes(((r.pose, r.scan) for r in log), holdout=0.2, protocol="points")
    assert run.metrics["keyframes"] == 910
    assert run.metrics["auc"] >= 0.995                   # read continuously; measured 0.9956
    assert run.metrics["auc_cell"] > 0.992               # read per cell; measured 0.9944
    assert np.isfinite(run.com.prob()).all()


@pytest.mark.slow
def test_intel_drift_flags_a_pose_error_but_not_the_corrected_poses(shared_data):
    """Cumulated JS drift on Intel: quiet with the log's poses; a 0.3 m / 2 degree error on the
    second half is flagged at once (measured: on the first update after it)."""
    from mapping.com import ContinuousOccupancyMap
    from slam.carmen import CarmenLog

    log = CarmenLog(shared_data / "logs" / "intel-corrected.log.gz")
    error = gtsam.Pose2(0.3, -0.2, 0.035)
    com = ContinuousOccupancyMap()
    flagged = None
    for i, r in enumerate(log[:600]):
        com.update(r.pose if i < 455 else error.compose(r.pose), r.scan)
        if i == 454:
            assert not com.needs_regeneration
        if flagged is None and com.needs_regeneration:
            flagged = i
    assert flagged is not None and flagged < 465
