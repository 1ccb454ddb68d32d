import csv
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from sim.campaign import (DECIMALS, Run, WorldSpec, cell, check_resumable, execute, plan, results, run_campaign,
                          run_line, table, table_markdown, termination_counts, world_spec, write_figures,
                          write_tables)
from sim.engines import DaskEngine, LocalEngine
from sim.episode import EpisodeConfig
from sim.results import CURVE_COLUMNS, read_curve

#: metrics that measure the machine, not the run
WALL = ("wall_time_s", "onboard_time_s")


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


def room_bitmap(path):
    """A 5 m x 3 m room (at --size 5 3) with a wall stub in the middle."""
    pixels = np.full((60, 100), 255, dtype=np.uint8)
    pixels[:2], pixels[-2:], pixels[:, :2], pixels[:, -2:] = 0, 0, 0, 0
    pixels[20:40, 50:54] = 0
    Image.fromarray(pixels).save(path)
    return path


@pytest.fixture
def room(tmp_path):
    (tmp_path / "maps").mkdir()
    return WorldSpec(str(room_bitmap(tmp_path / "maps" / "room.png")), (0.8, 0.8, 0.5), size=(5.0, 3.0))


@pytest.fixture(scope="module")
def pool():
    """Two worker processes, started once: spawning and importing is most of a tiny run's time."""
    with LocalEngine(2) as engine:
        yield engine


def configs(max_steps=50):
    base = EpisodeConfig(metrics_every=10)
    return {m: base.overridden(m, "truth", max_steps) for m in ("gp", "grid")}


def without_wall(m):
    return {k: v for k, v in m.items() if k not in WALL}


def test_world_spec_checks_the_world_and_keeps_a_scale_for_bitmaps_only(tmp_path, room, monkeypatch):
    from sim.world_io import StartError

    monkeypatch.chdir(tmp_path)
    bitmap = world_spec("maps/room.png", 0.25, size=(5.0, 3.0))
    assert bitmap.spec == room.spec and bitmap.size == (5.0, 3.0)      # absolute: workers need no cwd
    assert not bitmap.load().collides(bitmap.start[:2], 0.25)
    cave = world_spec("cave", 0.25, size=(5.0, 3.0))                     # one --size for mixed worlds
    assert (cave.spec, cave.size, cave.resolution) == ("cave", None, None)
    assert cave.start == pytest.approx((2.0, 2.0, np.pi / 4))
    assert world_spec("cave", 0.25, (3.0, 2.0, 0.5)).start == (3.0, 2.0, 0.5)
    with pytest.raises(StartError, match="not free"):
        world_spec("maps/room.png", 0.25, (0.05, 0.05, 0.0), size=(5.0, 3.0))
    with pytest.raises(FileNotFoundError, match="atlantis.png: no such map file"):
        world_spec("atlantis.png", 0.25, size=(5.0, 3.0))


def test_run_line_says_how_a_run_ended():
    run = Run(WorldSpec("cave", (0, 0, 0)), configs()["grid"].model_dump(), 3, "out/cave/grid/seed_3")
    m = {"termination_reason": "frontiers_exhausted", "travel_distance_m": 41.26, "coverage": 0.9987,
         "wall_time_s": 5.04}
    assert run_line(run, m, None) == "cave grid seed 3: frontiers_exhausted, 41.3 m, coverage 99.9 %, 5.0 s wall"
    error = "Traceback (most recent call last):\n  ...\nFileNotFoundError: hall.png: no such map file\n"
    assert run_line(run, None, error) == "cave grid seed 3 failed: FileNotFoundError: hall.png: no such map file"


def test_plan_lays_out_one_folder_per_run(tmp_path, room):
    runs = plan(tmp_path, [room, WorldSpec("cave", (0, 0, 0))], configs(), [0, 3])
    assert len(runs) == 8
    assert {r.folder for r in runs} >= {str(tmp_path / "room.png" / "grid" / "seed_3"),
                                       str(tmp_path / "cave" / "gp" / "seed_0")}
    assert len({r.folder for r in runs}) == 8
    with pytest.raises(ValueError, match="share a folder name"):
        plan(tmp_path, [room, WorldSpec(str(tmp_path / "other" / "room.png"), (0, 0, 0))], configs(), [0])


def test_dask_cluster_and_process_pool_give_the_same_runs(tmp_path, room, pool):
    gp = {"gp": configs()["gp"]}
    runs_local = plan(tmp_path / "local", [room], gp, [0, 1])
    runs_dask = plan(tmp_path / "dask", [room], gp, [0, 1])
    assert run_campaign(runs_local, pool) == {"done_before": 0, "finished": 2, "failed": 0}
    with DaskEngine(workers=2) as engine:
        assert run_campaign(runs_dask, engine) == {"done_before": 0, "finished": 2, "failed": 0}
    local, dask = results(runs_local)["room.png"], results(runs_dask)["room.png"]
    assert [m["seed"] for m in local["gp"]] == [0, 1]
    assert [without_wall(m) for m in local["gp"]] == [without_wall(m) for m in dask["gp"]]
    # the seeds differ: the runs are not copies of each other
    # (the map: sensor noise differs; 50 steps of a slow start drive the same path at any seed)
    assert local["gp"][0]["final_map_entropy_nats"] != local["gp"][1]["final_map_entropy_nats"]


def test_campaign_resumes_only_unfinished_runs(tmp_path, room, pool):
    runs = plan(tmp_path, [room], configs(), [0, 1])
    execute(runs[0])
    done = tmp_path / "room.png" / "gp" / "seed_0" / "metrics.json"
    stamp = done.stat().st_mtime_ns
    ended = []
    summary = run_campaign(runs, pool, lambda run, m, error: ended.append(run.folder))
    assert summary == {"done_before": 1, "finished": 3, "failed": 0}
    assert sorted(ended) == sorted(r.folder for r in runs[1:])
    assert done.stat().st_mtime_ns == stamp
    assert all(len(v) == 2 for v in results(runs)["room.png"].values())


def test_a_campaign_run_is_run_again_by_rerun_from_its_folder(tmp_path, room):
    """Its metrics.json says how to load its world (a bitmap's path and size), so ``gpexplore
    rerun`` repeats it: the same metrics but for the machine's times."""
    from typer.testing import CliRunner

    from sim.cli import app

    run = plan(tmp_path, [room], configs(max_steps=20), [2])[0]
    first = execute(run)
    assert first["world_spec"] == {"world": room.spec, "size": [5.0, 3.0], "resolution": None}
    result = CliRunner().invoke(app, ["rerun", run.folder, "--out", str(tmp_path / "again")])
    assert result.exit_code == 0, result.output
    again = json.loads((tmp_path / "again" / "metrics.json").read_text())
    assert without_wall(again) == without_wall(json.loads((Path(run.folder) / "metrics.json").read_text()))


def test_a_failed_run_is_recorded_and_retried(tmp_path, room, pool):
    missing = WorldSpec(str(tmp_path / "later" / "hall.png"), room.start, size=room.size)
    runs = plan(tmp_path / "out", [missing, room], configs(30), [0])
    ended = {}
    summary = run_campaign(runs, pool, lambda run, m, error: ended.update({run.folder: error}))
    assert summary == {"done_before": 0, "finished": 2, "failed": 2}
    for run in runs:
        error_file = tmp_path / "out" / run.world.name / run.method / "seed_0" / "error.json"
        if run.world is missing:
            error = json.loads(error_file.read_text())
            assert error["error"].startswith("FileNotFoundError") and "hall.png" in error["error"]
            assert "Traceback" in error["traceback"] and error["traceback"] == ended[run.folder]
        else:
            assert not error_file.exists() and ended[run.folder] is None
    write_tables(tmp_path / "out", runs)
    assert "gp 0/1 (1 failed)" in (tmp_path / "out" / "table.md").read_text()

    (tmp_path / "later").mkdir()
    room_bitmap(tmp_path / "later" / "hall.png")  # the map arrives: the failed runs are retried
    assert run_campaign(runs, pool) == {"done_before": 2, "finished": 2, "failed": 0}
    assert not list((tmp_path / "out").rglob("error.json"))


def test_tables_and_figures_come_from_the_run_folders(tmp_path, room, pool):
    runs = plan(tmp_path, [room], configs(), [0, 1])
    run_campaign(runs, pool)
    rows = write_tables(tmp_path, runs)["room.png"]
    assert rows == table(results(runs)["room.png"])
    with open(tmp_path / "table.csv") as f:
        sheet = list(csv.DictReader(f))
    assert len(sheet) == 2 * len(rows)
    for line in sheet:
        expected = next(r for r in rows if r["metric"] == line["metric"])[line["method"]]
        assert line["world"] == "room.png" and int(line["n"]) == expected["n"]
        if expected["mean"] is None:
            assert line["mean"] == ""
        else:
            assert float(line["mean"]) == pytest.approx(expected["mean"])
            assert float(line["stderr"]) == pytest.approx(expected["stderr"])
    travel = next(r for r in rows if r["metric"] == "Travel distance (m)")
    markdown = (tmp_path / "table.md").read_text()
    assert markdown == table_markdown(runs)                 # what `gpexplore campaign` prints
    assert "## room.png" in markdown
    assert f"| Travel distance (m) | {cell(travel['gp'], 2, DECIMALS['travel_distance_m'])} |" in markdown
    for path in write_figures(tmp_path, runs):
        assert path.stat().st_size > 10_000, path
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == [
        "room.png_coverage.png", "room.png_entropy.png", "room.png_travel.png"]


def test_curve_file_holds_the_runs_samples(tmp_path, room):
    run = plan(tmp_path, [room], configs(), [0])[0]
    m = execute(run)
    curve = read_curve(f"{run.folder}/curve.csv")
    assert list(curve) == list(CURVE_COLUMNS)
    assert curve["step"][0] == 0 and curve["step"][-1] == m["steps"]
    assert curve["time_s"][-1] == pytest.approx(m["sim_time_s"])
    assert curve["travel_m"][-1] == pytest.approx(m["travel_distance_m"])
    assert curve["coverage"][-1] == pytest.approx(m["coverage"])
    assert curve["entropy_nats"][-1] == pytest.approx(m["final_map_entropy_nats"])
    assert np.all(np.diff(curve["travel_m"]) >= 0)


def test_a_folder_from_another_experiment_is_not_resumed(tmp_path, room):
    """A finished run counts for a resumed campaign only if it ran the same configuration,
    start and seed: a table must not mix experiments."""
    runs = plan(tmp_path, [room], configs(), [0])
    execute(runs[0])
    check_resumable(runs)                                   # the same campaign: fine
    with pytest.raises(ValueError, match="another configuration"):
        check_resumable(plan(tmp_path, [room], configs(max_steps=60), [0]))
    moved = WorldSpec(room.spec, (1.0, 0.8, 0.5), size=room.size)
    with pytest.raises(ValueError, match="start"):
        check_resumable(plan(tmp_path, [moved], configs(), [0]))
