import gtsam
import pytest

from sim.episode import EpisodeConfig, run_episode
from exploration.stack import StackConfig
from small_worlds import two_rooms


@pytest.fixture(scope="module")
def world():
    return two_rooms()


@pytest.mark.parametrize("method, poses", [("gp", "truth"), ("grid", "truth"), ("gp", "slam")])
def test_small_world_is_explored_to_completion(world, method, poses):
    config = EpisodeConfig(max_steps=1500, stack=StackConfig(poses=poses, explorer={"method": method}))
    result = run_episode(world, gtsam.Pose2(1.5, 1.5, 0.0), config, seed=1)
    m = result.metrics
    assert m["termination_reason"] in ("frontiers_exhausted", "no_reachable_goal"), m
    assert m["steps"] < config.max_steps
    # the grid stops once its frontier regions are smaller than 10 cells of 0.2 m
    assert m["coverage"] >= (0.99 if method == "gp" else 0.95)
    assert m["collisions"] == 0
    assert m["auc"] > 0.9
    # travel and steps against an independent bound: test_episode_bound.py
    # the robot went through the door into the right room
    assert max(p.x() for p in result.truth) > 6.0
    if poses == "slam":
        assert m["ate_rmse_m"] < 0.15 and m["keyframes"] > 10


def test_runs_are_reproducible(world):
    config = EpisodeConfig(max_steps=200, stack=StackConfig(poses="truth"))
    a = run_episode(world, gtsam.Pose2(1.5, 1.5, 0.0), config, seed=4).metrics
    b = run_episode(world, gtsam.Pose2(1.5, 1.5, 0.0), config, seed=4).metrics
    a.pop("wall_time_s"), b.pop("wall_time_s")
    assert a == b


def test_step_budget_is_a_termination_reason(world):
    config = EpisodeConfig(max_steps=30, stack=StackConfig(poses="truth"))
    m = run_episode(world, gtsam.Pose2(1.5, 1.5, 0.0), config, seed=0).metrics
    assert m["termination_reason"] == "step_budget" and m["steps"] == 30
