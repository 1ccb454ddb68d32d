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


def write_flaser_log(path, poses, scans, period=0.5, odometry=None):
    """A raw CARMEN log: a FLASER line per scan with ``poses`` in both pose slots (so they are
    also its odometry; a corrected log with ``odometry`` in the second), one every ``period`` s;
    beams with no return read 81.91 as in real logs."""
    lines = ["# message formats defined: FLASER"]
    for k, (p, s, o) in enumerate(zip(poses, scans, odometry or poses)):
        r = " ".join(f"{v:.3f}" for v in np.where(s.ranges < s.max_range, s.ranges, 81.91))
        pose = f"{p.x():.4f} {p.y():.4f} {p.theta():.5f}"
        odom = f"{o.x():.4f} {o.y():.4f} {o.theta():.5f}"
        lines.append(f"FLASER {len(s.ranges)} {r} {pose} {odom} {k * period:.3f} test {k * period:.3f}")
    path.write_text("\n".join(lines) + "\n")


def one_line(output):
    """CLI output with rich's error box and line wrapping removed."""
    return " ".join(output.replace("│", " ").split())


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


def test_map_command_reads_the_com_section_and_saves_its_configuration(tmp_path):
    from sim.config_file import read_config
    from sim.lidar import Lidar, LidarConfig

    world = corridor_world()
    poses = [gtsam.Pose2(x, 2.0, 0.0) for x in (2.0, 3.0, 4.0)]
    lidar = Lidar(LidarConfig(beams=90), seed=0)
    log = tmp_path / "corridor.clf"
    write_flaser_log(log, poses, [lidar.scan(world, p) for p in poses])
    config = tmp_path / "cfg.toml"
    config.write_text("[stack.com.query]\nresolution = 0.2\n[stack.com.training]\nmax_range = 6.0\n")
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["map", str(log), "--out", str(out), "--config", str(config),
                                      "--max-range", "8"])
    assert result.exit_code == 0, result.output
    assert yaml.safe_load((out / "map.yaml").read_text())["resolution"] == pytest.approx(0.2)
    saved = read_config(out / "config.toml").stack.com
    assert saved.query.resolution == 0.2 and saved.training.max_range == 8.0     # the option wins


def auc_against_truth(com, world):
    """ROC AUC of a saved map's Λ against the true occupancy, over the cells it has observed."""
    prob = com["prob"]
    iy, ix = np.nonzero(np.abs(prob - 0.5) > 0.01)
    xy = com["origin"] + com["resolution"] * np.column_stack([ix, iy])
    return roc_auc(world.is_occupied(xy), prob[iy, ix])


def test_map_with_slam_poses_undoes_the_odometry_drift(tmp_path):
    """The first two legs of the cave tour (16 m, 320 scans) with 10 % odometry noise, as a raw
    log whose pose slots hold the drifting odometry: --poses log maps with it, --poses slam with
    the replay (SLAM on every scan, the map from every 4th). Measured: AUC against the true map
    0.900 (odometry) and 0.986 (SLAM); trajectory at most 0.024 m off the truth (odometry 1.01 m)."""
    from sim.lidar import Lidar
    from sim.odometry import Odometry, OdometryNoise
    from sim.robot import Robot
    from sim.tour import drive_tour
    from sim.worlds import cave
    from slam.g2o import read_g2o
    from slam.tum import read_tum

    builtin = cave()
    noise = OdometryNoise(alpha1=0.1**2, alpha2=0.1**2, alpha3=0.1**2)
    odometry = Odometry(noise, seed=0, start=builtin.start)    # the odometry frame is the world's
    drive = drive_tour(Robot(builtin.world, builtin.start), Lidar(seed=0), odometry, builtin.tour[:3])
    log = tmp_path / "cave.clf"
    write_flaser_log(log, drive.odometry, drive.scans, period=0.1)
    auc = {}
    for poses in ("log", "slam"):
        out = tmp_path / poses
        result = CliRunner().invoke(app, ["map", str(log), "--poses", poses, "--out", str(out),
                                          "--max-range", "8", "--every", "4"])
        assert result.exit_code == 0, result.output
        auc[poses] = auc_against_truth(np.load(out / "com.npz"), builtin.world)
    stamps, trajectory = read_tum(tmp_path / "slam" / "trajectory.tum")
    assert len(trajectory) == len(drive.scans) and stamps[1] == pytest.approx(0.1)
    error = {name: max(np.hypot(*(e.translation() - t.translation())) for e, t in zip(estimate, drive.truth))
             for name, estimate in (("odometry", drive.odometry), ("slam", trajectory))}
    assert error["odometry"] > 0.5 and error["slam"] < 0.1, error
    assert auc["slam"] > 0.97 and auc["slam"] > auc["log"] + 0.05, auc
    metrics = json.loads((tmp_path / "slam" / "metrics.json").read_text())
    assert metrics["poses"] == "slam" and metrics["keyframes"] == len(range(0, len(drive.scans), 4))
    assert metrics["slam"]["scans"] == len(drive.scans) and metrics["slam"]["wall_time_s"] > 0
    assert len(read_g2o(tmp_path / "slam" / "graph.g2o").poses) == metrics["slam"]["keyframes"]


@pytest.mark.parametrize("option, value, message", [
    ("--holdout", "1", "'--holdout': 1.0 is not a fraction in [0, 1)"),
    ("--holdout", "-0.2", "'--holdout': -0.2 is not a fraction in [0, 1)"),
    ("--holdout", "nan", "'--holdout': nan is not a fraction in [0, 1)"),
    ("--max-range", "0", "'--max-range': 0.0 is not a positive finite number"),
    ("--max-range", "-3", "'--max-range': -3.0 is not a positive finite number"),
    ("--max-range", "inf", "'--max-range': inf is not a positive finite number"),
    ("--every", "0", "'--every': Input should be greater than or equal to 1"),
    ("--poses", "gps", "'--poses': Value error, 'gps' is not one of 'log', 'slam'"),
    ("--config", "missing.toml", "'--config': file 'missing.toml' does not exist"),
])
def test_map_command_rejects_bad_options_by_name_and_value(tmp_path, option, value, message):
    log = tmp_path / "x.clf"
    log.write_text("FLASER 2 1.0 1.0 0 0 0 0 0 0 0 h 0\n")
    result = CliRunner().invoke(app, ["map", str(log), "--out", str(tmp_path / "o"), option, value])
    assert result.exit_code == 2 and message in one_line(result.output), result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("poses", ["log", "slam"])
def test_map_command_reports_log_errors_with_the_line(tmp_path, poses):
    log = tmp_path / "bad.clf"
    log.write_text("# a log\nFLASER 3 1.0 1.0 0 0 0 0 0 0 0 h 0\n")
    result = CliRunner().invoke(app, ["map", str(log), "--poses", poses, "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "bad.clf:2: FLASER line has 2 ranges for n = 3" in one_line(result.output)


def test_ros_map_pgm_is_trinary_top_row_first(tmp_path):
    prob = np.array([[0.9, 0.1], [0.5, 0.5]])            # row 0 at the bottom
    write_ros_map(tmp_path / "m.pgm", prob, np.array([1.05, 2.05]), 0.1)
    data = (tmp_path / "m.pgm").read_bytes()
    assert data.startswith(b"P5\n2 2\n255\n")
    assert list(data[-4:]) == [205, 205, 0, 254]            # top row (row 1) first
    assert yaml.safe_load((tmp_path / "m.yaml").read_text())["origin"] == pytest.approx([1.0, 2.0, 0.0])


def test_entropy_and_coverage_and_auc():
    frame = GridFrame(0.1)
    frame.ensure(np.array([0, 0]), np.array([9, 9]))
    square = (0.0, 1.0, 0.0, 1.0)                      # 25 cells of 0.2 m
    assert map_entropy(frame, np.full(frame.shape, 0.5), square) == pytest.approx(25 * np.log(2))
    assert map_entropy(frame, np.full(frame.shape, 1e-9), square) < 1e-6
    # off the map is unknown: ln 2 per cell however sure the map is
    far = (100.0, 101.0, 100.0, 101.0)
    assert map_entropy(frame, np.full(frame.shape, 1e-9), far) == pytest.approx(25 * np.log(2))
    free_space = np.array([0.1, 0.5, 0.35])              # the map read at the true free space
    assert coverage(free_space, 0.2) == pytest.approx(1 / 3)
    assert coverage(free_space) == pytest.approx(2 / 3)  # known: |p - 0.5| > 0.1
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


@pytest.fixture(scope="module")
def intel_maps(shared_data, tmp_path_factory):
    """`gpexplore map` on the whole Intel log, 20 % of each scan's labelled points held out, with
    the log's poses and with the SLAM replay's: {poses: (metrics, output folder)}."""
    maps = {}
    for poses in ("log", "slam"):
        out = tmp_path_factory.mktemp(f"intel-{poses}")
        result = CliRunner().invoke(app, ["map", str(shared_data / "logs" / "intel-corrected.log.gz"),
                                          "--poses", poses, "--holdout", "0.2", "--out", str(out)])
        assert result.exit_code == 0, result.output
        maps[poses] = json.loads((out / "metrics.json").read_text()), out
    return maps


@pytest.mark.slow
def test_intel_log_heldout_auc(intel_maps):
    """The whole Intel log with its poses: the issue's target, AUC >= 0.995 read continuously."""
    metrics, out = intel_maps["log"]
    assert metrics["keyframes"] == 910 and metrics["holdout"]["protocol"] == "points"
    assert metrics["software"]["packages"]["numpy"] == np.__version__     # what it was computed with
    assert metrics["auc"] >= 0.995                      # measured 0.9956
    assert metrics["auc_cell"] > 0.992                  # measured 0.9944
    assert np.isfinite(np.load(out / "com.npz")["prob"]).all()


@pytest.mark.slow
def test_intel_slam_poses_map_nearly_as_well_as_the_corrected_log(intel_maps):
    """The same protocol with the poses of our SLAM replay (from the log's raw odometry) instead
    of GMapping's. Measured: AUC 0.9905 read continuously, 0.9886 per cell (log poses 0.9956,
    0.9944; raw odometry 0.857, 0.848); replay 9.7 s, 113 loop closures."""
    log, _ = intel_maps["log"]
    slam, out = intel_maps["slam"]
    assert slam["slam"]["scans"] == 910 and slam["slam"]["loop_closures"] > 0
    assert slam["auc"] > log["auc"] - 0.01 and slam["auc_cell"] > log["auc_cell"] - 0.01
    assert (out / "trajectory.tum").exists() and (out / "graph.g2o").exists()


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


def corridor_log(path, odometry_drift=None):
    """A CARMEN log in the corridor world; with ``odometry_drift`` (rad per scan) a corrected log
    whose odometry turns away from its poses."""
    from sim.lidar import Lidar, LidarConfig

    world = corridor_world()
    poses = [gtsam.Pose2(x, 2.0, 0.0) for x in np.arange(1.5, 8.0, 0.5)]
    lidar = Lidar(LidarConfig(beams=90), seed=0)
    scans = [lidar.scan(world, p) for p in poses]
    odometry = None
    if odometry_drift is not None:
        odometry = [gtsam.Pose2(p.x(), p.y(), k * odometry_drift) for k, p in enumerate(poses)]
    write_flaser_log(path, poses, scans, odometry=odometry)
    return path


def test_map_at_a_raw_logs_own_poses_warns_and_suggests_slam_poses(tmp_path):
    raw = corridor_log(tmp_path / "raw.clf")
    result = CliRunner().invoke(app, ["map", str(raw), "--out", str(tmp_path / "raw"), "--max-range", "8"])
    assert result.exit_code == 0, result.output
    assert "warning: raw.clf has no corrected poses" in one_line(result.output)
    assert "--poses slam" in one_line(result.output)
    assert "no corrected poses" in json.loads((tmp_path / "raw" / "metrics.json").read_text())["warnings"][0]
    corrected = corridor_log(tmp_path / "corrected.clf", odometry_drift=0.02)
    result = CliRunner().invoke(app, ["map", str(corrected), "--out", str(tmp_path / "c"), "--max-range", "8"])
    assert result.exit_code == 0 and "warning" not in result.output, result.output
    assert json.loads((tmp_path / "c" / "metrics.json").read_text())["warnings"] == []


def test_map_skips_malformed_lines_when_asked_and_says_how(tmp_path):
    log = corridor_log(tmp_path / "log.clf")
    lines = log.read_text().splitlines()
    lines.insert(3, "FLASER 3 1.0 1.0 0 0 0 0 0 0 0 h 0")
    log.write_text("\n".join(lines) + "\n")
    result = CliRunner().invoke(app, ["map", str(log), "--out", str(tmp_path / "o"), "--max-range", "8"])
    assert result.exit_code == 2 and "log.clf:4: FLASER line has 2 ranges" in one_line(result.output)
    assert "--skip-malformed skips such lines" in one_line(result.output) and not (tmp_path / "o").exists()
    result = CliRunner().invoke(app, ["map", str(log), "--out", str(tmp_path / "o"), "--max-range", "8",
                                      "--skip-malformed"])
    assert result.exit_code == 0, result.output
    assert "skipped 1 malformed lines (first: line 4" in one_line(result.output)
    assert (tmp_path / "o" / "com.npz").exists()


def test_map_refuses_a_folder_gpexplore_did_not_write(tmp_path):
    log = corridor_log(tmp_path / "log.clf")
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("x")
    result = CliRunner().invoke(app, ["map", str(log), "--out", str(tmp_path / "mine"), "--overwrite"])
    assert result.exit_code == 2 and "not a gpexplore run folder" in one_line(result.output)
    assert (tmp_path / "mine" / "notes.txt").exists()
