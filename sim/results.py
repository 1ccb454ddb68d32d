"""Write what an exploration run produced: metrics, trajectories, pose graph, maps and figures."""

from __future__ import annotations

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
from slam.poses import positions
from slam.tum import write_tum


#: Columns of curve.csv, a run's samples over its steps.
CURVE_COLUMNS = ("step", "time_s", "travel_m", "coverage", "entropy_nats")


def write_episode(out: str | Path, result: EpisodeResult) -> None:
    """metrics.json, config.toml (the run's configuration), curve.csv, trajectory.tum,
    ground_truth.tum, graph.g2o (Pose SLAM), com.npz (a COM), map.pgm + map.yaml and figures/ (with the
    animation when frames were recorded) in ``out``; metrics.json, with the start's area
    (``start_metrics``), is written last, so a folder that has it holds a finished run."""
    out = Path(out)
    stack = result.stack
    if result.config is not None:
        write_config(out / CONFIG_NAME, result.config)
    write_curve(out / "curve.csv", result)
    write_tum(out / "trajectory.tum", result.stamps, result.estimate)
    write_tum(out / "ground_truth.tum", result.stamps, result.truth)
    if isinstance(stack.localiser, PoseSlam):
        stack.localiser.write_g2o(out / "graph.g2o")
    prob = stack.map.prob()
    if isinstance(stack.map, ContinuousOccupancyMap):
        save_com(out / "com.npz", stack.map)
    write_ros_map(out / "map.pgm", prob, stack.map.frame.origin, stack.map.frame.resolution)
    _figures(out / "figures", result, prob)
    write_json_atomic(out / "metrics.json", {**result.metrics, **start_metrics(result)})


def start_metrics(result: EpisodeResult) -> dict:
    """metrics.json's description of the start's area (``sim.world_io.StartArea``): reachable and
    free area, share, ``start_enclosed``, and the warning about an enclosed start in ``warnings``."""
    if result.world is None or result.config is None or not result.truth:
        return {}
    start = result.truth[0]
    area = start_area(result.world, (start.x(), start.y()), result.config.robot.radius)
    warnings = list(result.metrics.get("warnings", [])) + ([area.warning()] if area.enclosed else [])
    return {**area.metrics(), "warnings": warnings}


def _figures(folder: Path, result: EpisodeResult, prob: np.ndarray) -> None:
    stack = result.stack
    m = result.metrics
    loops = stack.loop_segments()
    title = (f"{m['world']} ({m['method']}): {m['travel_distance_m']:.0f} m, coverage "
             f"{100 * m['coverage']:.1f} %, {m['termination_reason']}")
    map_figure(folder / "map_trajectory.png", prob, stack.map.frame.extent, result.estimate,
               result.truth, loops, title)
    frontier_figure(folder / "frontier_maps.png", result.snapshots)
    entropy_figure(folder / "entropy.png", {m["method"]: result.curve})
    if result.frames:
        write_animation(folder, result)
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
