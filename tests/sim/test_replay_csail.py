"""The MIT CSAIL benchmark log: relation error against Cartographer's published figures."""

import json

import pytest

from slam.carmen import CarmenLog
from slam.evaluation import read_relations, relation_error
from slam.g2o import read_g2o
from sim.logs import replay_log
from slam.replay import write_replay
from slam.tum import read_tum

#: Hess et al. 2016, Table I (Cartographer on mit-csail): mean translational (m), rotational (deg).
CARTOGRAPHER = (0.0319, 0.369)


@pytest.fixture(scope="module")
def csail(shared_data, tmp_path_factory):
    log = CarmenLog(shared_data / "logs" / "mit-csail.clf")
    result = replay_log(log)
    out = tmp_path_factory.mktemp("csail")
    metrics = write_replay(out, log, result, shared_data / "relations" / "mit-csail.relations",
                           figure=False)
    return log, result, out, metrics


def test_relation_error_beats_cartographer(csail):
    _, _, _, metrics = csail
    e = metrics["relation_error"]
    assert e["relations"] == 1172 and e["interpolated"] == 0
    assert e["all"]["trans_mean_m"] < CARTOGRAPHER[0]
    assert e["all"]["rot_mean_deg"] < CARTOGRAPHER[1]
    # long relations (revisits) are the loop closures' work: without them they are ~1 m
    assert e["long_ge_5s"]["trans_mean_m"] < 0.1
    assert metrics["loop_closures"] >= 10


def test_outputs_are_consistent(csail, shared_data):
    log, result, out, metrics = csail
    stamps, poses = read_tum(out / "trajectory.tum")
    assert len(poses) == len(log) == metrics["scans"]
    # what metricEvaluator reads (the corrected log's FLASER poses) scores the same
    corrected = CarmenLog(out / "corrected.clf")
    again = relation_error(read_relations(shared_data / "relations" / "mit-csail.relations"),
                           [r.scan.timestamp for r in corrected], [r.pose for r in corrected])
    assert again.translational.mean() == pytest.approx(metrics["relation_error"]["all"]["trans_mean_m"], abs=1e-5)
    graph = read_g2o(out / "graph.g2o")
    assert len(graph.poses) == metrics["keyframes"]
    assert len(graph.edges) == metrics["keyframes"] - 1 + metrics["loop_closures"]
    assert json.loads((out / "metrics.json").read_text())["keyframes"] == metrics["keyframes"]


def test_false_loops_injected_after_verification_do_not_move_the_map(csail, shared_data):
    """Wrong loop closures (random distant keyframes, the prediction moved 0.3-1 m and 3-10°,
    confident) injected where verification turned a candidate down, about 30 % as many as the
    true loops: the gates and the consistency layer keep nearly all out, and the relation error
    stays within 10 % of the clean replay's. (The benchmark injects 50-60 %.)

    The injection is chaotic (which candidates are turned down, and so which false loops come,
    depends on every loop before), so it is judged over five seeds, of which one may miss: a
    false loop within the graph's honest uncertainty cannot be told from a true one when it
    comes. Seed 3 is such a miss (0.34 m): its first false loop, 225 → 670, lay at d² 12.7 from
    the prediction, whose own error was 0.30 m at σ 0.42 m; the links' heading floor lets it
    bend the map at no cost, and no later loop contradicts it enough for the consistency layer
    (see the README, Pose SLAM on recorded logs)."""
    from slam.false_loops import inject_false_loops
    from slam.pose_slam import PoseSlam

    log, _, _, clean = csail
    relations = read_relations(shared_data / "relations" / "mit-csail.relations")
    reference = clean["relation_error"]["all"]
    held = []
    for seed in range(5):
        slam = PoseSlam()
        injected = inject_false_loops(slam, rate=0.05, seed=seed)
        result = replay_log(log, slam=slam)
        error = relation_error(relations, result.stamps, result.trajectory,
                               [r.odometry for r in log]).summary()["all"]
        kept = sum(any(loop is false for loop in slam.loops) for false in injected)
        held.append(len(injected) >= 5 and kept <= 1
                    and error["trans_mean_m"] <= 1.1 * reference["trans_mean_m"]
                    and error["rot_mean_deg"] <= 1.1 * reference["rot_mean_deg"])
    assert sum(held) >= 4, held
