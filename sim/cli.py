"""The `gpexplore` command line: parse, build, run with a progress bar, write results.

The options several commands share, and their validation, are in ``sim.cli_options``; what the
commands run is in the library (``sim.episode``, ``sim.campaign``, ``sim.logs``, ``sim.tour``).
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.markup import escape

from sim.cli_options import (Builtin, Config, Engine, Log, LogPoses, MaxSteps, Method, MethodOption,
                             Methods, OdomTopic, Out, Overwrite, Poses, PosesOption, Resolution, ScanTopic, Seed,
                             Seeds, Size, SkipMalformed, Solver, Start, World, WorldArgument, Worlds,
                             episode_config, fraction, numbers, positive)

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Autonomous exploration on continuous Gaussian-process frontier maps.")
#: soft_wrap: a line is never broken at the console's width (80 columns when piped), so
#: machine-readable lines stay whole.
console = Console(soft_wrap=True)
#: Warnings and status go to standard error, so that piped results stay clean.
err_console = Console(stderr=True, soft_wrap=True)


def warn(message: str) -> None:
    """A warning on standard error: ``warning: message``."""
    err_console.print(f"[yellow]warning:[/yellow] {escape(message)}")


def _version(value: bool) -> None:
    """``--version``: the installed package's version, then exit."""
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            typer.echo(f"gpexplore {version('gpexplore')}")
        except PackageNotFoundError:            # run from a source tree that was never installed
            typer.echo("gpexplore (not installed: version unknown)")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[bool, typer.Option(
        "--version", callback=_version, is_eager=True, help="print the version and exit")] = False,
):
    """Autonomous exploration on continuous Gaussian-process frontier maps."""


#: Steps between animation frames for ``explore --animate`` when the configuration sets none.
ANIMATE_EVERY = 10


def _check_out(out: Path, command: str, overwrite: bool) -> None:
    """Before any work: ``out`` can become this run's folder (``sim.results.check_run_folder``)."""
    from sim.results import OutputError, check_run_folder

    try:
        check_run_folder(out, command, overwrite)
    except OutputError as err:
        raise typer.BadParameter(str(err), param_hint="'--out'") from None


def _claim_out(out: Path, command: str, overwrite: bool) -> Path:
    """Clear an earlier run's files from ``out`` and mark it as this run's, once every input has
    been checked and just before the work starts."""
    from sim.results import OutputError, claim_run_folder

    try:
        return claim_run_folder(out, command, overwrite)
    except (OutputError, OSError) as err:
        raise typer.BadParameter(str(err), param_hint="'--out'") from None


def _results_line(out: Path) -> str:
    """``results in OUT/: a, b, figures/c``: the files the run wrote, its own folder's first."""
    from sim.results import RUN_MARKER

    files = sorted((p.relative_to(out) for p in out.rglob("*") if p.is_file() and p.name != RUN_MARKER),
                   key=lambda p: (len(p.parts), str(p)))
    return f"results in {out}/: {', '.join(map(str, files))}"


def _check_file(path: Optional[Path], option: str) -> None:
    """Before any work: a file can be written at ``path`` (given to ``option``)."""
    from sim.results import OutputError, check_output_file

    if path is None:
        return
    try:
        check_output_file(path)
    except OutputError as err:
        raise typer.BadParameter(str(err), param_hint=f"'{option}'") from None


@contextmanager
def _world_errors(option: str = "--world"):
    """A world that does not load is a usage error of ``option``; a start that is not free, of --start."""
    from sim.world_io import StartError

    try:
        yield
    except StartError as err:
        raise typer.BadParameter(str(err), param_hint="'--start'") from None
    except (ValueError, FileNotFoundError) as err:
        raise typer.BadParameter(str(err), param_hint=f"'{option}'") from None


@app.command()
def world(
    world: WorldArgument = "cave",
    size: Size = None,
    resolution: Resolution = None,
    start: Annotated[Optional[tuple[float, float]], typer.Option(
        parser=numbers("--start X Y"), metavar="X Y", help="start X Y (m) for the reachable area")] = None,
    radius: Annotated[float, typer.Option(callback=positive, help="robot radius, m")] = 0.25,
    out: Annotated[Optional[Path], typer.Option(dir_okay=False, help="write a figure of the world here (PNG)")] = None,
):
    """Load a world and print its frame, size and, from a start, the reachable free area."""
    from sim.world_io import load_world, start_area

    _check_file(out, "--out")
    with _world_errors("WORLD"):
        w = load_world(world, size=size, resolution=resolution)
    (rx, ry), (width, height) = w.resolution, w.size
    console.print(f"{w.name}: {w.shape[1]} x {w.shape[0]} cells of {rx:.4g} x {ry:.4g} m, "
                  f"{width:.3f} x {height:.3f} m, origin {w.origin}", markup=False)
    console.print(f"occupied: {100 * w.occupied.mean():.1f} % of cells")
    if start:
        with _world_errors():
            area = start_area(w, start, radius)
        console.print(f"reachable free space from ({start[0]:g}, {start[1]:g}): {area.reachable_m2:.1f} m² "
                      f"({100 * area.share:.1f} % of the {area.free_m2:.1f} m² a robot of radius {radius:g} m fits in)", markup=False)
        if area.enclosed:
            warn(area.warning())
    if out:
        from sim.figures import world_figure

        world_figure(out, w, start, radius)
        console.print(f"figure: {out}", markup=False)


@app.command()
def demo(
    out: Out = Path("results/tour"),
    world: Annotated[Builtin, typer.Option(help="built-in world whose scripted tour to drive")] = Builtin("cave"),
    seed: Seed = 0,
    overwrite: Overwrite = False,
):
    """Drive the robot along the built-in world's scripted tour and write truth, odometry and a
    figure (an earlier demo's folder is replaced; another run's needs --overwrite)."""
    from sim.figures import tour_figure
    from sim.tour import demo_tour
    from sim.worlds import BUILTIN_WORLDS
    from slam.atomic import write_json_atomic
    from slam.provenance import software
    from slam.tum import write_tum

    _claim_out(out, "demo", overwrite)
    builtin = BUILTIN_WORLDS[world.value]()
    log, m = demo_tour(builtin, seed, progress=True)
    write_tum(out / "ground_truth.tum", log.stamps, log.truth)
    write_tum(out / "odometry.tum", log.stamps, log.odometry)
    write_json_atomic(out / "metrics.json", {**m, "software": software()})
    tour_figure(out / "figures" / "tour.png", builtin.world, log)
    console.print(f"{m['steps']} scans, {m['travel_distance_m']:.1f} m in {m['sim_time_s']:.0f} s of robot "
                  f"time ({m['wall_time_s']:.1f} s wall), {m['collisions']} collisions, odometry drift "
                  f"{m['final_odometry_drift_m']:.2f} m at the end")
    console.print(_results_line(out), markup=False)


@app.command("map")
def map_(
    log: Log,
    poses: Annotated[LogPoses, typer.Option(
        help="log: the log's own poses (a bag's odometry); slam: the SLAM replay's")] = LogPoses.log,
    out: Out = Path("results/map"),
    config: Config = None,
    max_range: Annotated[Optional[float], typer.Option(
        callback=positive, help="mapping range, m: farther hits count as no return "
        "(default: the configuration's stack.com.training.max_range, 10)")] = None,
    holdout: Annotated[float, typer.Option(
        callback=fraction, help="fraction in [0, 1) of each scan's labelled points held out for the AUC")] = 0.0,
    every: Annotated[int, typer.Option(min=1, help="map every n-th scan (SLAM still uses them all)")] = 1,
    skip_malformed: SkipMalformed = False,
    scan_topic: ScanTopic = None,
    odom_topic: OdomTopic = None,
    overwrite: Overwrite = False,
):
    """Build the continuous occupancy map of a log: com.npz, map.pgm/yaml, metrics.json, figure;
    with --poses slam also the replay's trajectory.tum and graph.g2o; config.toml, the configuration used."""
    import numpy as np

    from mapping.export import save_com, write_ros_map
    from mapping.figure import com_figure
    from sim.config_file import CONFIG_NAME, write_config
    from sim.logs import map_log
    from slam.atomic import write_json_atomic
    from slam.provenance import software
    from slam.replay import replay_metrics, write_trajectory_and_graph

    _check_out(out, "map", overwrite)
    cfg = episode_config(config)
    if max_range is not None:
        cfg.stack.com.training.max_range = max_range
    records = _open_log(log, skip_malformed=skip_malformed, scan_topic=scan_topic, odom_topic=odom_topic)
    warnings = []
    if poses == LogPoses.log and not records.has_corrected_poses():
        warnings.append(f"{log.name} has no corrected poses: its own poses are its raw odometry, whose drift "
                        "smears the map; --poses slam maps it at Pose SLAM's poses")
        warn(warnings[-1])
    _claim_out(out, "map", overwrite)
    run = map_log(records, poses.value, cfg.stack.com, cfg.stack.slam, every, holdout, progress=True)
    metrics = {"log": str(log), "poses": poses.value, "warnings": warnings}
    if run.replay is not None:
        write_trajectory_and_graph(out, run.replay)
        metrics["slam"] = replay_metrics(records, run.replay)
        console.print(_replay_summary(metrics["slam"]))
    metrics.update(run.metrics, software=software())
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
    console.print(_results_line(out), markup=False)


@app.command()
def replay(
    log: Log,
    relations: Annotated[Optional[Path], typer.Option(
        exists=True, dir_okay=False, help="Kümmerle .relations file to score against")] = None,
    out: Out = Path("results/replay"),
    config: Config = None,
    max_range: Annotated[float, typer.Option(
        callback=positive, help="readings at or beyond this (m) are no return")] = 80.0,
    skip_malformed: SkipMalformed = False,
    scan_topic: ScanTopic = None,
    odom_topic: OdomTopic = None,
    overwrite: Overwrite = False,
):
    """Run Pose SLAM over a CARMEN log or ROS bag; write trajectory.tum, graph.g2o, metrics.json,
    config.toml (the configuration used) and, for a CARMEN log, corrected.clf."""
    from sim.config_file import CONFIG_NAME, write_config
    from sim.logs import replay_log
    from slam.evaluation import RelationsError, check_time_base, read_relations
    from slam.replay import write_replay

    _check_out(out, "replay", overwrite)
    cfg = episode_config(config)
    try:
        reference = read_relations(relations) if relations is not None else None
    except RelationsError as err:
        raise typer.BadParameter(str(err), param_hint="'--relations'") from None
    records = _open_log(log, max_range, skip_malformed, scan_topic, odom_topic)
    if reference is not None:
        try:
            check_time_base(reference, [r.scan.timestamp for r in records], str(log))
        except RelationsError as err:
            raise typer.BadParameter(str(err), param_hint="'--relations'") from None
    _claim_out(out, "replay", overwrite)
    result = replay_log(records, cfg.stack.slam, progress=True)
    write_config(out / CONFIG_NAME, cfg)
    try:
        metrics = write_replay(out, records, result, relations)
    except RelationsError as err:
        console.print(f"[red]error:[/red] {escape(str(err))}")
        raise typer.Exit(2) from None
    console.print(_replay_summary(metrics))
    for name, e in metrics.get("relation_error", {}).items():
        if isinstance(e, dict) and e["n"]:
            console.print(f"relation error {name} (n={e['n']}): {e['trans_mean_m']:.4f} ± {e['trans_std_m']:.4f} m, "
                          f"{e['rot_mean_deg']:.3f} ± {e['rot_std_deg']:.3f} deg")
    console.print(_results_line(out), markup=False)


def _open_log(path: Path, max_range: float = 80.0, skip_malformed: bool = False,
              scan_topic: Optional[str] = None, odom_topic: Optional[str] = None):
    """The laser records of a CARMEN log or, by its path, a ROS bag; a bad one exits 2 with the reason."""
    from sim.logs import open_log
    from slam.carmen import CarmenLog, LogFormatError
    from slam.rosbag import BagError

    try:
        records = open_log(path, max_range, skip_malformed, scan_topic, odom_topic)
    except (LogFormatError, BagError, FileNotFoundError) as err:
        hint = (" (--skip-malformed skips such lines, counted)"
                if isinstance(err, LogFormatError) and err.line is not None else "")
        console.print(f"[red]error:[/red] {escape(str(err))}{hint}")
        raise typer.Exit(2) from None
    except ValueError as err:                      # topics given for a CARMEN log
        raise typer.BadParameter(str(err), param_hint="'--scan-topic'" if scan_topic else "'--odom-topic'")
    if records.skipped:
        what, unit = ("malformed lines", "line") if isinstance(records, CarmenLog) else ("scans", "scan")
        number, reason = records.skipped[0]
        console.print(escape(f"skipped {len(records.skipped)} {what} (first: {unit} {number}: {reason})"))
    return records


def _replay_summary(metrics: dict) -> str:
    """One line from a replay's metrics: scans, keyframes, loop closures, wall time, fallbacks."""
    rtf = metrics["real_time_factor"]
    speed = f"{rtf:.1f}x real time" if rtf is not None else "no real-time factor: the log's stamps are broken"
    fallbacks = metrics["fallbacks"]
    return (f"SLAM: {metrics['scans']} scans, {metrics['keyframes']} keyframes, {metrics['loop_closures']} "
            f"loop closures in {metrics['wall_time_s']:.1f} s ({speed})"
            + (f"; fallbacks: {', '.join(f'{k} {v}' for k, v in fallbacks.items())}" if fallbacks else ""))


@app.command()
def posegraph(
    graph: Annotated[Path, typer.Argument(
        exists=True, dir_okay=False, metavar="GRAPH", help="2-D g2o pose graph (VERTEX_SE2 / EDGE_SE2)")],
    out: Annotated[Optional[Path], typer.Option(dir_okay=False, help="write the optimised graph here (g2o)")] = None,
    method: Annotated[Solver, typer.Option(help="GTSAM stage: dogleg or lm (both QR)")] = Solver.dogleg,
    frame_i_residual: Annotated[bool, typer.Option(
        help="minimise χ² with the translation residual left in frame i instead of rotated into the "
        "measurement's frame as g2o's EdgeSE2 does (the definition under which the published "
        "minima of the standard 2-D pose graphs were computed; the same for isotropic information)")] = False,
):
    """Optimise a 2-D g2o pose graph and print χ² before and after.

    GTSAM (dog-leg or Levenberg–Marquardt, QR) then Levenberg–Marquardt on g2o's exact χ².
    """
    import time

    from slam.g2o import G2oFormatError, chi2, optimize, read_g2o, refine_g2o, write_g2o

    _check_file(out, "--out")
    try:
        g = read_g2o(graph)
    except G2oFormatError as err:
        console.print(f"[red]error:[/red] {escape(str(err))}")
        raise typer.Exit(2) from None
    for message in g.warnings:
        warn(message)
    rotated = not frame_i_residual
    before = chi2(g, g.poses, rotated=rotated)
    # optimize_g2o's two stages, each one call that reports nothing until it returns: say what runs
    err_console.print(f"optimising {len(g.poses)} poses, {len(g.edges)} edges: GTSAM {method.value} (QR) ...",
                      markup=False)
    tic = time.perf_counter()
    values, iterations = optimize(g, method=method.value)
    err_console.print(f"GTSAM {method.value}: {iterations} iterations in {time.perf_counter() - tic:.1f} s; "
                      "Levenberg–Marquardt on g2o's exact chi2 ...", markup=False)
    poses, more = refine_g2o(g, {k: values.atPose2(k) for k in g.poses}, rotated=rotated)
    iterations += more
    wall = time.perf_counter() - tic
    after = chi2(g, poses, rotated=rotated)
    name = "chi2 (g2o EdgeSE2)" if rotated else "chi2 (translation residual in frame i)"
    console.print(f"{graph.name}: {len(g.poses)} poses, {len(g.edges)} edges", markup=False)
    console.print(f"{name}: {before:.6g} -> {after:.9g}")
    console.print(f"2 x GTSAM error at the result: {2 * g.factor_graph().error(g.values_of(poses)):.9g}")
    console.print(f"{iterations} iterations, {wall:.2f} s")
    if out:
        write_g2o(out, poses, g.edges)
        console.print(f"optimised graph: {out}", markup=False)


def _rerun_file(path: Optional[Path]) -> Optional[Path]:
    """``--rerun``: a .rrd file, and the Rerun SDK to write it."""
    if path is None:
        return None
    if path.suffix != ".rrd":
        raise typer.BadParameter(f"{path}: a Rerun recording is a .rrd file")
    _check_file(path, "--rerun")
    try:
        import rerun  # noqa: F401
    except ImportError:
        raise typer.BadParameter("no Rerun SDK: pip install gpexplore[viz]") from None
    return path


def _config_for(cfg, method: Optional[Method], poses: Optional[Poses], max_steps: Optional[int]):
    """``cfg`` with the options given on the command line (None keeps the configuration's)."""
    return cfg.overridden(method and method.value, poses and poses.value, max_steps)


@app.command()
def explore(
    world: World = "cave",
    size: Size = None,
    resolution: Resolution = None,
    start: Start = None,
    method: MethodOption = None,
    poses: PosesOption = None,
    seed: Seed = 0,
    max_steps: MaxSteps = None,
    config: Config = None,
    out: Out = Path("results/explore"),
    overwrite: Overwrite = False,
    animate: Annotated[bool, typer.Option(
        help="write figures/animation.gif (and .mp4 with ffmpeg): a frame every animate_every steps "
        f"(configuration; {ANIMATE_EVERY} if unset)")] = False,
    rerun: Annotated[Optional[Path], typer.Option(
        callback=_rerun_file, help=escape("record the run for the Rerun viewer to this .rrd file "
                                          "(pip install gpexplore[viz])"))] = None,
):
    """Explore a world with SLAM, the map and the frontier explorer in the loop; write results and
    config.toml, the configuration used (gpexplore rerun OUT runs it again)."""
    from sim.world_io import load_world, start_pose
    from sim.worlds import BUILTIN_WORLDS

    _check_out(out, "explore", overwrite)
    cfg = _config_for(episode_config(config), method, poses, max_steps)
    if animate and not cfg.animate_every:
        cfg = cfg.model_copy(update={"animate_every": ANIMATE_EVERY})
    with _world_errors():
        w = load_world(world, size=size, resolution=resolution)
        pose = start_pose(world, w, cfg.robot.radius, start)
    spec = {"world": world if world in BUILTIN_WORLDS else str(Path(world).resolve()),
            "size": list(size) if size else None, "resolution": resolution}
    _explore(w, pose, cfg, seed, out, overwrite, spec, rerun)


def _explore(w, pose, cfg, seed: int, out: Path, overwrite: bool, world_spec: dict,
             rerun: Optional[Path] = None) -> None:
    """Explore ``w`` from ``pose``, write the run into ``out`` with metrics.json's ``world_spec``
    (what loads the world again: ``world`` as given to --world, a file's absolute path, and
    ``size``, ``resolution``), and report it."""
    from sim.episode import run_episode
    from sim.results import write_episode
    from sim.world_io import start_area

    area = start_area(w, (pose.x(), pose.y()), cfg.robot.radius)
    if area.enclosed:
        warn(area.warning())
    _claim_out(out, "explore", overwrite)
    if rerun:
        from sim.rerun_log import RerunLog

        watch = RerunLog(rerun, w)
    else:
        watch = None
    result = run_episode(w, pose, cfg, seed=seed, progress=True, watch=watch)
    if watch:
        watch.close()
    result.metrics["world_spec"] = world_spec
    write_episode(out, result, progress=True)
    m = result.metrics
    console.print(f"{m['termination_reason']}: {m['travel_distance_m']:.1f} m in {m['sim_time_s']:.0f} s of "
                  f"robot time ({m['wall_time_s']:.1f} s wall), coverage {100 * m['coverage']:.1f} %, "
                  f"AUC {m['auc']:.3f}, ATE {m['ate_rmse_m']:.3f} m, {m['loop_closures']} loop closures, "
                  f"{m['collisions']} collisions")
    console.print(_results_line(out), markup=False)
    if rerun:
        console.print(f"Rerun recording: {rerun} (open it with: rerun {rerun})", markup=False)


RunDir = Annotated[Path, typer.Argument(
    exists=True, file_okay=False, metavar="RUN_DIR", help="an explore run's output folder")]


def _run_metrics(run: Path) -> dict:
    """RUN_DIR's metrics.json; a missing or unreadable one is a usage error naming it."""
    import json

    try:
        metrics = json.loads((run / "metrics.json").read_text())
        if not isinstance(metrics, dict):
            raise ValueError("not a JSON object")
    except (OSError, ValueError) as err:
        raise typer.BadParameter(f"{run / 'metrics.json'}: {err}", param_hint="'RUN_DIR'") from None
    return metrics


@app.command("rerun")
def rerun_(
    run: RunDir,
    out: Out = Path("results/rerun"),
    overwrite: Overwrite = False,
):
    """Run an explore run again from its folder: its config.toml (method, pose source, step
    budget, animation, every setting) and metrics.json's world (world_spec), start and seed. The
    metrics come out the same, but for the wall time."""
    import gtsam

    from sim.config_file import CONFIG_NAME
    from sim.world_io import load_world

    if out.resolve() == run.resolve():
        raise typer.BadParameter("is RUN_DIR itself: give another folder", param_hint="'--out'")
    _check_out(out, "explore", overwrite)
    metrics = _run_metrics(run)
    missing = [k for k in ("world", "start", "seed", "method", "poses") if k not in metrics]
    if missing:
        raise typer.BadParameter(f"{run / 'metrics.json'} has no {', '.join(missing)}: not an explore run's",
                                 param_hint="'RUN_DIR'")
    if not (run / CONFIG_NAME).is_file():
        raise typer.BadParameter(f"{run / CONFIG_NAME}: no such file", param_hint="'RUN_DIR'")
    try:
        cfg = episode_config(run / CONFIG_NAME).overridden(metrics["method"], metrics["poses"])
    except typer.BadParameter as err:
        raise typer.BadParameter(err.message, param_hint="'RUN_DIR'") from None
    spec = metrics.get("world_spec") or {"world": metrics["world"], "size": None, "resolution": None}
    try:
        w = load_world(spec["world"], size=spec["size"], resolution=spec["resolution"])
    except (ValueError, FileNotFoundError) as err:
        how = "" if "world_spec" in metrics else " (its metrics.json has no world_spec, only the world's name)"
        raise typer.BadParameter(f"cannot load the run's world{how}: {err}", param_hint="'RUN_DIR'") from None
    _explore(w, gtsam.Pose2(*metrics["start"]), cfg, int(metrics["seed"]), out, overwrite, spec)


@app.command()
def figures(
    run: RunDir,
    out: Annotated[Optional[Path], typer.Option(
        file_okay=False, help="folder for the figures (default: RUN_DIR/figures)")] = None,
):
    """Redraw an explore run's figures from its folder's files: map_trajectory.png (com.npz or
    map.pgm/yaml, trajectory.tum, ground_truth.tum, graph.g2o's loop closures, metrics.json) and
    entropy.png (curve.csv). Not frontier_maps.png, com_panels.png or the animation: the run's
    frontier snapshots, scans and frames are not saved."""
    from sim.results import OutputError, check_output_file, redraw_figures

    folder = out if out is not None else run / "figures"
    try:
        for name in ("map_trajectory.png", "entropy.png"):
            check_output_file(folder / name)
    except OutputError as err:
        raise typer.BadParameter(str(err), param_hint="'--out'") from None
    _run_metrics(run)
    try:
        written = redraw_figures(run, folder)
    except (FileNotFoundError, ValueError, KeyError) as err:
        console.print(f"[red]error:[/red] {escape(str(err))}")
        raise typer.Exit(2) from None
    console.print(f"figures: {', '.join(map(str, written))}", markup=False)


def _run_and_report(worlds, configs, seeds: int, out: Path, engine: str, workers, scheduler) -> None:
    """Run the campaign with a progress bar over its runs, write table.md, table.csv and figures/,
    print Table I per world; exit 1 when runs failed."""
    from rich.markdown import Markdown
    from tqdm import tqdm

    from sim.campaign import (check_resumable, finished, plan, run_campaign, run_line, table_markdown,
                              write_figures, write_tables)
    from sim.engines import make_engine

    try:
        runs = plan(out, worlds, configs, list(range(seeds)))
    except ValueError as err:
        raise typer.BadParameter(str(err), param_hint="'--worlds'") from None
    try:
        check_resumable(runs)
    except ValueError as err:
        raise typer.BadParameter(str(err), param_hint="'--out'") from None
    try:
        pool = make_engine(engine, workers, scheduler)
    except (ValueError, ImportError) as err:
        raise typer.BadParameter(str(err), param_hint="'--engine'") from None
    except OSError as err:
        raise typer.BadParameter(f"no Dask scheduler at {scheduler}: {err}", param_hint="'--scheduler'") from None
    console.print(f"{len(runs)} runs on the {pool.name} engine ({pool.workers} workers), results in {out}/", markup=False)
    with pool, tqdm(total=len(runs), initial=sum(map(finished, runs)), desc="runs", unit="run") as bar:

        def report(run, metrics, error):
            bar.write(run_line(run, metrics, error))
            bar.update()

        summary = run_campaign(runs, pool, report)
    write_tables(out, runs)
    figures = write_figures(out, runs)
    console.print(Markdown(table_markdown(runs)), soft_wrap=False)
    console.print(f"{summary['done_before']} runs were done before, {summary['finished']} finished now, "
                  f"{summary['failed']} failed")
    console.print(f"results in {out}/: <world>/<method>/seed_<k>/, table.md, table.csv, "
                  f"figures/ ({len(figures)} figures)", markup=False)
    if summary["failed"]:
        console.print("[red]failed runs[/red] (error.json in their folders; run again to retry them)")
        raise typer.Exit(1)


@app.command()
def campaign(
    ctx: typer.Context,
    worlds: Worlds = ("cave", "office"),
    suite: Annotated[Optional[Path], typer.Option(
        exists=True, help="a floor-plan suite (its folder or manifest.csv): explore its maps, or "
        "those --worlds names, each run from a random start drawn from its seed in the largest "
        "free region, at least 0.5 m from walls, with a step budget by the free area (60 scans "
        "per m², at least 6000; --max-steps caps it)")] = None,
    methods: Methods = ("gp", "grid"),
    seeds: Seeds = 10,
    engine: Annotated[Engine, typer.Option(help="local (process pool) or dask (Dask distributed)")] = Engine.local,
    scheduler: Annotated[Optional[str], typer.Option(
        help="Dask scheduler address (default: a local cluster)")] = None,
    workers: Annotated[Optional[int], typer.Option(min=1, help="worker processes (default: the CPU count)")] = None,
    size: Size = None,
    resolution: Resolution = None,
    poses: PosesOption = None,
    max_steps: MaxSteps = None,
    config: Config = None,
    out: Annotated[Path, typer.Option(file_okay=False, help="output directory (runs resume from it)")] = Path(
        "results/campaign"),
):
    """Run every (world, method, seed) in parallel; each run lands in its folder as it finishes, so
    an interrupted campaign resumes. Writes Table I per world (table.md, table.csv) and figures/."""
    from click.core import ParameterSource

    from sim.campaign import suite_world_spec, world_spec
    from sim.suite import suite_maps

    if scheduler is not None and workers is not None:
        raise typer.BadParameter("the cluster at --scheduler has its own workers", param_hint="'--workers'")
    base = episode_config(config)
    configs = {m.value: _config_for(base, m, poses, None if suite else max_steps) for m in methods}
    radius = base.robot.radius
    if suite is None:
        with _world_errors("--worlds"):
            specs = [world_spec(w, radius, None, size, resolution) for w in worlds]
    else:
        named = ctx.get_parameter_source("worlds") != ParameterSource.DEFAULT
        with _world_errors("--suite"):
            maps = suite_maps(suite, list(worlds) if named else None)
            specs = [suite_world_spec(str(m), radius, max_steps=max_steps) for m in maps]
    _run_and_report(specs, configs, seeds, out, engine.value, workers, scheduler)


@app.command()
def compare(
    world: World = "cave",
    size: Size = None,
    resolution: Resolution = None,
    start: Start = None,
    seeds: Seeds = 10,
    methods: Methods = ("gp", "grid"),
    poses: PosesOption = None,
    config: Config = None,
    out: Annotated[Path, typer.Option(file_okay=False, help="output directory (runs resume from it)")] = Path(
        "results/compare"),
):
    """Run the methods over seeded runs on one world (a campaign on this machine's cores) and
    print the paper's Table I (mean ± standard error); every run's folder holds its config.toml."""
    from sim.campaign import world_spec

    base = episode_config(config)
    configs = {m.value: _config_for(base, m, poses, None) for m in methods}
    with _world_errors():
        spec = world_spec(world, base.robot.radius, start, size, resolution)
    _run_and_report([spec], configs, seeds, out, "local", None, None)


config_app = typer.Typer(no_args_is_help=True, help="gpexplore's configuration file (TOML).")
app.add_typer(config_app, name="config")


@config_app.command("dump")
def config_dump(
    out: Annotated[Optional[Path], typer.Option(
        dir_okay=False, help="write the TOML here (default: standard output)")] = None,
    config: Config = None,
):
    """Write the full configuration as TOML (the defaults, or the --config file completed with
    them): every section and setting, each described; edit it and pass it to explore, compare,
    campaign, replay or map with --config."""
    from sim.config_file import dumps_config, write_config

    _check_file(out, "--out")
    cfg = episode_config(config)
    if out is None:
        typer.echo(dumps_config(cfg), nl=False)
    else:
        write_config(out, cfg)
        console.print(f"configuration: {out}", markup=False)


if __name__ == "__main__":
    app()
