import json

import gtsam
import numpy as np
import pytest

import sim.campaign as campaign
from sim.campaign import run_campaign, table, termination_counts
from sim.episode import EpisodeConfig


def metrics(travel, coverage_99, reason="frontiers_exhausted"):
    return {"travel_distance_m": travel, "sim_time_s": 120.0, "entropy_rate_nats_per_step": -2.0,
            "final_map_entropy_nats": 100.0, "coverage": 0.99, "auc": 0.98, "ate_rmse_m": 0.05,
            "collisions": 0, "wall_time_s": 3.0, "termination_reason": reason,
            "travel_at_coverage_m": {"0.90": 20.0, "0.95": 30.0, "0.99": coverage_99}}


def test_table_is_mean_and_standard_error():
    results = {"gp": [metrics(50.0, 40.0), metrics(60.0, None), metrics(70.0, 44.0, "no_reachable_goal")]}
    rows = {r["metric"]: r["gp"] for r in table(results)}
    travel = rows["Travel distance (m)"]
    assert travel["mean"] == pytest.approx(60.0)
    assert travel["stderr"] == pytest.approx(10.0 / np.sqrt(3))
    assert rows["Exploration time (min)"]["mean"] == pytest.approx(2.0)
    assert rows["Coverage (%)"]["mean"] == pytest.approx(99.0)
    at99 = rows["Travel at 99 % coverage (m)"]
    assert at99["n"] == 2 and at99["mean"] == pytest.approx(42.0)
    assert termination_counts(results) == {"gp": {"frontiers_exhausted": 2, "no_reachable_goal": 1}}


def test_campaign_resumes_finished_runs(tmp_path, monkeypatch):
    calls = []

    class Result:
        def __init__(self, seed):
            self.metrics = metrics(10.0 + seed, 5.0)

    def fake_run(world, start, config, seed):
        calls.append(seed)
        return Result(seed)

    def fake_write(folder, result):
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "metrics.json").write_text(json.dumps(result.metrics))

    monkeypatch.setattr(campaign, "run_episode", fake_run)
    monkeypatch.setattr(campaign, "write_episode", fake_write)
    configs = {"gp": EpisodeConfig()}
    first = run_campaign(None, gtsam.Pose2(), configs, [0, 1], tmp_path)
    assert calls == [0, 1]
    again = run_campaign(None, gtsam.Pose2(), configs, [0, 1, 2], tmp_path)
    assert calls == [0, 1, 2]  # only the new seed ran
    assert [m["travel_distance_m"] for m in again["gp"]] == [10.0, 11.0, 12.0]
    assert first["gp"] == again["gp"][:2]
