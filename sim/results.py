"""Write what an exploration run produced: metrics, trajectories, pose graph, maps and figures;
and the run folders every command writes into (checked before the work, owned by one run)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np

from mapping.com import ContinuousOccupancyMap
from mapping.export import save_com, write_ros_map
from sim.config_file import CONFIG_NAME, write_config
from sim.animation import write_animation
from sim.episode import EpisodeResult
from sim.figures import entropy_figure, frontier_figure, map_figure
from sim.world_io import start_area
from slam.atomic import write_json_atomic, write_text_atomic
from slam.pose_slam import PoseSlam
from slam.provenance import software
from slam.poses import positions
from slam.tum import write_tum


#: The file that marks a folder as a gpexplore run's; it holds the command that wrote the folder.
RUN_MARKER = ".gpexplore-run"


class OutputError(ValueError):
    """An output path a run cannot write to; the message names it and says what to do."""


def check_output_file(path: str | Path) -> None:
    """Raise OutputError when a file cannot be written at ``path`` (it is a folder, or a parent is
    a file or not writable); an existing file is replaced. Checked before the work starts."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{path} is a folder, not a file")
    _check_creatable(path)


def check_run_folder(out: str | Path, command: str, overwrite: bool = False) -> None:
    """Raise OutputError when ``out`` cannot become the folder of a run of ``command`` (checked
    before the work starts, nothing is changed): it is a file, it cannot be created or written,
    it is a non-empty folder that gpexplore did not write, or it holds another run's results
    and ``overwrite`` is not given. A folder holding an earlier ``demo`` is the demo's to
    replace (the demo is meant to be run again)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputError(f"{out} is a file, not a folder")
    _check_creatable(out)
    if not out.is_dir() or not any(out.iterdir()):
        return
    owner = run_folder_owner(out)
    if owner is None:
        raise OutputError(f"{out} is not empty and is not a gpexplore run folder: give a new or empty "
                          "folder (--overwrite only replaces a gpexplore run's results)")
    if not overwrite and not (command == "demo" and owner == "demo"):
        what = f"a `{owner}` run's results" if owner else "another run's results"
        raise OutputError(f"{out} holds {what}: give --overwrite to replace them, or another folder")


def claim_run_folder(out: str | Path, command: str, overwrite: bool = False) -> Path:
    """Make ``out`` the folder of a run of ``command``: ``check_run_folder``, then clear the earlier
    run's files and mark the folder (``RUN_MARKER``). Returns ``out``."""
    out = Path(out)
    check_run_folder(out, command, overwrite)
    out.mkdir(parents=True, exist_ok=True)
    for entry in out.iterdir():
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()
    write_json_atomic(out / RUN_MARKER, {"command": command})
    return out


def run_folder_owner(folder: str | Path) -> str | None:
    """The command whose run wrote ``folder``: the marker's command, "" for a run folder of an
    older gpexplore (a metrics.json, or a config.toml gpexplore wrote, but no marker), None when
    gpexplore did not write it."""
    folder = Path(folder)
    try:
        return str(json.loads((folder / RUN_MARKER).read_text())["command"])
    except (OSError, ValueError, KeyError, TypeError):
        pass
    try:
        if isinstance(json.loads((folder / "metrics.json").read_text()), dict):
            return ""
    except (OSError, ValueError):
        pass
    try:
        with open(folder / CONFIG_NAME, encoding="utf-8") as f:
            if f.readline().startswith("# gpexplore configuration"):
                return ""
    except (OSError, ValueError):
        pass
    return None


def _check_creatable(path: Path) -> None:
    """OutputError unless ``path`` exists writable or can be created: its nearest existing parent
    is a writable folder."""
    probe = path if path.is_dir() else path.parent          # an existing file is replaced in its folder
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"cannot create {path}: {probe} is a file")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write {path}: {probe} is not writable")


#: Columns of curve.csv, a run's samples over its steps.
CURVE_COLUMNS = ("step", "time_s", "travel_m", "coverage", "entropy_nats")


def write_episode(out: str | Path, result: EpisodeResult, progress: bool = False) -> None:
    """metrics.json, config.toml (the run's configuration), curve.csv, trajectory.tum (the pose
    at each step as the robot then knew it), trajectory_final.tum (every step's pose after the
    run's last correction), ground_truth.tum, graph.g2o (Pose SLAM), com.npz (a COM), map.pgm + map.yaml and figures/ (with the
    animation when frames were recorded, its rendering with a progress bar when ``progress``) in ``out``; metrics.json, with the start's area
    (``start_metrics``), is written last, so a folder that has it holds a finished run."""
    out = Path(out)
    stack = result.stack
    if result.config is not None:
        write_config(out / CONFIG_NAME, result.config)
    write_curve(out / "curve.csv", result)
    write_tum(out / "trajectory.tum", result.stamps, result.estimate)
    write_tum(out / "trajectory_final.tum", result.stamps, stack.localiser.trajectory())
    write_tum(out / "ground_truth.tum", result.stamps, result.truth)
    if isinstance(stack.localiser, PoseSlam):
        stack.localiser.write_g2o(out / "graph.g2o")
    prob = stack.map.prob()
    if isinstance(stack.map, ContinuousOccupancyMap):
        save_com(out / "com.npz", stack.map)
    write_ros_map(out / "map.pgm", prob, stack.map.frame.origin, stack.map.frame.resolution)
    _figures(out / "figures", result, prob, progress)
    write_json_atomic(out / "metrics.json", {**result.metrics, **start_metrics(result), "software": software()})


def start_metrics(result: EpisodeResult) -> dict:
    """metrics.json's description of the start's area (``sim.world_io.StartArea``): reachable and
    free area, share, ``start_enclosed``, and the warning about an enclosed start in ``warnings``."""
    if result.world is None or result.config is None or not result.truth:
        return {}
    start = result.truth[0]
    area = start_area(result.world, (start.x(), start.y()), result.config.robot.radius)
    warnings = list(result.metrics.get("warnings", [])) + ([area.warning()] if area.enclosed else [])
    return {**area.metrics(), "warnings": warnings}


def run_title(metrics: dict) -> str:
    """The title of a run's figures, from its metrics.json."""
    m = metrics
    return (f"{m['world']} ({m['method']}): {m['travel_distance_m']:.0f} m, coverage "
            f"{100 * m['coverage']:.1f} %, {m['termination_reason']}")


def _figures(folder: Path, result: EpisodeResult, prob: np.ndarray, progress: bool) -> None:
    stack = result.stack
    m = result.metrics
    loops = stack.loop_segments()
    title = run_title(m)
    map_figure(folder / "map_trajectory.png", prob, stack.map.frame.extent, result.estimate,
               result.truth, loops, title)
    frontier_figure(folder / "frontier_maps.png", result.snapshots)
    entropy_figure(folder / "entropy.png", {m["method"]: result.curve})
    if result.frames:
        write_animation(folder, result, progress=progress)
    if isinstance(stack.map, ContinuousOccupancyMap):
        from mapping.figure import com_figure

        mapped = stack.mapped_scans()
        hits = [p.transformFrom(s.points().T).T for p, s in mapped]
        com_figure(folder / "com_panels.png", stack.map, positions(p for p, _ in mapped),
                   np.vstack(hits) if hits else None, title)



def write_curve(path: str | Path, result: EpisodeResult) -> None:
    """The run's samples of travel (m), coverage and map entropy (nats) over steps, as CSV."""
    m = result.metrics
    curve = np.array(result.curve, dtype=float).reshape(-1, 4)
    time = curve[:, :1] * m["sim_time_s"] / max(m["steps"], 1)
    rows = np.hstack([curve[:, :1], time, curve[:, 1:]])
    lines = [",".join(CURVE_COLUMNS)] + [f"{int(r[0])}," + ",".join(f"{v:.9g}" for v in r[1:]) for r in rows]
    write_text_atomic(path, "\n".join(lines) + "\n")


def read_curve(path: str | Path) -> dict[str, np.ndarray]:
    """curve.csv as one array per column (``CURVE_COLUMNS``)."""
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return dict(zip(CURVE_COLUMNS, data.T))


#: The figures ``redraw_figures`` draws again from a run folder's files (frontier_maps.png needs the
#: run's frontier snapshots, com_panels.png its scans and the animation its frames: none is saved).
REDRAWN_FIGURES = ("map_trajectory.png", "entropy.png")


def read_run_map(run: str | Path) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """A run's final map: ``prob`` (h, w), row 0 at the bottom, and its extent (xmin, xmax, ymin,
    ymax) in m; from com.npz when the run has one (a COM's probabilities), else from map.yaml
    (its image read as map_server reads it: free 0, occupied 1, unknown 0.5)."""
    from sim.world_io import read_ros_map

    run = Path(run)
    if (run / "com.npz").is_file():
        with np.load(run / "com.npz") as z:
            prob, r = np.asarray(z["prob"], float), float(z["resolution"])
            corner = np.asarray(z["origin"], float) - r / 2            # the centre of cell (0, 0)
    else:
        ros = read_ros_map(run / "map.yaml")
        prob = np.where(ros.state == ros.FREE, 0.0, np.where(ros.state == ros.OCCUPIED, 1.0, 0.5))
        corner, r = np.asarray(ros.origin, float), ros.resolution
    h, w = prob.shape
    return prob, (corner[0], corner[0] + w * r, corner[1], corner[1] + h * r)


def loop_segments_g2o(path: str | Path) -> np.ndarray:
    """(m, 2, 2) the loop closures of a run's graph.g2o as segments between their keyframes'
    poses: its edges between keyframes that are not consecutive (consecutive ones are the
    keyframe links)."""
    from slam.g2o import read_g2o

    graph = read_g2o(path)
    xy = {k: (p.x(), p.y()) for k, p in graph.poses.items()}
    loops = [(xy[i], xy[j]) for i, j, _, _ in graph.edges if abs(j - i) != 1]
    return np.array(loops, float).reshape(-1, 2, 2)


def redraw_figures(run: str | Path, folder: str | Path | None = None) -> list[Path]:
    """Draw a run's ``REDRAWN_FIGURES`` again from the files in its folder ``run`` into
    ``folder`` (default ``run``/figures): map_trajectory.png from the map (``read_run_map``),
    trajectory.tum, ground_truth.tum and graph.g2o's loops (none without a graph.g2o), titled
    from metrics.json; entropy.png from curve.csv. Returns the files written.

    Raises:
        FileNotFoundError: a file the figures need is missing (named).
    """
    from slam.tum import read_tum

    run = Path(run)
    folder = Path(folder) if folder is not None else run / "figures"
    for name in ("metrics.json", "trajectory.tum", "ground_truth.tum", "curve.csv"):
        if not (run / name).is_file():
            raise FileNotFoundError(f"{run / name}: no such file (an explore run's folder holds it)")
    if not (run / "com.npz").is_file() and not (run / "map.yaml").is_file():
        raise FileNotFoundError(f"{run}: no com.npz or map.yaml to draw the map from")
    metrics = json.loads((run / "metrics.json").read_text())
    prob, extent = read_run_map(run)
    _, estimate = read_tum(run / "trajectory.tum")
    _, truth = read_tum(run / "ground_truth.tum")
    graph = run / "graph.g2o"
    loops = loop_segments_g2o(graph) if graph.is_file() else np.zeros((0, 2, 2))
    map_figure(folder / "map_trajectory.png", prob, extent, estimate, truth, loops, run_title(metrics))
    curve = read_curve(run / "curve.csv")
    rows = np.column_stack([curve[c] for c in ("step", "travel_m", "coverage", "entropy_nats")])
    entropy_figure(folder / "entropy.png", {metrics["method"]: rows})
    return [folder / name for name in REDRAWN_FIGURES]
