"""The trajectories a run writes are read by evo, and evo's APE is the run's own ATE."""

import json

import pytest

from sim.episode import EpisodeConfig, run_episode
from sim.results import write_episode
from sim.worlds import BUILTIN_WORLDS


def test_evo_ape_of_the_written_trajectories_is_the_runs_ate(tmp_path):
    file_interface = pytest.importorskip("evo.tools.file_interface")
    from evo.core import metrics, sync

    cave = BUILTIN_WORLDS["cave"]()
    result = run_episode(cave.world, cave.start, EpisodeConfig(max_steps=120), seed=2)
    write_episode(tmp_path, result)
    written = json.loads((tmp_path / "metrics.json").read_text())

    # ate_rmse_m (the online estimate) and ate_final_rmse_m (the final trajectory): the RMS of the
    # position errors, without alignment (the run starts at its known start pose, so estimate
    # and truth share the world frame)
    for name, key in (("trajectory.tum", "ate_rmse_m"), ("trajectory_final.tum", "ate_final_rmse_m")):
        truth = file_interface.read_tum_trajectory_file(str(tmp_path / "ground_truth.tum"))
        estimate = file_interface.read_tum_trajectory_file(str(tmp_path / name))
        truth, estimate = sync.associate_trajectories(truth, estimate)
        assert estimate.num_poses == result.metrics["steps"]
        ape = metrics.APE(metrics.PoseRelation.translation_part)
        ape.process_data((truth, estimate))
        assert written[key] > 1e-3      # SLAM, not the truth: the comparison means something
        assert ape.get_statistic(metrics.StatisticsType.rmse) == pytest.approx(written[key], rel=1e-4, abs=2e-6)
    assert written["ate_final_rmse_m"] != written["ate_rmse_m"]    # the graph moved the poses
    # ate_final_aligned_rmse_m: evo's APE of the final trajectory (the last read) after its
    # Umeyama alignment (no scale)
    estimate.align(truth, correct_scale=False)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((truth, estimate))
    assert written["ate_final_aligned_rmse_m"] < written["ate_final_rmse_m"]
    assert ape.get_statistic(metrics.StatisticsType.rmse) == pytest.approx(written["ate_final_aligned_rmse_m"],
                                                                         rel=1e-4, abs=2e-6)
