import json

import numpy as np
import pytest
from typer.testing import CliRunner

from sim.cli import app
from slam.tum import read_tum

runner = CliRunner()


def test_every_command_has_help():
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0
    commands = [c.name or c.callback.__name__ for c in app.registered_commands]
    assert "demo" in commands and "world" in commands
    for name in commands:
        sub = runner.invoke(app, [name, "--help"])
        assert sub.exit_code == 0, f"{name} --help failed: {sub.output}"
        assert "Usage" in sub.output


def test_demo_writes_results(tmp_path):
    result = runner.invoke(app, ["demo", "--out", str(tmp_path), "--seed", "3"])
    assert result.exit_code == 0, result.output
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["collisions"] == 0 and metrics["steps"] > 500
    assert (tmp_path / "figures" / "tour.png").stat().st_size > 10_000
    stamps, truth = read_tum(tmp_path / "ground_truth.tum")
    _, odometry = read_tum(tmp_path / "odometry.tum")
    assert len(truth) == len(odometry) == metrics["steps"]
    # the tour closes on its start; the odometry has drifted away from the truth
    assert np.hypot(truth[-1].x() - truth[0].x(), truth[-1].y() - truth[0].y()) < 0.2
    assert metrics["final_odometry_drift_m"] > 0.05
    assert np.all(np.diff(stamps) > 0)


def test_world_command_reports_reachable_area(tmp_path):
    result = runner.invoke(app, ["world", "office", "--start", "2", "15", "--out", str(tmp_path / "w.png")])
    assert result.exit_code == 0, result.output
    assert "reachable free space" in result.output and (tmp_path / "w.png").exists()


def test_bitmap_without_scale_is_a_clear_error(tmp_path):
    from PIL import Image

    Image.fromarray(np.full((4, 4), 255, dtype=np.uint8)).save(tmp_path / "m.png")
    result = runner.invoke(app, ["world", str(tmp_path / "m.png")])
    assert result.exit_code == 2
    assert "no scale" in result.output
