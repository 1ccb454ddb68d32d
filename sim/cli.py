"""The `gpexplore` command line: parse, build, run with a progress bar, write results."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Optional

import gtsam
import numpy as np
import typer
from rich.console import Console

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Autonomous exploration on continuous Gaussian-process frontier maps.")
console = Console()
LOG_HELP = ("CARMEN log (.clf/.log, optionally .gz) or ROS bag (ROS 1 .bag; ROS 2 bag directory, "
            ".db3 or .mcap)")
SCAN_TOPIC_HELP = "ROS bags: the sensor_msgs/LaserScan topic (default: the only one, or /scan)"
ODOM_TOPIC_HELP = "ROS bags: the nav_msgs/Odometry topic (default: the only one, or /odom)"


def _load(world: str, size, resolution):
    from sim.world_io import load_world

    try:
        return load_world(world, size=size, resolution=resolution)
    except (ValueError, FileNotFoundError) as err:
        raise typer.BadParameter(str(err), param_hint="--world") from None


@app.command()
def world(
    world: str = typer.Argument("cave", help="built-in name (cave, office), bitmap or ROS .yaml"),
    size: Optional[tuple[float, float]] = typer.Option(None, help="bitmap size in meters: --size W H"),
    resolution: Optional[float] = typer.Option(None, help="bitmap resolution, m/pixel"),
    start: Optional[tuple[float, float]] = typer.Option(None, help="start X Y (m) for the reachable area"),
    radius: float = typer.Option(0.25, help="robot radius, m"),
    out: Optional[Path] = typer.Option(None, help="write a figure of the world here (PNG)"),
):
    """Load a world and print its frame, size and, from a start, the reachable free area."""
    w = _load(world, size, resolution)
    (rx, ry), (width, height) = w.resolution, w.size
    console.print(f"{w.name}: {w.shape[1]} x {w.shape[0]} cells of {rx:.4g} x {ry:.4g} m, "
                  f"{width:.3f} x {height:.3f} m, origin {w.origin}")
    console.print(f"occupied: {100 * w.occupied.mean():.1f} % of cells")
    if start:
        try:
            area = w.reachable(start, radius).sum() * rx * ry
        except ValueError as err:
            raise typer.BadParameter(str(err), param_hint="--start") from None
        console.print(f"reachable free space from {start}: {area:.1f} m²")
    if out:
        import matplotlib.pyplot as plt

        from sim.figures import plot_world, save_figure

        fig, ax = plt.subplots(figsize=(8, 8 * height / width + 0.5))
        plot_world(ax, w)
        save_figure(fig, out, dpi=120)
        console.print(f"figure: {out}")


@app.command()
def demo(
    out: Path = typer.Option(Path("results/demo"), help="output directory"),
    world: str = typer.Option("cave", help="built-in world with a demo tour: cave or office"),
    seed: int = typer.Option(0, help="seed for lidar and odometry noise"),
):
    """Drive the robot along the built-in world's scripted tour and write truth, odometry and a figure."""
    from sim.figures import tour_figure
    from sim.lidar import Lidar
    from sim.odometry import Odometry
    from sim.robot import Robot
    from sim.tour import drive_tour
    from sim.worlds import BUILTIN_WORLDS
    from slam.atomic import write_json_atomic
    from slam.tum import write_tum

    if world not in BUILTIN_WORLDS:
        raise typer.BadParameter(f"no built-in world '{world}' (have: {', '.join(BUILTIN_WORLDS)})",
                                 param_hint="--world")
    builtin = BUILTIN_WORLDS[world]()
    rng = np.random.SeedSequence(seed)
    lidar_seed, odom_seed = rng.spawn(2)
    robot = Robot(builtin.world, builtin.start)
    lidar = Lidar(seed=lidar_seed)
    odometry = Odometry(seed=odom_seed)
    tic = time.perf_counter()
    log = drive_tour(robot, lidar, odometry, builtin.tour, progress=True)
    wall = time.perf_counter() - tic
    write_tum(out / "ground_truth.tum", log.stamps, log.truth)
    write_tum(out / "odometry.tum", log.stamps, log.odometry)
    start = log.truth[0]
    drift = [np.hypot(*(start.compose(log.odometry[0].between(o)).translation() - t.translation()))
             for o, t in zip(log.odometry, log.truth)]
    metrics = {
        "world": builtin.world.name,
        "seed": seed,
        "start": [start.x(), start.y(), start.theta()],
        "steps": len(log.scans),
        "travel_distance_m": robot.distance,
        "sim_time_s": log.stamps[-1],
        "wall_time_s": wall,
        "collisions": robot.collisions,
        "final_odometry_drift_m": float(drift[-1]),
        "max_odometry_drift_m": float(max(drift)),
    }
    write_json_atomic(out / "metrics.json", metrics)
    tour_figure(out / "figures" / "tour.png", builtin.world, log)
    console.print(f"{metrics['steps']} scans, {robot.distance:.1f} m in {log.stamps[-1]:.0f} s of robot "
                  f"time ({wall:.1f} s wall), {robot.collisions} collisions, odometry drift "
                  f"{drift[-1]:.2f} m at the end")
    console.print(f"results in {out}/: metrics.json, ground_truth.tum, odometry.tum, figures/tour.png")


@app.command("map")
def map_(
    log: Path = typer.Argument(..., help=LOG_HELP),
    poses: str = typer.Option("log", help="log: the log's poses (a bag's odometry); slam: the SLAM replay"),
    out: Path = typer.Option(Path("results/map"), help="output directory"),
    config: Optional[Path] = typer.Option(None, help="configuration (TOML): its [stack.com] and, with "
                                          "--poses slam, [stack.slam] sections"),
    max_range: Optional[float] = typer.Option(None, help="mapping range, m: farther hits count as no "
                                              "return (default: stack.com.training.max_range, 10)"),
    holdout: float = typer.Option(0.0, help="fraction of each scan's labelled points held out for the AUC"),
    every: int = typer.Option(1, help="map every n-th scan (SLAM still uses them all)"),
    scan_topic: Optional[str] = typer.Option(None, help=SCAN_TOPIC_HELP),
    odom_topic: Optional[str] = typer.Option(None, help=ODOM_TOPIC_HELP),
):
    """Build the continuous occupancy map of a log: com.npz, map.pgm/yaml, metrics.json, figure;
    with --poses slam also the replay's trajectory.tum and graph.g2o; config.toml, the configuration used."""
    from mapping.export import save_com, write_ros_map
    from mapping.figure import com_figure
    from sim.config_file import CONFIG_NAME, write_config
    from sim.logs import map_log
    from slam.atomic import write_json_atomic
    from slam.replay import replay_metrics, write_trajectory_and_graph

    if poses not in ("log", "slam"):
        raise typer.BadParameter(f"unknown pose source '{poses}' (have: log, slam)", param_hint="--poses")
    if not 0 <= holdout < 1:
        raise typer.BadParameter(f"{holdout} is not a fraction in [0, 1)", param_hint="--holdout")
    if max_range is not None and not (max_range > 0 and math.isfinite(max_range)):
        raise typer.BadParameter(f"{max_range} m is not a positive finite range", param_hint="--max-range")
    if every < 1:
        raise typer.BadParameter(f"{every} is not a scan stride (1 or more)", param_hint="--every")
    cfg = _episode_config(config)
    if max_range is not None:
        cfg.stack.com.training.max_range = max_range
    records = _open_log(log, scan_topic=scan_topic, odom_topic=odom_topic)
    run = map_log(records, poses, cfg.stack.com, cfg.stack.slam, every, holdout, progress=True)
    metrics = {"log": str(log), "poses": poses}
    if run.replay is not None:
        write_trajectory_and_graph(out, run.replay)
        metrics["slam"] = replay_metrics(records, run.replay)
        console.print(_replay_summary(metrics["slam"]))
    metrics.update(run.metrics)
    com = run.map.com
    write_config(out / CONFIG_NAME, cfg)
    save_com(out / "com.npz", com)
    write_ros_map(out / "map.pgm", com.prob(), com.origin, com.resolution)
    write_json_atomic(out / "metrics.json", metrics)
    com_figure(out / "figures" / "com.png", com, np.asarray(run.map.origins), np.vstack(run.map.hits),
               title=log.name)
    m = run.metrics
    console.print(f"{m['keyframes']} scans mapped in {m['wall_time_s']:.1f} s (update median "
                  f"{m['update_ms_median']:.1f} ms, p95 {m['update_ms_p95']:.1f} ms); AUC {m['auc']:.4f} "
                  f"read continuously (bilinear), {m['auc_cell']:.4f} read per cell "
                  f"({m['holdout']['protocol']}); entropy {m['entropy_nats_0.2m']:.0f} nats")
    products = "com.npz, map.pgm, map.yaml, metrics.json, config.toml, figures/com.png"
    if poses == "slam":
        products += ", trajectory.tum, graph.g2o"
    console.print(f"results in {out}/: {products}")


@app.command()
def replay(
    log: Path = typer.Argument(..., help=LOG_HELP),
    relations: Optional[Path] = typer.Option(None, help="Kümmerle .relations file to score against"),
    out: Path = typer.Option(Path("results/replay"), help="output directory"),
    config: Optional[Path] = typer.Option(None, help="configuration (TOML): its [stack.slam] section"),
    max_range: float = typer.Option(80.0, help="readings at or beyond this (m) are no return"),
    skip_malformed: bool = typer.Option(False, help="skip malformed lines (counted) instead of failing"),
    scan_topic: Optional[str] = typer.Option(None, help=SCAN_TOPIC_HELP),
    odom_topic: Optional[str] = typer.Option(None, help=ODOM_TOPIC_HELP),
):
    """Run Pose SLAM over a CARMEN log or ROS bag; write trajectory.tum, graph.g2o, metrics.json,
    config.toml (the configuration used) and, for a CARMEN log, corrected.clf."""
    from sim.config_file import CONFIG_NAME, write_config
    from slam.carmen import CarmenLog
    from slam.evaluation import RelationsError
    from sim.logs import replay_log
    from slam.replay import write_replay

    cfg = _episode_config(config)
    records = _open_log(log, max_range, skip_malformed, scan_topic, odom_topic)
    result = replay_log(records, cfg.stack.slam, progress=True)
    write_config(out / CONFIG_NAME, cfg)
    try:
        metrics = write_replay(out, records, result, relations)
    except (RelationsError, FileNotFoundError) as err:
        console.print(f"[red]error:[/red] {err}")
        raise typer.Exit(2) from None
    console.print(_replay_summary(metrics))
    if "relation_error" in metrics:
        for name, e in metrics["relation_error"].items():
            if isinstance(e, dict) and e["n"]:
                console.print(f"relation error {name} (n={e['n']}): {e['trans_mean_m']:.4f} ± {e['trans_std_m']:.4f} m, "
                              f"{e['rot_mean_deg']:.3f} ± {e['rot_std_deg']:.3f} deg")
    corrected = "corrected.clf, " if isinstance(records, CarmenLog) else ""
    console.print(f"results in {out}/: trajectory.tum, graph.g2o, {corrected}metrics.json, config.toml, trajectory.png")


def _open_log(path: Path, max_range: float = 80.0, skip_malformed: bool = False,
              scan_topic: Optional[str] = None, odom_topic: Optional[str] = None):
    """The laser records of a CARMEN log or, by its path, a ROS bag; a bad one exits 2 with the reason."""
    from rich.markup import escape

    from slam.carmen import CarmenLog, LogFormatError
    from slam.rosbag import BagError, RosBag, is_bag

    bag = is_bag(path)
    if not bag and (scan_topic or odom_topic):
        raise typer.BadParameter(f"{path} is a CARMEN log, topics are for ROS bags",
                                 param_hint="--scan-topic" if scan_topic else "--odom-topic")
    try:
        if bag:
            records = RosBag(path, scan_topic, odom_topic, max_range=max_range)
        else:
            records = CarmenLog(path, max_range=max_range, skip_malformed=skip_malformed)
    except (LogFormatError, BagError, FileNotFoundError) as err:
        console.print(f"[red]error:[/red] {escape(str(err))}")
        raise typer.Exit(2) from None
    if records.skipped:
        what, unit = ("malformed lines", "line") if isinstance(records, CarmenLog) else ("scans", "scan")
        number, reason = records.skipped[0]
        console.print(escape(f"skipped {len(records.skipped)} {what} (first: {unit} {number}: {reason})"))
    return records


def _replay_summary(metrics: dict) -> str:
    """One line from a replay's metrics: scans, keyframes, loop closures, wall time."""
    return (f"SLAM: {metrics['scans']} scans, {metrics['keyframes']} keyframes, {metrics['loop_closures']} "
            f"loop closures in {metrics['wall_time_s']:.1f} s ({metrics['real_time_factor']:.1f}x real time)")


@app.command()
def posegraph(
    graph: Path = typer.Argument(..., help="2-D g2o pose graph (VERTEX_SE2 / EDGE_SE2)"),
    out: Optional[Path] = typer.Option(None, help="write the optimised graph here (g2o)"),
    method: str = typer.Option("dogleg", help="GTSAM stage: dogleg or lm (both QR)"),
    frame_i_residual: bool = typer.Option(False, help="minimise χ² with the translation residual left in "
                                          "frame i (the definition of SOURCES.md's reference minima)"),
):
    """Optimise a 2-D g2o pose graph and print χ² before and after.

    GTSAM (dog-leg or Levenberg–Marquardt, QR) then Levenberg–Marquardt on g2o's exact χ².
    """
    from slam.g2o import G2oFormatError, chi2, optimize_g2o, read_g2o, write_g2o

    try:
        g = read_g2o(graph)
    except (G2oFormatError, OSError) as err:
        console.print(f"[red]error:[/red] {err}")
        raise typer.Exit(2) from None
    if method not in ("dogleg", "lm"):
        raise typer.BadParameter("dogleg or lm", param_hint="--method")
    before = chi2(g, g.poses, rotated=not frame_i_residual)
    tic = time.perf_counter()
    poses, iterations = optimize_g2o(g, method=method, rotated=not frame_i_residual)
    wall = time.perf_counter() - tic
    after = chi2(g, poses, rotated=not frame_i_residual)
    name = "chi2 (translation residual in frame i)" if frame_i_residual else "chi2 (g2o EdgeSE2)"
    console.print(f"{graph.name}: {len(g.poses)} poses, {len(g.edges)} edges")
    console.print(f"{name}: {before:.6g} -> {after:.9g}")
    console.print(f"2 x GTSAM error at the result: {2 * g.factor_graph().error(g.values_of(poses)):.9g}")
    console.print(f"{iterations} iterations, {wall:.2f} s")
    if out:
        write_g2o(out, poses, g.edges)
        console.print(f"optimised graph: {out}")


def _episode_config(path: Optional[Path]):
    """The whole configuration (EpisodeConfig) in ``path``, TOML or YAML by suffix; defaults
    without one. A bad file is exit code 2 with the file, the dotted key and the problem."""
    from sim.config_file import ConfigError, read_config
    from sim.episode import EpisodeConfig

    if path is None:
        return EpisodeConfig()
    try:
        return read_config(path)
    except ConfigError as err:
        raise typer.BadParameter(str(err), param_hint="--config") from None


def _world_and_start(world: str, size, resolution, start, radius: float):
    from sim.worlds import BUILTIN_WORLDS, corner_start

    w = _load(world, size, resolution)
    if start is not None:
        pose = gtsam.Pose2(*start)
    elif world in BUILTIN_WORLDS:
        pose = BUILTIN_WORLDS[world]().start
    else:
        pose = corner_start(w, radius)
    if w.collides((pose.x(), pose.y()), radius):
        raise typer.BadParameter(f"start ({pose.x():.2f}, {pose.y():.2f}) is not free for a robot of "
                                 f"radius {radius} m", param_hint="--start")
    return w, pose


#: Steps between animation frames for ``explore --animate`` when the configuration sets none.
ANIMATE_EVERY = 10


@app.command()
def explore(
    world: str = typer.Option("cave", help="built-in name (cave, office), bitmap or ROS .yaml"),
    size: Optional[tuple[float, float]] = typer.Option(None, help="bitmap size in meters: --size W H"),
    resolution: Optional[float] = typer.Option(None, help="bitmap resolution, m/pixel"),
    start: Optional[tuple[float, float, float]] = typer.Option(
        None, help="start X Y THETA (m, m, rad); default: the built-in start or a free corner"),
    method: Optional[str] = typer.Option(None, help="gp (C-frontier on the COM) or grid (nearest "
                                         "frontier); default: stack.explorer.method, gp"),
    poses: Optional[str] = typer.Option(None, help="slam (Pose SLAM) or truth (perfect localisation); "
                                        "default: stack.poses, slam"),
    seed: int = typer.Option(0, help="seed of every random draw"),
    max_steps: Optional[int] = typer.Option(None, help="scans before the run stops; default: max_steps"),
    config: Optional[Path] = typer.Option(None, help="configuration (TOML, see `gpexplore config dump`)"),
    out: Path = typer.Option(Path("results/explore"), help="output directory"),
    animate: bool = typer.Option(False, help="write figures/animation.gif (and .mp4 with ffmpeg): "
                                 f"a frame every animate_every steps (config; {ANIMATE_EVERY} if unset)"),
    rerun: Optional[Path] = typer.Option(None, help="record the run for the Rerun viewer to this "
                                         ".rrd file (pip install "
                                         r"gpexplore\[viz])"),
):
    """Explore a world with SLAM, the map and the frontier explorer in the loop; write results and
    config.toml, the configuration used (--config config.toml with the same seed runs it again)."""
    from sim.episode import run_episode
    from sim.results import write_episode

    cfg = _config_for(_episode_config(config), method, poses, max_steps)
    if animate and not cfg.animate_every:
        cfg = cfg.model_copy(update={"animate_every": ANIMATE_EVERY})
    w, pose = _world_and_start(world, size, resolution, start, cfg.robot.radius)
    watch = _rerun_log(rerun, w) if rerun else None
    result = run_episode(w, pose, cfg, seed=seed, progress=True, watch=watch)
    if watch:
        watch.close()
    write_episode(out, result)
    m = result.metrics
    console.print(f"{m['termination_reason']}: {m['travel_distance_m']:.1f} m in {m['sim_time_s']:.0f} s of "
                  f"robot time ({m['wall_time_s']:.1f} s wall), coverage {100 * m['coverage']:.1f} %, "
                  f"AUC {m['auc']:.3f}, ATE {m['ate_rmse_m']:.3f} m, {m['loop_closures']} loop closures, "
                  f"{m['collisions']} collisions")
    console.print(f"results in {out}/: metrics.json, config.toml, trajectory.tum, ground_truth.tum, "
                  f"graph.g2o, map.pgm, map.yaml{', com.npz' if cfg.stack.explorer.method == 'gp' else ''}, "
                  "figures/")
    if rerun:
        console.print(f"Rerun recording: {rerun} (open it with: rerun {rerun})")


def _rerun_log(path: Path, world):
    """The Rerun recorder of a run; exit 2 when rerun-sdk is not installed."""
    if path.suffix != ".rrd":
        raise typer.BadParameter(f"{path}: a Rerun recording is a .rrd file", param_hint="--rerun")
    try:
        import rerun  # noqa: F401
    except ImportError:
        console.print(r"[red]error:[/red] --rerun needs the Rerun SDK: pip install gpexplore\[viz]")
        raise typer.Exit(2) from None
    from sim.rerun_log import RerunLog

    return RerunLog(path, world)


def _config_for(cfg, method: Optional[str], poses: Optional[str], max_steps: Optional[int]):
    """``cfg`` with the options given on the command line (None: keep the configuration's)."""
    from pydantic import ValidationError

    from sim.config_file import validation_message

    try:
        return cfg.overridden(method, poses, max_steps)
    except ValidationError as err:
        raise typer.BadParameter(validation_message(err, type(cfg)),
                                 param_hint="--method/--poses/--max-steps") from None


def _world_spec(world: str, size, resolution, start, radius: float):
    """A campaign's world, checked here (it loads, its start is free) and loaded again by each worker."""
    from sim.campaign import WorldSpec
    from sim.worlds import BUILTIN_WORLDS

    bitmap = world not in BUILTIN_WORLDS and Path(world).suffix.lower() not in (".yaml", ".yml")
    size, resolution = (size, resolution) if bitmap else (None, None)
    _, pose = _world_and_start(world, size, resolution, start, radius)
    spec = world if world in BUILTIN_WORLDS else str(Path(world).absolute())
    return WorldSpec(spec, (pose.x(), pose.y(), pose.theta()), size, resolution)


def _names(text: str, option: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names or len(set(names)) < len(names):
        raise typer.BadParameter(f"'{text}' is not a comma-separated list of distinct names", param_hint=option)
    return names


def _run_and_report(worlds, configs, seeds: int, out: Path, engine: str, workers, scheduler) -> None:
    """Run the campaign with a progress bar over its runs, write table.md, table.csv and figures/,
    print Table I per world; exit 1 when runs failed."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from sim.campaign import (cell, check_resumable, finished, plan, run_campaign, write_figures,
                              write_tables)
    from sim.engines import make_engine

    try:
        runs = plan(out, worlds, configs, list(range(seeds)))
    except ValueError as err:
        raise typer.BadParameter(str(err), param_hint="--worlds") from None
    try:
        check_resumable(runs)
    except ValueError as err:
        raise typer.BadParameter(str(err), param_hint="--out") from None
    try:
        pool = make_engine(engine, workers, scheduler)
    except (ValueError, ImportError) as err:
        raise typer.BadParameter(str(err), param_hint="--engine") from None
    except OSError as err:
        raise typer.BadParameter(f"no Dask scheduler at {scheduler}: {err}", param_hint="--scheduler") from None
    columns = (TextColumn("runs"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with pool, Progress(*columns, console=console) as bar:
        task = bar.add_task("runs", total=len(runs), completed=sum(finished(r) for r in runs))
        console.print(f"{len(runs)} runs on the {pool.name} engine ({pool.workers} workers), results in {out}/")

        def report(run, m, error):
            name = f"{run.world.name} {run.method} seed {run.seed}"
            if error is None:
                bar.console.print(f"{name}: {m['termination_reason']}, {m['travel_distance_m']:.1f} m, coverage "
                                  f"{100 * m['coverage']:.1f} %, {m['wall_time_s']:.1f} s wall")
            else:
                bar.console.print(f"[red]{name} failed:[/red] {error.strip().splitlines()[-1]}")
            bar.advance(task)

        summary = run_campaign(runs, pool, report)
    rows = write_tables(out, runs)
    figures = write_figures(out, runs)
    methods = list(configs)
    for world, world_rows in rows.items():
        view = Table(title=f"{world}: {seeds} runs per method, mean ± standard error")
        view.add_column("metric")
        for method in methods:
            view.add_column(method, justify="right")
        for row in world_rows:
            view.add_row(row["metric"], *(cell(row[m], seeds) for m in methods))
        console.print(view)
    console.print(f"{summary['done_before']} runs were done before, {summary['finished']} finished now, "
                  f"{summary['failed']} failed")
    console.print(f"results in {out}/: <world>/<method>/seed_<k>/, table.md, table.csv, "
                  f"figures/ ({len(figures)} figures)")
    if summary["failed"]:
        console.print("[red]failed runs[/red] (error.json in their folders; run again to retry them)")
        raise typer.Exit(1)


@app.command()
def campaign(
    worlds: str = typer.Option("cave,office", help="comma-separated worlds: built-in names, bitmaps, ROS .yaml"),
    methods: str = typer.Option("gp,grid", help="comma-separated methods"),
    seeds: int = typer.Option(10, min=1, help="runs per world and method (seeds 0..N-1)"),
    engine: str = typer.Option("local", help="local (process pool) or dask (Dask distributed)"),
    scheduler: Optional[str] = typer.Option(None, help="Dask scheduler address (default: a local cluster)"),
    workers: Optional[int] = typer.Option(None, min=1, help="worker processes (default: the CPU count)"),
    size: Optional[tuple[float, float]] = typer.Option(None, help="size of the bitmap worlds, m: --size W H"),
    resolution: Optional[float] = typer.Option(None, help="resolution of the bitmap worlds, m/pixel"),
    poses: Optional[str] = typer.Option(None, help="slam or truth; default: stack.poses, slam"),
    max_steps: Optional[int] = typer.Option(None, help="scans before a run stops; default: max_steps"),
    config: Optional[Path] = typer.Option(None, help="configuration (TOML, see `gpexplore config dump`)"),
    out: Path = typer.Option(Path("results/campaign"), help="output directory (runs resume from it)"),
):
    """Run every (world, method, seed) in parallel; each run lands in its folder as it finishes, so
    an interrupted campaign resumes. Writes Table I per world (table.md, table.csv) and figures/."""
    if scheduler is not None and workers is not None:
        raise typer.BadParameter("the cluster at --scheduler has its own workers", param_hint="--workers")
    base = _episode_config(config)
    configs = {m: _config_for(base, m, poses, max_steps) for m in _names(methods, "--methods")}
    specs = [_world_spec(w, size, resolution, None, base.robot.radius) for w in _names(worlds, "--worlds")]
    _run_and_report(specs, configs, seeds, out, engine, workers, scheduler)


@app.command()
def compare(
    world: str = typer.Option("cave", help="built-in name (cave, office), bitmap or ROS .yaml"),
    size: Optional[tuple[float, float]] = typer.Option(None, help="bitmap size in meters: --size W H"),
    resolution: Optional[float] = typer.Option(None, help="bitmap resolution, m/pixel"),
    start: Optional[tuple[float, float, float]] = typer.Option(None, help="start X Y THETA"),
    seeds: int = typer.Option(10, min=1, help="runs per method (seeds 0..N-1)"),
    methods: str = typer.Option("gp,grid", help="comma-separated methods"),
    poses: Optional[str] = typer.Option(None, help="slam or truth; default: stack.poses, slam"),
    config: Optional[Path] = typer.Option(None, help="configuration (TOML, see `gpexplore config dump`)"),
    out: Path = typer.Option(Path("results/compare"), help="output directory (runs resume from it)"),
):
    """Run the methods over seeded runs on one world (a campaign on this machine's cores) and
    print the paper's Table I (mean ± standard error); every run's folder holds its config.toml."""
    base = _episode_config(config)
    configs = {m: _config_for(base, m, poses, None) for m in _names(methods, "--methods")}
    spec = _world_spec(world, size, resolution, start, base.robot.radius)
    _run_and_report([spec], configs, seeds, out, "local", None, None)


config_app = typer.Typer(no_args_is_help=True, help="gpexplore's configuration file (TOML).")
app.add_typer(config_app, name="config")


@config_app.command("dump")
def config_dump(
    out: Optional[Path] = typer.Option(None, help="write the TOML here (default: standard output)"),
    config: Optional[Path] = typer.Option(None, help="dump this configuration file (TOML or YAML) "
                                          "completed with the defaults, instead of the defaults"),
):
    """Write the full configuration as TOML: every section and setting, each described; edit it
    and pass it to explore, compare, campaign, replay or map with --config."""
    from sim.config_file import dumps_config, write_config

    cfg = _episode_config(config)
    if out is None:
        typer.echo(dumps_config(cfg), nl=False)
    else:
        write_config(out, cfg)
        console.print(f"configuration: {out}")


if __name__ == "__main__":
    app()
