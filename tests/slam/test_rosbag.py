"""ROS bags in: LaserScan and Odometry messages written with rosbags' own writers (ROS 1, ROS 2
sqlite3 and MCAP) from a simulated tour, read back, replayed and mapped."""

import json
import math
import sys

import gtsam
import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore
from typer.testing import CliRunner

from sim.cli import app
from slam.rosbag import BagError, RosBag, is_bag
from slam.scan import LaserScan
from slam.tum import read_tum

T0 = 1_700_000_000     # the bag clock at the tour's start, s
STORAGES = ["ros1", "sqlite3", "mcap", "mcap-file"]


def write_bag(path, storage, topics, range_min=0.0, scan_frame="base_link", static=()):
    """A bag at ``path`` in ``storage`` (ros1: a .bag; sqlite3, mcap: a ROS 2 bag directory;
    mcap-file: the .mcap inside one) holding ``topics``: name → LaserScans (stamped by their
    ``timestamp``, in ``scan_frame``) or (stamp, Pose2) odometry (of ``base_link``), and
    ``static``: (parent, child, Pose2) transforms on /tf_static. Returns the path to read."""
    ros1 = storage == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if "tf2_msgs/msg/TFMessage" not in store.types:
        from rosbags.typesys import get_types_from_msg
        store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    t = store.types

    def header(stamp, frame_id="base_link"):
        sec, nanosec = divmod(round(stamp * 1e9), 10**9)
        return t["std_msgs/msg/Header"](**({"seq": 0} if ros1 else {}),
                                        stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
                                        frame_id=frame_id)

    def quaternion(yaw):
        return t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))

    def static_message(stamp):
        return stamp, "tf2_msgs/msg/TFMessage", t["tf2_msgs/msg/TFMessage"](transforms=[
            t["geometry_msgs/msg/TransformStamped"](
                header=header(stamp, parent), child_frame_id=child,
                transform=t["geometry_msgs/msg/Transform"](
                    translation=t["geometry_msgs/msg/Vector3"](x=p.x(), y=p.y(), z=0.2),
                    rotation=quaternion(p.theta())))
            for parent, child, p in static])

    def scan_message(s: LaserScan):
        step = float(s.angles[1] - s.angles[0])
        return s.timestamp, "sensor_msgs/msg/LaserScan", t["sensor_msgs/msg/LaserScan"](
            header=header(s.timestamp, scan_frame), angle_min=float(s.angles[0]), angle_max=float(s.angles[-1]),
            angle_increment=step, time_increment=0.0, scan_time=0.1, range_min=range_min,
            range_max=s.max_range, ranges=s.ranges.astype(np.float32), intensities=np.zeros(0, np.float32))

    def odometry_message(stamp, pose: gtsam.Pose2):
        vector = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        q = t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(pose.theta() / 2),
                                              w=math.cos(pose.theta() / 2))
        return stamp, "nav_msgs/msg/Odometry", t["nav_msgs/msg/Odometry"](
            header=header(stamp), child_frame_id="base_link",
            pose=t["geometry_msgs/msg/PoseWithCovariance"](
                pose=t["geometry_msgs/msg/Pose"](
                    position=t["geometry_msgs/msg/Point"](x=pose.x(), y=pose.y(), z=0.0), orientation=q),
                covariance=np.zeros(36)),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](linear=vector, angular=vector), covariance=np.zeros(36)))

    messages = sorted(((topic, *(scan_message(m) if isinstance(m, LaserScan) else odometry_message(*m)))
                       for topic, items in topics.items() for m in items), key=lambda m: m[1])
    if static:
        messages.insert(0, ("/tf_static", *static_message(messages[0][1])))
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
        writer = Writer2(path, version=9, storage_plugin=plugin)
    with writer:
        connections = {topic: writer.add_connection(topic, msgtype, typestore=store)
                       for topic, _, msgtype, _ in {m[0]: m for m in messages}.values()}
        serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
        for topic, stamp, msgtype, message in messages:
            writer.write(connections[topic], round(stamp * 1e9), serialize(message, msgtype))
    return path / f"{path.name}.mcap" if storage == "mcap-file" else path


def bag_path(tmp_path, storage, name="tour"):
    return tmp_path / (f"{name}.bag" if storage == "ros1" else name)


@pytest.fixture(scope="module")
def tour():
    """The first leg of the cave tour (~170 scans at 10 Hz, 2 % beam dropouts read NaN), with 10 %
    odometry noise in an odometry frame turned by π from the world's, so its yaw wraps at ±π while
    the robot heads east. Scans are stamped on the bag clock."""
    from sim.lidar import Lidar, LidarConfig
    from sim.odometry import Odometry, OdometryNoise
    from sim.robot import Robot
    from sim.tour import drive_tour
    from sim.worlds import cave

    builtin = cave()
    noise = OdometryNoise(alpha1=0.1**2, alpha2=0.1**2, alpha3=0.1**2)
    odometry = Odometry(noise, seed=0, start=gtsam.Pose2(1.0, -2.0, builtin.start.theta() + math.pi))
    lidar = Lidar(LidarConfig(dropout=0.02, dropout_value="nan"), seed=0)
    drive = drive_tour(Robot(builtin.world, builtin.start), lidar, odometry, builtin.tour[:3])
    drive.scans = [LaserScan(s.ranges, s.angles, s.max_range, T0 + s.timestamp) for s in drive.scans]
    drive.stamps = [T0 + t for t in drive.stamps]
    return drive


def odometry_at_half_rate(drive):
    """Odometry messages at every other scan from the second on, and at the last: the first scan
    comes before any odometry and those in between are interpolated."""
    ks = sorted(set(range(1, len(drive.stamps), 2)) | {len(drive.stamps) - 1})
    return ks, [(drive.stamps[k], drive.odometry[k]) for k in ks]


@pytest.fixture(scope="module")
def bags(tour, tmp_path_factory):
    """The tour written in every storage: {storage: path}."""
    folder = tmp_path_factory.mktemp("bags")
    _, odometry = odometry_at_half_rate(tour)
    return {storage: write_bag(bag_path(folder, storage, storage), storage,
                               {"/scan": tour.scans, "/odom": odometry})
            for storage in STORAGES}


@pytest.mark.parametrize("storage", STORAGES)
def test_records_read_back_equal_the_written_scans_and_odometry(tour, bags, storage):
    bag = RosBag(bags[storage])
    assert is_bag(bags[storage])
    assert (bag.scan_topic, bag.odom_topic) == ("/scan", "/odom")
    ks, _ = odometry_at_half_rate(tour)
    assert len(bag) == len(tour.scans) - 1
    assert bag.skipped and bag.skipped[0][0] == 1 and len(bag.skipped) == 1
    assert "before the first odometry message" in bag.skipped[0][1]
    assert any(np.isnan(tour.scans[k].ranges).any() for k in range(1, len(tour.scans)))
    for k, record in enumerate(bag, start=1):
        written = tour.scans[k]
        assert record.index == k + 1
        assert record.scan.timestamp == pytest.approx(written.timestamp, abs=1e-6)
        assert record.scan.max_range == written.max_range
        np.testing.assert_allclose(record.scan.angles, written.angles, atol=1e-6)
        np.testing.assert_allclose(record.scan.ranges, written.ranges, rtol=1e-6, equal_nan=True)
        np.testing.assert_array_equal(record.scan.hit, written.hit)
        np.testing.assert_array_equal(record.scan.no_return, written.no_return)
        # exact at an odometry message; halfway between two (x, y and yaw along the shorter arc)
        if k in ks:
            expected = tour.odometry[k]
        else:
            a, b = tour.odometry[k - 1], tour.odometry[k + 1]
            expected = gtsam.Pose2((a.x() + b.x()) / 2, (a.y() + b.y()) / 2,
                                   a.theta() + a.rotation().between(b.rotation()).theta() / 2)
        assert record.pose.equals(expected, 1e-6), (k, record.pose, expected)
        error = tour.odometry[k].between(record.pose)
        assert np.hypot(error.x(), error.y()) < 0.03 and abs(error.theta()) < 0.03, (k, error)
        assert record.odometry.equals(record.pose, 1e-12)
    yaw = np.array([p.theta() for p in tour.odometry])
    assert (yaw > 3.0).any() and (yaw < -3.0).any()       # the wrap was interpolated across


def ate(estimate, truth):
    """RMS position error after anchoring the first pose to the truth (m)."""
    anchor = truth[0].compose(estimate[0].inverse())
    return float(np.sqrt(np.mean([np.sum((anchor.compose(e).translation() - t.translation()) ** 2)
                                  for e, t in zip(estimate, truth)])))


def one_line(output):
    return " ".join(output.replace("│", " ").split())


def test_replay_and_map_commands_on_a_bag(tour, bags, tmp_path):
    """SLAM over the MCAP bag stays near the truth: ATE 0.010 m against the odometry's 0.47 m
    (measured); the map command maps the ROS 1 bag with its odometry."""
    out = tmp_path / "replay"
    result = CliRunner().invoke(app, ["replay", str(bags["mcap"]), "--out", str(out)])
    assert result.exit_code == 0, result.output
    text = one_line(result.output)
    assert "skipped 1 scans (first: scan 1:" in text and "corrected.clf" not in text
    stamps, trajectory = read_tum(out / "trajectory.tum")
    truth = tour.truth[1:]
    assert len(trajectory) == len(truth) and stamps[0] == pytest.approx(tour.stamps[1])
    slam_ate, odometry_ate = ate(trajectory, truth), ate(tour.odometry[1:], truth)
    assert odometry_ate > 0.3 and slam_ate < 0.05, (slam_ate, odometry_ate)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["scans"] == len(truth) and metrics["skipped_scans"] == 1
    assert (metrics["scan_topic"], metrics["odom_topic"]) == ("/scan", "/odom")
    assert not (out / "corrected.clf").exists() and (out / "graph.g2o").exists()

    out = tmp_path / "map"
    result = CliRunner().invoke(app, ["map", str(bags["ros1"]), "--out", str(out), "--every", "8",
                                      "--scan-topic", "/scan", "--odom-topic", "/odom"])
    assert result.exit_code == 0, result.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["keyframes"] == len(range(0, len(truth), 8)) and metrics["auc"] > 0.9


def small_scans(n=3, ranges=(1.0, 2.0, 3.0), start=0.0):
    return [LaserScan(np.array(ranges) + k, np.array([-0.1, 0.0, 0.1]), 8.0, start + 0.1 * k) for k in range(n)]


def small_odometry(n=2, start=0.0):
    return [(start + 0.2 * k, gtsam.Pose2(0.1 * k, 0.0, 0.0)) for k in range(n)]


@pytest.mark.parametrize("storage", ["ros1", "sqlite3"])
def test_topics_are_detected_or_chosen_by_name(tmp_path, storage):
    rear = small_scans(ranges=(5.0, 5.0, 5.0))
    path = write_bag(bag_path(tmp_path, storage, "two"), storage,
                     {"/scan": small_scans(), "/scan_rear": rear, "/odom": small_odometry()})
    assert RosBag(path).scan_topic == "/scan"
    chosen = RosBag(path, scan_topic="/scan_rear")
    assert chosen.scan_topic == "/scan_rear" and chosen[0].scan.ranges[0] == 5.0
    path = write_bag(bag_path(tmp_path, storage, "ambiguous"), storage,
                     {"/front": small_scans(), "/rear": rear, "/wheel": small_odometry()})
    with pytest.raises(BagError, match=r"several sensor_msgs/LaserScan topics \(/front, /rear\): "
                                       r"choose one with --scan-topic"):
        RosBag(path)
    bag = RosBag(path, scan_topic="/rear")
    assert bag.odom_topic == "/wheel"


@pytest.mark.parametrize("topics, options, message", [
    ({"/odom": small_odometry()}, {},
     "no sensor_msgs/LaserScan topic (topics: /odom (nav_msgs/Odometry))"),
    ({"/scan": small_scans()}, {}, "no nav_msgs/Odometry topic (topics: /scan (sensor_msgs/LaserScan))"),
    ({"/scan": small_scans(), "/odom": small_odometry()}, {"scan_topic": "/laser"},
     "no topic '/laser' (--scan-topic); sensor_msgs/LaserScan topics: /scan"),
    ({"/scan": small_scans(), "/odom": small_odometry()}, {"odom_topic": "/scan"},
     "topic '/scan' (--odom-topic) holds sensor_msgs/LaserScan, not nav_msgs/Odometry"),
    ({"/scan": small_scans(start=5.0), "/odom": small_odometry()}, {},
     "none of the 3 scans on '/scan' lies within the odometry's time span (0.000 to 0.200 s)"),
])
def test_bags_without_usable_scans_or_odometry_are_refused_by_name(tmp_path, topics, options, message):
    path = write_bag(tmp_path / "bad", "mcap", topics)
    with pytest.raises(BagError) as err:
        RosBag(path, **options)
    assert str(err.value) == f"{path}: {message}"


def test_range_conventions_and_yaw_interpolation_across_the_wrap(tmp_path):
    # below range_min, -inf and NaN carry nothing; at or past range_max and +inf are no return
    ranges = [0.05, 1.0, 5.0, 7.0, np.inf, -np.inf, np.nan]
    scan = LaserScan(np.array(ranges), np.linspace(-0.3, 0.3, 7), 5.0, timestamp=0.5)
    odometry = [(0.0, gtsam.Pose2(0.0, 0.0, 3.0)), (1.0, gtsam.Pose2(1.0, 2.0, -3.0))]
    path = write_bag(tmp_path / "ranges", "sqlite3", {"/scan": [scan], "/odom": odometry}, range_min=0.1)
    record = RosBag(path)[0]
    assert record.scan.max_range == 5.0
    np.testing.assert_array_equal(record.scan.hit, [False, True, False, False, False, False, False])
    np.testing.assert_array_equal(record.scan.no_return, [False, False, True, True, True, False, False])
    assert np.isnan(record.scan.ranges[[0, 5, 6]]).all()
    assert RosBag(path, max_range=0.5)[0].scan.no_return[1]      # the smaller range rules
    # halfway from 3.0 to -3.0 rad along the shorter arc is π, not 0
    assert record.pose.x() == pytest.approx(0.5) and record.pose.y() == pytest.approx(1.0)
    assert abs(record.pose.theta()) == pytest.approx(math.pi, abs=1e-6)


def test_cli_errors_on_bad_bags_exit_2_naming_the_file(tmp_path, monkeypatch):
    runner = CliRunner()
    path = write_bag(tmp_path / "small.bag", "ros1", {"/scan": small_scans(), "/odom": small_odometry()})
    result = runner.invoke(app, ["replay", str(path), "--scan-topic", "/laser", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and f"{path}: no topic '/laser' (--scan-topic)" in one_line(result.output)
    result = runner.invoke(app, ["map", str(path), "--odom-topic", "/scan", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "holds sensor_msgs/LaserScan, not nav_msgs/Odometry" in \
        one_line(result.output)
    garbage = tmp_path / "garbage.bag"
    garbage.write_bytes(b"not a bag at all\n" * 10)
    for command in ("replay", "map"):
        result = runner.invoke(app, [command, str(garbage), "--out", str(tmp_path / "o")])
        assert result.exit_code == 2 and f"{garbage}: cannot read bag" in one_line(result.output), result.output
    clf = tmp_path / "x.clf"
    clf.write_text("FLASER 2 1.0 1.0 0 0 0 0 0 0 0 h 0\n")
    result = runner.invoke(app, ["replay", str(clf), "--scan-topic", "/scan", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "topics are for ROS bags" in one_line(result.output)
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)      # rosbags not installed
    result = runner.invoke(app, ["replay", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "pip install gpexplore[ros]" in one_line(result.output)
    assert not (tmp_path / "o").exists()


MOUNT = gtsam.Pose2(0.3, 0.1, 0.2)      # the laser on the base: 0.3 m ahead, 0.1 m left, 0.2 rad


@pytest.mark.parametrize("storage", ["ros1", "mcap"])
def test_the_laser_offset_is_read_from_tf_static_through_a_chain_of_frames(tmp_path, storage):
    from slam.laser_log import laser_mount

    # base_footprint ← base_link ← laser, and a sibling frame; the odometry's child is base_link
    to_base_link = gtsam.Pose2(0.05, 0.0, 0.0)
    static = [("base_footprint", "base_link", to_base_link),
              ("/base_footprint", "laser", to_base_link.compose(MOUNT)),
              ("base_link", "camera", gtsam.Pose2(0.2, 0.0, 1.0))]
    path = write_bag(bag_path(tmp_path, storage, "mounted"), storage,
                     {"/scan": small_scans(), "/odom": small_odometry()}, scan_frame="laser", static=static)
    bag = RosBag(path)
    assert (bag.base_frame, bag.laser_frame) == ("base_link", "laser")
    assert bag.laser_offset.equals(MOUNT, 1e-6) and bag.laser_offset_source == "/tf_static"
    mount = laser_mount(bag, [0.0, 0.0, 0.0])
    assert mount.source == "/tf_static" and mount.warning is None
    assert mount.metrics()["laser_offset"] == pytest.approx([0.3, 0.1, 0.2])


def test_without_tf_static_the_configured_offset_applies_and_the_metrics_say_so(tmp_path):
    from slam.laser_log import laser_mount

    path = write_bag(tmp_path / "bare", "mcap", {"/scan": small_scans(), "/odom": small_odometry()},
                     scan_frame="laser")
    bag = RosBag(path)
    assert bag.laser_offset is None and bag.laser_offset_note == "no /tf_static topic"
    metrics = laser_mount(bag, [0.3, 0.1, 0.2]).metrics()
    assert metrics == {"laser_offset": [0.3, 0.1, 0.2], "laser_offset_source": "configuration",
                       "laser_offset_note": "no /tf_static topic"}
    unrelated = write_bag(tmp_path / "unrelated", "mcap", {"/scan": small_scans(), "/odom": small_odometry()},
                          scan_frame="laser", static=[("base_link", "camera", MOUNT)])
    assert "no chain of transforms from 'base_link' to 'laser'" in RosBag(unrelated).laser_offset_note
