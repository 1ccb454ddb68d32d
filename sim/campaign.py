"""Campaigns: every (world, method, seed) run in parallel on an engine, and the paper's Table I.

Each run writes its own folder (``<out>/<world>/<method>/seed_<k>/``) as soon as it finishes; a
run whose ``metrics.json`` exists is finished and is not run again, so an interrupted campaign
resumes where it stopped. A run that fails leaves ``error.json`` (with the traceback) in its
folder instead, does not stop the others, and is run again on resume.
"""

from __future__ import annotations

import csv
import io
import json
import traceback
from collections import Counter
from dataclasses import dataclass, replace
from pathlib import Path

import gtsam
import numpy as np

from sim.episode import EpisodeConfig, run_episode
from sim.results import read_curve, write_episode
from sim.world import World
from sim.worlds import BUILTIN_WORLDS
from slam.atomic import write_json_atomic, write_text_atomic

#: Table I rows: (label, metrics key, scale).
ROWS = [
    ("Travel distance (m)", "travel_distance_m", 1.0),
    ("Exploration time (min)", "sim_time_s", 1 / 60),
    ("Map entropy rate (nats/step)", "entropy_rate_nats_per_step", 1.0),
    ("Final map entropy (nats)", "final_map_entropy_nats", 1.0),
    ("Coverage (%)", "coverage", 100.0),
    ("AUC", "auc", 1.0),
    ("Travel at 90 % coverage (m)", ("travel_at_coverage_m", "0.90"), 1.0),
    ("Travel at 95 % coverage (m)", ("travel_at_coverage_m", "0.95"), 1.0),
    ("Travel at 99 % coverage (m)", ("travel_at_coverage_m", "0.99"), 1.0),
    ("Travel at the last gain (m)", "travel_at_last_gain_m", 1.0),
    ("ATE RMSE (m)", "ate_rmse_m", 1.0),
    ("Collisions", "collisions", 1.0),
    ("Wall time (s)", "wall_time_s", 1.0),
]


@dataclass(frozen=True)
class WorldSpec:
    """A world as a worker loads it: a built-in name, a bitmap (with ``size`` W, H in m or
    ``resolution`` in m/pixel) or a ROS .yaml map, and the start X, Y, THETA (m, m, rad).

    A ``start`` of None asks for a seeded random start per run (``sim.suite.sample_start``,
    drawn by ``plan``), the same for every method of a seed; ``max_steps``, when given, is this
    world's step budget in place of the configuration's (``sim.suite.step_budget``).
    """

    spec: str
    start: tuple[float, float, float] | None
    size: tuple[float, float] | None = None
    resolution: float | None = None
    max_steps: int | None = None

    @property
    def name(self) -> str:
        """The world's folder in a campaign: the built-in name or the map's file name."""
        return self.spec if self.spec in BUILTIN_WORLDS else Path(self.spec).name

    def load(self) -> World:
        from sim.world_io import load_world

        return load_world(self.spec, size=self.size, resolution=self.resolution)


def world_spec(world: str, radius: float, start: tuple[float, float, float] | None = None,
               size: tuple[float, float] | None = None, resolution: float | None = None) -> WorldSpec:
    """A campaign's world, checked here (it loads, a robot of ``radius`` m fits at its start:
    ``start``, else the built-in or a free corner's) and loaded again by each worker. ``size``
    and ``resolution`` apply to a bitmap only, so that one of each serves a list of mixed worlds.

    Raises FileNotFoundError or ValueError for a world that does not load, ``StartError`` for a
    start that is not free."""
    from sim.world_io import has_own_scale, load_world, start_pose

    if has_own_scale(world):
        size = resolution = None
    spec = world if world in BUILTIN_WORLDS else str(Path(world).absolute())
    pose = start_pose(world, load_world(world, size, resolution), radius, start)
    return WorldSpec(spec, (pose.x(), pose.y(), pose.theta()), size, resolution)


def suite_world_spec(world: str, radius: float, size: tuple[float, float] | None = None,
                     resolution: float | None = None, max_steps: int | None = None) -> WorldSpec:
    """A world of the suite benchmark: seeded random starts (``sim.suite.sample_start``) and the
    step budget of its free area for a robot of ``radius`` m (``sim.suite.step_budget``), capped
    at ``max_steps`` when given (smoke tests). Checked here as ``world_spec`` checks.

    Raises FileNotFoundError or ValueError for a world that does not load or has no room for the
    robot."""
    from sim.suite import free_area_m2, step_budget
    from sim.world_io import has_own_scale, load_world

    if has_own_scale(world):
        size = resolution = None
    spec = world if world in BUILTIN_WORLDS else str(Path(world).absolute())
    budget = step_budget(free_area_m2(load_world(world, size, resolution), radius))
    return WorldSpec(spec, None, size, resolution, budget if max_steps is None else min(budget, max_steps))


@dataclass(frozen=True)
class Run:
    """One run of a campaign, plain data that pickles cheaply: the world is loaded by the worker."""

    world: WorldSpec
    config: dict  # EpisodeConfig.model_dump()
    seed: int
    folder: str

    @property
    def method(self) -> str:
        return self.config["stack"]["explorer"]["method"]


def plan(out: str | Path, worlds: list[WorldSpec], configs: dict[str, EpisodeConfig],
         seeds: list[int]) -> list[Run]:
    """Every (world, method, seed) run, each in ``<out>/<world>/<method>/seed_<k>/`` (an absolute
    path: workers need not share this process's working directory). A world without a start gets
    seed k's random start in run k of every method; a world's own ``max_steps`` replaces the
    configuration's."""
    names = [w.name for w in worlds]
    if len(set(names)) < len(names):
        raise ValueError(f"two worlds share a folder name: {', '.join(names)} (rename a map file)")
    out = Path(out).absolute()
    radii = sorted({c.robot.radius for c in configs.values()})
    runs = []
    for w in worlds:
        starts = _seeded_starts(w, radii, seeds)
        for method, config in configs.items():
            if w.max_steps is not None:
                config = config.overridden(max_steps=w.max_steps)
            for seed in seeds:
                world = w if w.start is not None else replace(w, start=starts[config.robot.radius, seed])
                runs.append(Run(world, config.model_dump(), seed, str(out / w.name / method / f"seed_{seed}")))
    return runs


def _seeded_starts(world: WorldSpec, radii: list[float], seeds: list[int]) -> dict:
    """{(radius, seed): (x, y, theta)} of ``sim.suite.sample_start``, for a world without a start."""
    if world.start is not None:
        return {}
    from sim.suite import sample_start

    loaded = world.load()
    poses = {(r, s): sample_start(loaded, r, s) for r in radii for s in seeds}
    return {key: (p.x(), p.y(), p.theta()) for key, p in poses.items()}


def execute(run: Run) -> dict:
    """Load the world, explore it and write the run's folder (metrics.json's ``world_spec`` loads
    the world again for ``gpexplore rerun``); the run's metrics. Runs in a worker."""
    world = run.world.load()
    result = run_episode(world, gtsam.Pose2(*run.world.start), EpisodeConfig.model_validate(run.config),
                         seed=run.seed)
    size = run.world.size
    result.metrics["world_spec"] = {"world": run.world.spec, "size": None if size is None else list(size),
                                    "resolution": run.world.resolution}
    write_episode(run.folder, result)
    return result.metrics


def finished(run: Run) -> bool:
    return (Path(run.folder) / "metrics.json").exists()


def check_resumable(runs: list[Run]) -> None:
    """Raise ValueError when a finished run's folder holds another run: a different
    configuration, world start or seed than ``runs`` asks for (mixing them would make a table
    of different experiments)."""
    from sim.config_file import CONFIG_NAME, read_config

    for run in filter(finished, runs):
        folder = Path(run.folder)
        metrics = json.loads((folder / "metrics.json").read_text())
        asked = EpisodeConfig.model_validate(run.config)
        found = read_config(folder / CONFIG_NAME) if (folder / CONFIG_NAME).exists() else None
        if found != asked:
            raise ValueError(f"{folder} holds a run with another configuration: give another output "
                             "directory, or delete the folder to run it again")
        if metrics["seed"] != run.seed or not np.allclose(metrics["start"], run.world.start):
            raise ValueError(f"{folder} holds a run from seed {metrics['seed']} and start "
                             f"{metrics['start']}: give another output directory, or delete the folder")


def failed(run: Run) -> bool:
    return not finished(run) and (Path(run.folder) / "error.json").exists()


def run_campaign(runs: list[Run], engine, on_end=None) -> dict[str, int]:
    """Run every unfinished run on ``engine``, all at once, and record each as it ends.

    ``on_end(run, metrics, error)`` is called as each run ends (``error`` is the traceback of a
    failed run, else None). Returns how many runs were already done, finished now and failed.
    """
    pending = [r for r in runs if not finished(r)]
    futures = {engine.submit(execute, r): r for r in pending}
    summary = {"done_before": len(runs) - len(pending), "finished": 0, "failed": 0}
    for future in engine.as_completed(futures):
        run = futures[future]
        error_file = Path(run.folder) / "error.json"
        try:
            metrics, error = future.result(), None
            error_file.unlink(missing_ok=True)
            summary["finished"] += 1
        except Exception as err:  # a failed run is recorded and the others go on
            metrics, error = None, "".join(traceback.format_exception(err))
            write_json_atomic(error_file, {"world": run.world.name, "method": run.method, "seed": run.seed,
                                           "error": f"{type(err).__name__}: {err}", "traceback": error})
            summary["failed"] += 1
        if on_end is not None:
            on_end(run, metrics, error)
    return summary


def run_line(run: Run, metrics: dict | None, error: str | None) -> str:
    """How a run ended, in one line (for ``run_campaign``'s ``on_end``): how it stopped, its
    travel, coverage and wall time, or the last line of its traceback."""
    name = f"{run.world.name} {run.method} seed {run.seed}"
    if error is not None:
        return f"{name} failed: {error.strip().splitlines()[-1]}"
    m = metrics
    return (f"{name}: {m['termination_reason']}, {m['travel_distance_m']:.1f} m, coverage "
            f"{100 * m['coverage']:.1f} %, {m['wall_time_s']:.1f} s wall")


def results(runs: list[Run]) -> dict[str, dict[str, list[dict]]]:
    """Metrics of the finished runs by world and method, in the order of ``runs``."""
    return _finished_by_world_and_method(runs, lambda folder: json.loads((folder / "metrics.json").read_text()))


def curves(runs: list[Run]) -> dict[str, dict[str, list[dict[str, np.ndarray]]]]:
    """The curve.csv samples of the finished runs by world and method, in the order of ``runs``."""
    return _finished_by_world_and_method(runs, lambda folder: read_curve(folder / "curve.csv"))


def _finished_by_world_and_method(runs: list[Run], read) -> dict[str, dict[str, list]]:
    out: dict[str, dict[str, list]] = {}
    for run in runs:
        found = out.setdefault(run.world.name, {}).setdefault(run.method, [])
        if finished(run):
            found.append(read(Path(run.folder)))
    return out


def _value(metrics: dict, key):
    if isinstance(key, tuple):
        metrics = metrics[key[0]]
        key = key[1]
    v = metrics.get(key)
    return np.nan if v is None else float(v)


def table(results: dict[str, list[dict]]) -> list[dict]:
    """Rows of Table I: per method, mean and standard error of each metric over the runs, and
    how many runs reached it (runs that never reached a coverage level are left out)."""
    rows = []
    for label, key, scale in ROWS:
        row = {"metric": label}
        for method, runs in results.items():
            values = np.array([_value(m, key) for m in runs]) * scale
            values = values[np.isfinite(values)]
            n = len(values)
            row[method] = {
                "mean": float(values.mean()) if n else None,
                "stderr": float(values.std(ddof=1) / np.sqrt(n)) if n > 1 else (0.0 if n else None),
                "n": n,
            }
        rows.append(row)
    return rows


def termination_counts(results: dict[str, list[dict]]) -> dict[str, dict[str, int]]:
    """How each method's runs ended."""
    counts = {}
    for method, runs in results.items():
        reasons = [m["termination_reason"] for m in runs]
        counts[method] = {r: reasons.count(r) for r in sorted(set(reasons))}
    return counts


#: Decimals of each Table I metric (by metrics key), the same for its mean and standard error.
DECIMALS = {"travel_distance_m": 1, "sim_time_s": 1, "entropy_rate_nats_per_step": 2,
            "final_map_entropy_nats": 0, "coverage": 1, "auc": 3, "travel_at_coverage_m": 1,
            "travel_at_last_gain_m": 1,
            "ate_rmse_m": 3, "collisions": 1, "wall_time_s": 1, "missed_area_m2": 1}


def _fixed(x: float, decimals: int) -> str:
    return f"{round(x, decimals) + 0.0:.{decimals}f}"  # + 0.0: no "-0.0"


def cell(value: dict, runs: int, decimals: int = 2) -> str:
    """A Table I entry: mean ± standard error with ``decimals`` decimals each, with the number
    of runs when some are missing."""
    if value["mean"] is None:
        return "—"
    return (f"{_fixed(value['mean'], decimals)} ± {_fixed(value['stderr'], decimals)}"
            + (f" (n={value['n']})" if value["n"] < runs else ""))


def table_markdown(runs: list[Run]) -> str:
    """Table I per world in Markdown, from the finished runs: a row per metric, a column per
    method (mean ± standard error, with the number of runs where some are missing), then how
    many runs finished or failed and how they ended. ``table.md`` holds it."""
    planned = Counter((r.world.name, r.method) for r in runs)
    lost = Counter((r.world.name, r.method) for r in runs if failed(r))
    md = ["# Table I: mean ± standard error over seeds", ""]
    for world, by_method in results(runs).items():
        methods = list(by_method)
        md += [f"## {world}", "", "| metric | " + " | ".join(methods) + " |", "|---|" + "---:|" * len(methods)]
        for (_, key, _), row in zip(ROWS, table(by_method), strict=True):
            decimals = DECIMALS.get(key[0] if isinstance(key, tuple) else key, 2)
            md.append(f"| {row['metric']} | "
                      + " | ".join(cell(row[m], planned[world, m], decimals) for m in methods) + " |")
        finished_runs = ", ".join(f"{m} {len(by_method[m])}/{planned[world, m]}"
                                  + (f" ({lost[world, m]} failed)" if lost[world, m] else "") for m in methods)
        ended = "; ".join(f"{m}: " + ", ".join(f"{reason} {n}" for reason, n in reasons.items())
                          for m, reasons in termination_counts(by_method).items() if reasons)
        md += ["", f"Runs finished: {finished_runs}. Ended: {ended or 'none yet'}.", ""]
    return "\n".join(md)


def write_tables(out: str | Path, runs: list[Run]) -> dict[str, list[dict]]:
    """``table.md`` (``table_markdown``) and ``table.csv`` (world, metric, method, mean, stderr,
    n) in ``out`` from the finished runs; returns Table I's rows by world."""
    out = Path(out)
    rows_by_world = {world: table(by_method) for world, by_method in results(runs).items()}
    text = io.StringIO()
    sheet = csv.writer(text, lineterminator="\n")
    sheet.writerow(["world", "metric", "method", "mean", "stderr", "n"])
    for world, rows in rows_by_world.items():
        for row in rows:
            sheet.writerows([world, row["metric"], m, _csv_number(v["mean"]), _csv_number(v["stderr"]), v["n"]]
                            for m, v in row.items() if m != "metric")
    write_text_atomic(out / "table.md", table_markdown(runs))
    write_text_atomic(out / "table.csv", text.getvalue())
    return rows_by_world


def _csv_number(v: float | None) -> str:
    return "" if v is None else repr(v)


def write_figures(out: str | Path, runs: list[Run]) -> list[Path]:
    """Per world, figures comparing the methods over the finished runs in ``out/figures/``:
    travel distance, coverage over travel and time, map entropy over steps."""
    from sim.campaign_figures import coverage_figure, entropy_band_figure, travel_figure

    folder = Path(out) / "figures"
    by_world, curves_by_world = results(runs), curves(runs)
    paths = []
    for world, by_method in by_world.items():
        if not any(by_method.values()):
            continue
        paths += [folder / f"{world}_travel.png", folder / f"{world}_coverage.png",
                  folder / f"{world}_entropy.png"]
        travel_figure(paths[-3], by_method, world)
        coverage_figure(paths[-2], curves_by_world[world], world)
        entropy_band_figure(paths[-1], curves_by_world[world], world)
    return paths
