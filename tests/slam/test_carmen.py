"""CARMEN reader and corrected-log writer."""

import gzip
import math

import gtsam
import numpy as np
import pytest

from slam.carmen import CarmenLog, LogFormatError, write_corrected_log


def flaser(ranges, pose, odom, stamp):
    r = " ".join(f"{v:.2f}" for v in ranges)
    return (f"FLASER {len(ranges)} {r} {pose[0]} {pose[1]} {pose[2]} {odom[0]} {odom[1]} {odom[2]} "
            f"{stamp} host {stamp}\n")


def test_flaser_fields_angles_and_no_return(tmp_path):
    ranges = [1.0] * 181
    ranges[0], ranges[1], ranges[2] = 81.91, float("nan"), -1.0
    path = tmp_path / "a.clf"
    path.write_text("# comment\nPARAM robot_use_laser on 1 host 1\nUNKNOWN 1 2 3\n"
                    + flaser(ranges, (1, 2, 0.5), (3, 4, 0.25), 100.5))
    log = CarmenLog(path)
    assert len(log) == 1 and log.params["robot_use_laser"] == "on"
    rec = log[0]
    assert rec.line == 4 and rec.scan.timestamp == 100.5
    assert rec.pose.equals(gtsam.Pose2(1, 2, 0.5), 1e-12)
    assert rec.odometry.equals(gtsam.Pose2(3, 4, 0.25), 1e-12)   # raw log: odometry slot
    assert rec.scan.angles[0] == pytest.approx(-math.pi / 2)       # beam 0 at -90 deg
    assert rec.scan.angles[-1] == pytest.approx(math.pi / 2)       # 181 beams include both ends
    assert not rec.scan.hit[:3].any() and rec.scan.no_return[0] and rec.scan.hit[3:].all()


def test_malformed_line_is_named_or_skipped(tmp_path):
    good = flaser([1.0] * 180, (0, 0, 0), (0, 0, 0), 1.0)
    bad = "FLASER 180 " + " ".join(["1.0"] * 171) + " 0 0 0 0 0 0 2.0 host 2.0\n"
    path = tmp_path / "bad.clf"
    path.write_text(good + bad + good.replace(" 1.0 host", " 3.0 host"))
    with pytest.raises(LogFormatError, match=r"bad\.clf:2: FLASER line has 171 ranges"):
        CarmenLog(path)
    log = CarmenLog(path, skip_malformed=True)
    assert len(log) == 2 and [n for n, _ in log.skipped] == [2]


def test_empty_and_laserless_logs_are_clear_errors(tmp_path):
    empty = tmp_path / "empty.clf"
    empty.write_text("")
    with pytest.raises(LogFormatError, match="empty.clf: no laser messages"):
        CarmenLog(empty)
    odom_only = tmp_path / "odom.clf.gz"
    with gzip.open(odom_only, "wt") as f:
        f.write("ODOM 0 0 0 0 0 0 1.0 host 1.0\n")
    with pytest.raises(LogFormatError, match="no laser messages"):
        CarmenLog(odom_only)


def test_gmapping_rebased_odom_lines_are_chained_into_raw_odometry(tmp_path):
    # GMapping writes ODOM lines that continue from the corrected pose after each scan.
    corrected = [gtsam.Pose2(0, 0, 0), gtsam.Pose2(1.1, 0.05, 0.1), gtsam.Pose2(2.3, 0.1, 0.15)]
    wheel = [gtsam.Pose2(0, 0, 0), gtsam.Pose2(1.0, 0.0, 0.0), gtsam.Pose2(2.0, 0.0, 0.05)]
    lines = []
    for k, c in enumerate(corrected):
        if k == 0:
            odom = wheel[0]
        else:  # the last ODOM before scan k: corrected[k-1] ∘ (wheel increment)
            odom = corrected[k - 1].compose(wheel[k - 1].between(wheel[k]))
        lines.append(f"ODOM {odom.x()} {odom.y()} {odom.theta()} 0 0 0 {k + 0.5} pippo {k + 0.5}\n")
        p = (c.x(), c.y(), c.theta())
        lines.append(flaser([1.0] * 180, p, p, k + 1.0))
        stamp = ["0", "4.58333e-72", "5.21"][k]      # meant to be 0; intel has garbage there
        lines.append(f"ODOM {c.x()} {c.y()} {c.theta()} 0 0 0 {stamp} pippo {stamp}\n")
        lines.append("NEFF 30\n")
    path = tmp_path / "c.log"
    path.write_text("".join(lines))
    log = CarmenLog(path)
    assert log.rebased_odometry
    for k in range(1, 3):
        step = log[k - 1].odometry.between(log[k].odometry)
        assert step.equals(wheel[k - 1].between(wheel[k]), 1e-9)
        assert log[k].pose.equals(corrected[k], 1e-9)


def test_corrected_log_roundtrip(tmp_path):
    path = tmp_path / "a.clf"
    path.write_text("".join(flaser([1.0 + i] * 180, (0, 0, 0), (0, 0, 0), 10.0 + i) for i in range(3)))
    log = CarmenLog(path)
    poses = [gtsam.Pose2(i, 2 * i, 0.1 * i) for i in range(3)]
    write_corrected_log(tmp_path / "out.clf", log, poses)
    again = CarmenLog(tmp_path / "out.clf")
    for rec, new, pose in zip(log, again, poses):
        assert new.pose.equals(pose, 1e-6) and new.odometry.equals(pose, 1e-6)
        np.testing.assert_array_equal(new.scan.ranges, rec.scan.ranges)
        assert new.scan.timestamp == rec.scan.timestamp


@pytest.mark.parametrize("name, scans", [("freiburg-079-corrected.log.gz", 4791), ("intel-corrected.log.gz", 910)])
def test_real_corrected_log_odometry_is_wheel_odometry(shared_data, name, scans):
    log = CarmenLog(shared_data / "logs" / name)
    assert log.rebased_odometry and len(log) == scans
    # the wheel odometry drifts away from the SLAM poses over the run (metres by the end)
    end = log[-1].pose.between(log[0].pose.compose(log[0].odometry.between(log[-1].odometry)))
    assert math.hypot(end.x(), end.y()) > 1.0
    # ...but step by step it is close to the SLAM motion (a few centimetres)
    steps = [np.hypot(*(a.pose.between(b.pose).translation() - a.odometry.between(b.odometry).translation()))
             for a, b in zip(log.records[:-1], log.records[1:])]
    assert np.median(steps) < 0.06 and max(steps) < 0.5     # no jumps from missed re-basing


def test_a_scan_with_no_odom_line_since_the_last_has_no_odometry(tmp_path):
    """Örebro's corrected log: ODOM lines only repeat the corrected pose after each scan, with a
    wheel increment before a few scans. A stale value would claim the robot stood still."""
    corrected = [gtsam.Pose2(0, 0, 0), gtsam.Pose2(1.5, 0.2, 0.4), gtsam.Pose2(3.0, 0.5, 0.6)]
    lines = ["ODOM 0 0 0 0 0 0 0 pippo 0\n"]           # as Örebro's log starts
    for k, c in enumerate(corrected):
        if k == 2:                                 # a wheel increment before the third scan only
            odom = corrected[1].compose(gtsam.Pose2(1.4, 0.1, 0.2))
            lines.append(f"ODOM {odom.x()} {odom.y()} {odom.theta()} 0 0 0 0 pippo 0\n")
        p = (c.x(), c.y(), c.theta())
        lines.append(flaser([1.0] * 181, p, p, 0.0))
        lines.append(f"ODOM {c.x()} {c.y()} {c.theta()} 0 0 0 0 pippo 0\n")
    path = tmp_path / "o.log"
    path.write_text("".join(lines))
    log = CarmenLog(path)
    assert log.rebased_odometry and log.has_odom_lines
    assert log.duration is None                     # all stamps 0: no duration to speak of
    assert log[0].odometry.equals(gtsam.Pose2(), 1e-12)
    assert log[1].odometry is None                  # nothing was logged between scans 0 and 1
    # the increment before scan 2 chains on from scan 0's odometry (none came in between)
    assert log[2].odometry.equals(gtsam.Pose2(1.4, 0.1, 0.2), 1e-9)


def test_a_malformed_line_error_carries_its_line_number(tmp_path):
    path = tmp_path / "bad.clf"
    path.write_text(flaser([1.0] * 3, (0, 0, 0), (0, 0, 0), 1.0) + "FLASER 3 1.0 0 0 0 0 0 0 2.0 host 2.0\n")
    with pytest.raises(LogFormatError) as err:
        CarmenLog(path)
    assert err.value.line == 2
    empty = tmp_path / "empty.clf"
    empty.write_text("")
    with pytest.raises(LogFormatError) as err:
        CarmenLog(empty)
    assert err.value.line is None


def test_corrected_poses_are_told_from_raw_odometry(tmp_path):
    path = tmp_path / "raw.clf"
    path.write_text("".join(flaser([1.0] * 3, (0.1 * k, 0, 0), (0.1 * k, 0, 0), k) for k in range(10)))
    assert not CarmenLog(path).has_corrected_poses()
    # poses that part from the odometry by a turn of 0.2 rad are corrected poses
    path.write_text("".join(flaser([1.0] * 3, (0.1 * k, 0, 0), (0.1 * k, 0, 0.02 * k), k) for k in range(11)))
    assert CarmenLog(path).has_corrected_poses()


@pytest.mark.parametrize("name, corrected", [("mit-csail.clf", False), ("intel-corrected.log.gz", True),
                                             ("belgioioso-corrected.log.gz", True)])
def test_real_logs_corrected_or_raw(shared_data, name, corrected):
    assert CarmenLog(shared_data / "logs" / name).has_corrected_poses() == corrected


def robotlaser(ranges, laser, robot, stamp):
    """A ROBOTLASER1 line: 180° from -90°, 1° steps, no remissions."""
    r = " ".join(f"{v:.2f}" for v in ranges)
    poses = " ".join(str(v) for v in (*laser, *robot))
    return (f"ROBOTLASER1 0 {-math.pi / 2} {math.pi} {math.pi / 180} 81.9 0.01 0 {len(ranges)} {r} 0 "
            f"{poses} 0.1 0.0 0.5 0.3 0.0 {stamp} host {stamp}\n")


MOUNT = gtsam.Pose2(0.3, 0.1, 0.2)


@pytest.mark.parametrize("kind", ["ROBOTLASER1", "FLASER"])
def test_a_lines_laser_offset_is_read_and_the_pose_is_the_robots(tmp_path, kind):
    robots = [gtsam.Pose2(5, -2, 0.4), gtsam.Pose2(6, -1.5, 0.9)]
    line = robotlaser if kind == "ROBOTLASER1" else flaser
    path = tmp_path / "mounted.clf"
    path.write_text("".join(line([2.0] * 181, pose_triple(r.compose(MOUNT)), pose_triple(r), 1.0 + k)
                            for k, r in enumerate(robots)))
    log = CarmenLog(path)
    assert log.laser_offset.equals(MOUNT, 1e-6) and log.laser_offset_source == "log"
    for record, robot in zip(log, robots):
        assert record.laser_offset.equals(MOUNT, 1e-6)
        assert record.pose.equals(robot, 1e-6)           # the base's pose, not the laser's
        assert record.odometry.equals(robot, 1e-6)
    write_corrected_log(tmp_path / "out.clf", log, robots)
    again = CarmenLog(tmp_path / "out.clf")              # the laser pose is written at base ∘ mount
    assert again.laser_offset.equals(MOUNT, 1e-5)
    assert all(a.pose.equals(r, 1e-5) for a, r in zip(again, robots))


def test_a_log_whose_two_poses_agree_states_no_offset(shared_data, tmp_path):
    from slam.laser_log import laser_mount

    log = CarmenLog(shared_data / "logs" / "mit-csail.clf")
    assert log.laser_offset is None
    assert all(r.pose.equals(r.odometry, 0) for r in log)
    mount = laser_mount(log, [0.3, 0.1, 0.2])            # the configured one applies
    assert mount.source == "configuration" and mount.pose.equals(MOUNT, 1e-12)


def test_a_configured_offset_that_the_log_contradicts_is_warned_about(tmp_path):
    from slam.laser_log import laser_mount

    path = tmp_path / "mounted.clf"
    robot = gtsam.Pose2(1, 1, 0)
    path.write_text(robotlaser([2.0] * 181, pose_triple(robot.compose(MOUNT)), pose_triple(robot), 1.0))
    log = CarmenLog(path)
    assert laser_mount(log, [0, 0, 0]).warning is None
    mount = laser_mount(log, [0.2, 0.0, 0.0])
    assert mount.pose.equals(MOUNT, 1e-6) and mount.source == "log"
    assert "mounted.clf" in mount.warning and "0.200 m" in mount.warning


def pose_triple(pose: gtsam.Pose2) -> tuple[float, float, float]:
    return pose.x(), pose.y(), pose.theta()
