"""Mapping a log (sim.logs.map_log) says what it does while it learns the map."""

from pathlib import Path
from types import SimpleNamespace

import gtsam
import numpy as np

from sim.lidar import Lidar, LidarConfig
from sim.logs import map_log
from small_worlds import two_rooms


class Log(list):
    """A laser log's records (``.scan``, ``.pose``, ``.odometry``), as map_log reads them."""

    path = Path("two_rooms.clf")
    laser_offset = None     # the log states no mount


def test_learning_the_map_of_a_log_shows_a_progress_bar(capsys):
    """The COM is learned after the replay, from every mapped scan, and scored: the longest
    stretch of `gpexplore map` (11 of Intel's 13 s), which said nothing."""
    world = two_rooms()
    lidar = Lidar(LidarConfig(beams=90), seed=0)
    poses = [gtsam.Pose2(x, 1.5, 0.0) for x in np.arange(1.0, 4.0, 0.5)]
    records = [SimpleNamespace(scan=lidar.scan(world, p), pose=p, odometry=p) for p in poses]
    log = Log(records)
    run = map_log(log, "log", progress=True)
    assert run.metrics["keyframes"] == len(poses)
    last = capsys.readouterr().err.rstrip().split("\r")[-1]
    assert last.startswith("learning the map: 100%") and f"{len(poses)}/{len(poses)} [" in last, last
    assert "scoring the map: AUC, entropy" in last
    map_log(log, "log")
    assert capsys.readouterr().err == ""                            # quiet unless asked
