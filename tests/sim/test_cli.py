import json

import numpy as np
import pytest
from typer.testing import CliRunner

from sim.cli import app
from slam.tum import read_tum

runner = CliRunner()


def one_line(output):
    """CLI output with rich's error box and line wrapping removed."""
    return " ".join(output.replace("│", " ").split())


def error_lines(output):
    """The lines inside rich's error box, without the box."""
    return [line.strip("│ ") for line in output.splitlines() if line.startswith("│")]


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
    assert metrics["software"]["packages"]["numpy"] == np.__version__
    assert (tmp_path / "figures" / "tour.png").stat().st_size > 10_000
    stamps, truth = read_tum(tmp_path / "ground_truth.tum")
    _, odometry = read_tum(tmp_path / "odometry.tum")
    assert len(truth) == len(odometry) == metrics["steps"]
    # the tour closes on its start; the odometry has drifted away from the truth
    assert np.hypot(truth[-1].x() - truth[0].x(), truth[-1].y() - truth[0].y()) < 0.2
    assert metrics["final_odometry_drift_m"] > 0.05
    assert metrics["max_odometry_drift_m"] >= metrics["final_odometry_drift_m"]
    assert np.all(np.diff(stamps) > 0)


def test_odometry_drift_is_the_odometry_error_from_the_true_start():
    """Odometry in its own frame (rotated by 90 degrees and shifted) that follows the truth
    exactly has no drift; one that ends 0.3 m to the side has 0.3 m at the end."""
    import gtsam

    from sim.tour import TourLog, odometry_drift

    truth = [gtsam.Pose2(1.0 + x, 2.0, 0.0) for x in (0.0, 1.0, 2.0)]
    frame = gtsam.Pose2(5.0, -3.0, np.pi / 2)
    exact = [frame.compose(truth[0].between(t)) for t in truth]
    log = TourLog(stamps=[0.0, 1.0, 2.0], truth=truth, odometry=exact)
    np.testing.assert_allclose(odometry_drift(log), 0.0, atol=1e-12)
    log.odometry = exact[:2] + [exact[2].compose(gtsam.Pose2(0.0, 0.3, 0.0))]
    np.testing.assert_allclose(odometry_drift(log), [0.0, 0.0, 0.3], atol=1e-12)


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


@pytest.mark.parametrize("method", ["gp", "grid"])
def test_explore_writes_every_result(tmp_path, method):
    from PIL import Image

    pixels = np.full((60, 100), 255, dtype=np.uint8)  # 5 m x 3 m at 0.05 m, walls around
    pixels[:2], pixels[-2:], pixels[:, :2], pixels[:, -2:] = 0, 0, 0, 0
    pixels[20:40, 50:54] = 0
    Image.fromarray(pixels).save(tmp_path / "room.png")
    out = tmp_path / "run"
    result = runner.invoke(app, ["explore", "--world", str(tmp_path / "room.png"), "--size", "5", "3",
                                 "--max-steps", "400", "--seed", "2", "--method", method, "--out", str(out)])
    assert result.exit_code == 0, result.output
    metrics = json.loads((out / "metrics.json").read_text())
    for key in ("start", "travel_distance_m", "sim_time_s", "wall_time_s", "onboard_time_s", "steps", "keyframes",
                "loop_closures", "regenerations", "final_map_entropy_nats", "entropy_rate_nats_per_step",
                "coverage", "auc", "ate_rmse_m", "collisions", "termination_reason"):
        assert key in metrics, key
    assert metrics["termination_reason"] in ("frontiers_exhausted", "no_reachable_goal")
    assert metrics["coverage"] > 0.95 and metrics["collisions"] == 0
    assert metrics["start_enclosed"] is False and metrics["warnings"] == [] and metrics["reachable_area_m2"] > 5
    assert metrics["software"]["packages"]["numpy"] == np.__version__     # what it was computed with
    products = ["trajectory.tum", "ground_truth.tum", "graph.g2o", "map.pgm", "map.yaml",
                "figures/map_trajectory.png", "figures/frontier_maps.png", "figures/entropy.png"]
    if method == "gp":
        products += ["com.npz", "figures/com_panels.png"]
    for name in products:
        assert (out / name).stat().st_size > 0, name
    stamps, poses = read_tum(out / "trajectory.tum")
    assert len(poses) == metrics["steps"]
    # the results line lists every file written (curve.csv was left out), on one line though
    # longer than the 80 columns of a pipe (it wrapped: `100.0 \n%`)
    line = next(line for line in result.stdout.splitlines() if line.startswith("results in"))
    assert len(line) > 80
    for name in products + ["metrics.json", "config.toml", "curve.csv"]:
        assert f" {name}," in line + ",", name
    summary = next(line for line in result.stdout.splitlines() if line.startswith(metrics["termination_reason"]))
    assert summary.endswith(" collisions") and len(summary) > 80


def test_explore_rejects_a_blocked_start(tmp_path):
    result = runner.invoke(app, ["explore", "--start", "0.1", "0.1", "0", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "'--start': start (0.10, 0.10) is not free" in one_line(result.output)


@pytest.mark.parametrize("args, message", [
    (["explore", "--method", "foo"], "'--method': Value error, 'foo' is not one of 'gp', 'grid'"),
    (["explore", "--poses", "gps"], "'--poses': Value error, 'gps' is not one of 'slam', 'truth'"),
    (["map", "LOG", "--poses", "truth"], "'--poses': Value error, 'truth' is not one of 'log', 'slam'"),
    (["posegraph", "LOG", "--method", "gn"], "'--method': Value error, 'gn' is not one of 'dogleg', 'lm'"),
    (["campaign", "--engine", "spark"], "'--engine': Value error, 'spark' is not one of 'local', 'dask'"),
    (["demo", "--world", "atlantis"], "'--world': Value error, 'atlantis' is not one of 'cave', 'office'"),
    (["compare", "--methods", "gp,astar"], "'--methods': 'astar' is not one of 'gp', 'grid'"),
    (["campaign", "--methods", "gp", "--methods", "grid,gp"], "'--methods': gp given twice"),
    (["campaign", "--worlds", "cave,cave"], "'--worlds': cave given twice"),
])
def test_choices_are_checked_by_name_listing_the_choices(tmp_path, args, message):
    log = tmp_path / "x.clf"
    log.write_text("FLASER 2 1.0 1.0 0 0 0 0 0 0 0 h 0\n")
    args = [str(log) if a == "LOG" else a for a in args]
    result = runner.invoke(app, [*args, "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and message in one_line(result.output), result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("args, option, message", [
    (["explore", "--seed", "-5"], "--seed", "Input should be greater than or equal to 0"),
    (["demo", "--seed", "-1"], "--seed", "Input should be greater than or equal to 0"),
    (["campaign", "--seeds", "0"], "--seeds", "Input should be greater than or equal to 1"),
    (["explore", "--max-steps", "-10"], "--max-steps", "Input should be greater than or equal to 1"),
    (["campaign", "--max-steps", "0"], "--max-steps", "Input should be greater than or equal to 1"),
    (["explore", "--resolution", "0"], "--resolution", "0.0 is not a positive finite number"),
    (["world", "office", "--radius", "-1"], "--radius", "-1.0 is not a positive finite number"),
])
def test_a_number_out_of_range_is_a_one_line_usage_error_naming_only_its_option(tmp_path, args, option, message):
    result = runner.invoke(app, [*args, "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and isinstance(result.exception, SystemExit), result.output
    assert error_lines(result.output) == [f"Invalid value for '{option}': {message}"]
    assert "Traceback" not in result.output and not (tmp_path / "o").exists()


@pytest.mark.parametrize("args, message", [
    (["explore", "--start", "5", "5"], "'--start': --start X Y THETA needs 3 numbers, got '--out'"),
    (["compare", "--start", "5", "5"], "'--start': --start X Y THETA needs 3 numbers, got '--out'"),
    (["explore", "--size", "5", "--start", "1", "1", "0"], "'--size': --size W H needs 2 numbers, got '--start'"),
    (["world", "office", "--start", "2"], "'--start': --start X Y needs 2 numbers, got '--out'"),
    (["explore", "--start", "1", "nan", "0"], "'--start': --start X Y THETA needs 3 numbers, got 'nan'"),
])
def test_a_tuple_option_short_of_numbers_does_not_swallow_the_next_option(tmp_path, args, message):
    result = runner.invoke(app, [*args, "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and message in one_line(result.output), result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("command", ["map", "replay"])
def test_a_missing_log_is_named_before_any_work(tmp_path, command):
    missing = tmp_path / "gone.clf"
    result = runner.invoke(app, [command, str(missing), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert f"'LOG':path'{missing}'doesnotexist" in "".join(result.output.replace("│", "").split())
    assert not (tmp_path / "o").exists()


def test_help_shows_config_sections_and_points_at_no_missing_file():
    result = runner.invoke(app, ["map", "--help"])
    assert result.exit_code == 0
    assert "[stack.com]" in one_line(result.output) and "[stack.slam]" in one_line(result.output)
    assert "pip install gpexplore[viz]" in one_line(runner.invoke(app, ["explore", "--help"]).output)
    for name in [c.name or c.callback.__name__ for c in app.registered_commands]:
        text = runner.invoke(app, [name.rstrip("_"), "--help"]).output
        assert "DESIGN.md" not in text and "SOURCES.md" not in text, name


def room(tmp_path):
    from PIL import Image

    pixels = np.full((60, 100), 255, dtype=np.uint8)  # 5 m x 3 m at --size 5 3, walls around
    pixels[:2], pixels[-2:], pixels[:, :2], pixels[:, -2:] = 0, 0, 0, 0
    pixels[20:40, 50:54] = 0
    (tmp_path / "maps").mkdir()
    Image.fromarray(pixels).save(tmp_path / "maps" / "room.png")
    return tmp_path / "maps" / "room.png"


def test_campaign_writes_runs_tables_and_figures(tmp_path):
    out = tmp_path / "c"
    args = ["campaign", "--worlds", str(room(tmp_path)), "--size", "5", "3", "--methods", "gp,grid",
            "--seeds", "1", "--poses", "truth", "--max-steps", "40", "--workers", "2", "--out", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "0 runs were done before, 2 finished now, 0 failed" in result.output
    for method in ("gp", "grid"):
        m = json.loads((out / "room.png" / method / "seed_0" / "metrics.json").read_text())
        assert (m["method"], m["seed"], m["poses"]) == (method, 0, "truth") and m["steps"] <= 40
    assert "## room.png" in (out / "table.md").read_text()
    assert len((out / "table.csv").read_text().splitlines()) == 1 + 2 * 13     # 13 metrics, 2 methods
    assert len(list((out / "figures").glob("room.png_*.png"))) == 3
    again = runner.invoke(app, args)
    assert again.exit_code == 0 and "2 runs were done before, 0 finished now" in again.output


def test_campaign_explores_the_suite_from_seeded_starts(tmp_path, shared_data):
    """--suite with --worlds: the named maps only, each run from its seed's random start (the
    same for both methods), its budget capped by --max-steps."""
    from sim.suite import sample_start
    from sim.world_io import load_world

    suite = shared_data / "maps" / "suite"
    out = tmp_path / "c"
    result = runner.invoke(app, ["campaign", "--suite", str(suite), "--worlds", "lab_c", "--seeds", "1",
                                 "--poses", "truth", "--max-steps", "30", "--workers", "2", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert [p.name for p in out.iterdir() if p.is_dir() and p.name != "figures"] == ["lab_c.yaml"]
    start = sample_start(load_world(suite / "lab_c.yaml"), 0.25, 0)
    for method in ("gp", "grid"):
        m = json.loads((out / "lab_c.yaml" / method / "seed_0" / "metrics.json").read_text())
        np.testing.assert_allclose(m["start"], [start.x(), start.y(), start.theta()])
        assert m["steps"] <= 30
    bad = runner.invoke(app, ["campaign", "--suite", str(suite), "--worlds", "atlantis", "--out", str(tmp_path / "d")])
    assert bad.exit_code == 2 and "--suite" in bad.output and "atlantis" in bad.output


def test_campaign_rejects_bad_options_by_name(tmp_path):
    for args, option in ((["--worlds", "atlantis"], "--world"), (["--engine", "spark"], "--engine"),
                         (["--methods", "gp,gp"], "--methods"), (["--methods", "astar"], "--method"),
                         (["--scheduler", "tcp://h:8786", "--workers", "2"], "--workers")):
        result = runner.invoke(app, ["campaign", "--worlds", "office", *args, "--out", str(tmp_path)])
        assert result.exit_code == 2, (args, result.output)
        assert option in result.output, (args, result.output)


def test_compare_is_a_one_world_campaign(tmp_path):
    out = tmp_path / "c"
    result = runner.invoke(app, ["compare", "--world", str(room(tmp_path)), "--size", "5", "3", "--seeds", "1",
                                 "--methods", "grid", "--poses", "truth", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert json.loads((out / "room.png" / "grid" / "seed_0" / "metrics.json").read_text())["method"] == "grid"
    assert "Travel distance (m)" in result.output and (out / "table.md").exists()


@pytest.mark.slow
def test_a_killed_campaign_resumes_without_redoing_finished_runs(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "c"
    command = [sys.executable, "-m", "sim.cli", "campaign", "--worlds", str(room(tmp_path)), "--size", "5", "3",
               "--methods", "grid", "--seeds", "4", "--poses", "truth", "--max-steps", "150", "--workers", "1",
               "--out", str(out)]
    metrics = [out / "room.png" / "grid" / f"seed_{k}" / "metrics.json" for k in range(4)]
    first = subprocess.Popen(command, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not any(m.exists() for m in metrics) and first.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    os.killpg(first.pid, signal.SIGKILL)  # the campaign and its workers, mid-run
    first.wait()
    done = {m: m.stat().st_mtime_ns for m in metrics if m.exists()}
    assert 1 <= len(done) < len(metrics)
    again = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stdout + again.stderr
    assert f"{len(done)} runs were done before, {4 - len(done)} finished now, 0 failed" in again.stdout
    assert all(m.exists() for m in metrics)
    assert {m: m.stat().st_mtime_ns for m in done} == done


def test_version_is_the_package_version_and_the_license_file_matches_pyproject():
    import sys
    from pathlib import Path

    if sys.version_info >= (3, 11):
        import tomllib
    else:
        import tomli as tomllib
    root = Path(__file__).resolve().parents[2]
    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.output.strip() == f"gpexplore {project['version']}"
    assert project["license"] == "MIT" and (root / "LICENSE").read_text().startswith("MIT License")


def pocket_world(tmp_path):
    """A 10 m x 10 m room (0.05 m/px) holding a closed 2 m box whose inside is centred on (7, 7)."""
    from PIL import Image

    pixels = np.full((200, 200), 255, dtype=np.uint8)
    pixels[:2], pixels[-2:], pixels[:, :2], pixels[:, -2:] = 0, 0, 0, 0
    top, left = 200 - 160, 120                      # rows run top down: y 6..8 m is rows 40..80
    pixels[top:top + 40, left:left + 2] = pixels[top:top + 40, left + 38:left + 40] = 0
    pixels[top:top + 2, left:left + 40] = pixels[top + 38:top + 40, left:left + 40] = 0
    path = tmp_path / "pocket.png"
    Image.fromarray(pixels).save(path)
    return path


def test_a_start_in_an_enclosed_pocket_is_warned_about_and_recorded(tmp_path):
    world = pocket_world(tmp_path)
    result = runner.invoke(app, ["world", str(world), "--resolution", "0.05", "--start", "7", "7"])
    assert result.exit_code == 0 and "enclosed pocket" in one_line(result.output)
    result = runner.invoke(app, ["world", str(world), "--resolution", "0.05", "--start", "3", "3"])
    assert result.exit_code == 0 and "enclosed" not in result.output
    out = tmp_path / "run"
    result = runner.invoke(app, ["explore", "--world", str(world), "--resolution", "0.05", "--start", "7", "7", "0",
                                 "--method", "grid", "--poses", "truth", "--max-steps", "30", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "warning: the start (7.00, 7.00) is in an enclosed pocket" in one_line(result.output)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["start_enclosed"] is True and metrics["reachable_area_m2"] < 3.0
    assert metrics["reachable_share"] < 0.05 and "enclosed pocket" in metrics["warnings"][0]


def test_a_start_outside_a_world_is_named_without_numpy_reprs():
    result = runner.invoke(app, ["world", "cave", "--start", "5", "5"])
    assert result.exit_code == 2
    assert "'--start': start (5.00, 5.00) is not free for a robot of radius 0.25 m" in one_line(result.output)
    assert "np.float64" not in result.output


def no_work(*args, **kwargs):
    raise AssertionError("the work started before the output was checked")


@pytest.mark.parametrize("target, message", [
    ("afile", "is a file"),
    ("afile/sub", "cannot create"),
    ("foreign", "is not empty and is not a gpexplore run folder"),
    ("old_run", "holds another run's results: give --overwrite to replace them"),
])
def test_explore_checks_its_output_folder_before_any_work(tmp_path, monkeypatch, target, message):
    import sim.episode

    monkeypatch.setattr(sim.episode, "run_episode", no_work)
    (tmp_path / "afile").write_text("x")
    (tmp_path / "foreign").mkdir()
    (tmp_path / "foreign" / "thesis.tex").write_text("precious")
    (tmp_path / "old_run").mkdir()
    (tmp_path / "old_run" / "metrics.json").write_text("{}")
    result = runner.invoke(app, ["explore", "--poses", "truth", "--out", str(tmp_path / target)])
    assert result.exit_code == 2 and message in one_line(result.output), result.output
    result = runner.invoke(app, ["explore", "--poses", "truth", "--out", str(tmp_path / "foreign"), "--overwrite"])
    assert result.exit_code == 2 and (tmp_path / "foreign" / "thesis.tex").read_text() == "precious"


def test_a_run_owns_its_folder_and_overwrite_clears_the_older_run(tmp_path):
    from PIL import Image

    pixels = np.full((60, 100), 255, dtype=np.uint8)
    pixels[:2], pixels[-2:], pixels[:, :2], pixels[:, -2:] = 0, 0, 0, 0
    Image.fromarray(pixels).save(tmp_path / "room.png")
    out = tmp_path / "run"
    args = ["explore", "--world", str(tmp_path / "room.png"), "--size", "5", "3", "--poses", "truth",
            "--max-steps", "20", "--out", str(out)]
    assert runner.invoke(app, args + ["--method", "gp"]).exit_code == 0
    assert (out / "com.npz").exists()
    result = runner.invoke(app, args + ["--method", "grid"])
    assert result.exit_code == 2 and "`explore` run's results: give --overwrite" in one_line(result.output)
    result = runner.invoke(app, args + ["--method", "grid", "--overwrite"])
    assert result.exit_code == 0, result.output
    assert not (out / "com.npz").exists() and not (out / "figures" / "com_panels.png").exists()
    assert json.loads((out / "metrics.json").read_text())["method"] == "grid"


def test_demo_runs_again_into_its_own_folder_but_not_into_another_runs(tmp_path):
    out = tmp_path / "demo"
    for _ in range(2):
        result = runner.invoke(app, ["demo", "--world", "office", "--out", str(out)])
        assert result.exit_code == 0, result.output
    (tmp_path / "explored").mkdir()
    (tmp_path / "explored" / ".gpexplore-run").write_text('{"command": "explore"}')
    result = runner.invoke(app, ["demo", "--world", "office", "--out", str(tmp_path / "explored")])
    assert result.exit_code == 2 and "holds a `explore` run's results" in one_line(result.output)


def test_file_outputs_are_checked_before_any_work(tmp_path, monkeypatch):
    import slam.g2o

    monkeypatch.setattr(slam.g2o, "optimize_g2o", no_work)
    graph = tmp_path / "g.g2o"
    graph.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n")
    result = runner.invoke(app, ["posegraph", str(graph), "--out", str(tmp_path / "g.g2o" / "x.g2o")])
    assert result.exit_code == 2 and "'--out': cannot create" in one_line(result.output)
    result = runner.invoke(app, ["world", "cave", "--out", str(tmp_path / "g.g2o" / "w.png")])
    assert result.exit_code == 2 and "'--out': cannot create" in one_line(result.output)
    result = runner.invoke(app, ["config", "dump", "--out", str(tmp_path / "g.g2o" / "c.toml")])
    assert result.exit_code == 2 and "'--out': cannot create" in one_line(result.output)


def test_rerun_runs_a_run_again_from_its_folder_and_figures_redraws_it(tmp_path):
    """config.toml and metrics.json's world_spec, start and seed are all a run needs: `rerun`
    gives the same metrics but for the wall time; `figures` draws the map and entropy figures
    again from the folder's files; the animation is listed among the results."""
    from PIL import Image

    pixels = np.full((60, 100), 255, dtype=np.uint8)  # 5 m x 3 m at 0.05 m, walls around
    pixels[:2], pixels[-2:], pixels[:, :2], pixels[:, -2:] = 0, 0, 0, 0
    Image.fromarray(pixels).save(tmp_path / "room.png")
    first, again = tmp_path / "first", tmp_path / "again"
    result = runner.invoke(app, ["explore", "--world", str(tmp_path / "room.png"), "--size", "5", "3",
                                 "--start", "1", "1.5", "0.3", "--seed", "5", "--max-steps", "30",
                                 "--animate", "--out", str(first)])
    assert result.exit_code == 0, result.output
    assert "figures/animation.gif" in next(line for line in result.stdout.splitlines() if "results in" in line)
    a = json.loads((first / "metrics.json").read_text())
    assert a["world_spec"] == {"world": str(tmp_path / "room.png"), "size": [5.0, 3.0], "resolution": None}
    result = runner.invoke(app, ["rerun", str(first), "--out", str(again)])
    assert result.exit_code == 0, result.output
    b = json.loads((again / "metrics.json").read_text())
    assert a.pop("wall_time_s") > a.pop("onboard_time_s") > 0 and b.pop("wall_time_s") > b.pop("onboard_time_s") > 0
    assert a == b and a["steps"] == 30 and a["start"] == [1.0, 1.5, 0.3] and a["seed"] == 5
    assert (again / "figures" / "animation.gif").exists()                 # the configuration's animate_every
    result = runner.invoke(app, ["rerun", str(first), "--out", str(first)])
    assert result.exit_code == 2 and "is RUN_DIR itself" in one_line(result.output)

    redrawn = tmp_path / "redrawn"
    result = runner.invoke(app, ["figures", str(first), "--out", str(redrawn)])
    assert result.exit_code == 0, result.output
    for name in ("map_trajectory.png", "entropy.png"):
        old, new = (np.asarray(Image.open(folder / name)) for folder in (first / "figures", redrawn))
        assert old.shape == new.shape and np.mean(old != new) < 0.01, name   # the same figure
    assert not (redrawn / "frontier_maps.png").exists()
    result = runner.invoke(app, ["figures", str(first)])                # over the run's own figures
    assert result.exit_code == 0 and f"{first}/figures/map_trajectory.png" in result.stdout, result.output
    (first / "curve.csv").unlink()
    result = runner.invoke(app, ["figures", str(first)])
    assert result.exit_code == 2 and "curve.csv: no such file" in one_line(result.output)


def test_figures_draws_the_loops_of_graph_g2o(tmp_path):
    """The loop closures are graph.g2o's edges between keyframes that are not consecutive."""
    from sim.results import loop_segments_g2o

    (tmp_path / "graph.g2o").write_text(
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 1 1 0\n"
        "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 2 0 1 0 1 0 0 1 0 1\nEDGE_SE2 0 2 1 1 0 1 0 0 1 0 1\n")
    np.testing.assert_array_equal(loop_segments_g2o(tmp_path / "graph.g2o"), [[[0, 0], [1, 1]]])


def test_rerun_of_a_folder_without_a_recoverable_world_says_why(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.toml").write_text("max_steps = 5\n")
    (run / "metrics.json").write_text(json.dumps({"world": "suite_map_7.png", "start": [1, 1, 0], "seed": 0,
                                                  "method": "gp", "poses": "slam"}))
    result = runner.invoke(app, ["rerun", str(run), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "no world_spec, only the world's name" in one_line(result.output)
