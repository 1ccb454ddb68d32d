"""A log replay's results (a CARMEN log or ROS bag through Pose SLAM) in standard formats."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import gtsam
import numpy as np

from slam.atomic import write_json_atomic
from slam.carmen import CarmenLog, write_corrected_log
from slam.consistency import revisit_distances, self_consistency, travel
from slam.evaluation import read_relations, relation_error
from slam.laser_log import LaserLog, LaserMount
from slam.pose_slam import PoseSlam
from slam.provenance import software
from slam.poses import positions
from slam.tum import write_tum


@dataclass
class ReplayResult:
    """A finished replay: the SLAM object, every scan's final pose, and the wall time (s)."""

    slam: PoseSlam
    stamps: np.ndarray
    trajectory: list[gtsam.Pose2]
    wall_time: float
    mount: LaserMount | None = None


def write_replay(out: str | Path, log: LaserLog, result: ReplayResult,
                 relations: str | Path | None = None, figure: bool = True) -> dict:
    """Write trajectory.tum, graph.g2o, metrics.json (and trajectory.png) to ``out``, and for a
    CARMEN log corrected.clf (a bag has no CARMEN lines to correct: trajectory.tum holds its poses);
    returns the metrics."""
    out = Path(out)
    write_trajectory_and_graph(out, result)
    if isinstance(log, CarmenLog):
        write_corrected_log(out / "corrected.clf", log, result.trajectory, result.slam.laser_offset)
    metrics = {"log": str(log.path), **replay_metrics(log, result), "software": software()}
    if relations is not None:
        odometry = [r.odometry for r in log]
        error = relation_error(read_relations(relations), result.stamps, result.trajectory,
                               odometry if None not in odometry else None, source=str(log.path))
        metrics["relation_error"] = error.summary()
    write_json_atomic(out / "metrics.json", metrics)
    if figure:
        trajectory_figure(out / "trajectory.png", result)
    return metrics


def write_trajectory_and_graph(out: str | Path, result: ReplayResult) -> None:
    """``out``/trajectory.tum (every scan's pose) and ``out``/graph.g2o (the keyframe graph)."""
    out = Path(out)
    write_tum(out / "trajectory.tum", result.stamps, result.trajectory)
    result.slam.write_g2o(out / "graph.g2o")


def replay_metrics(log: LaserLog, result: ReplayResult) -> dict:
    """What the replay did: scans, keyframes, loop closures (proposed by the gates, verified by
    registration, accepted, and why the others were turned down), front-end matches with an
    unobservable direction, fallbacks from the normal path, the largest correction a loop made,
    wall time (s) and the real-time factor (None when the log's stamps are broken)."""
    slam = result.slam
    if isinstance(log, CarmenLog):
        source = {"skipped_lines": len(log.skipped)}
    else:
        source = {"scan_topic": log.scan_topic, "odom_topic": log.odom_topic, "skipped_scans": len(log.skipped)}
    return {
        "scans": len(log),
        **source,
        **(result.mount.metrics() if result.mount else {}),
        "warnings": [result.mount.warning] if result.mount and result.mount.warning else [],
        "keyframes": len(slam.graph),
        "loop_closures": len(slam.loops),
        "loops": {"proposed": slam.loop_counts["proposed"], "verified": slam.loop_counts["verified"],
                  "accepted": len(slam.loops), "rejected": dict(slam.detector.rejected),
                  "correlative_searches": slam.detector.searches},
        "degenerate_matches": slam.degenerate_matches,
        "fallbacks": {**slam.fallbacks, **slam.graph.fallbacks, **slam.front_end.counts},
        "largest_correction_m": slam.largest_correction,
        "self_consistency": log_consistency(log, result.trajectory, slam),
        "log_duration_s": log.duration,
        "wall_time_s": result.wall_time,
        "real_time_factor": (log.duration / result.wall_time
                             if result.wall_time > 0 and log.duration else None),
    }


def log_consistency(log: LaserLog, trajectory: list[gtsam.Pose2], slam: PoseSlam) -> dict:
    """How well ``trajectory``'s scans of ``log`` agree where the robot came back
    (``slam.consistency``), pairs of scans chosen by the travel along the log's own poses, so
    that two trajectories of one log are compared on the same pairs."""
    scans = [r.scan.points() for r in log]
    return self_consistency(revisit_distances(trajectory, scans, slam.laser_offset, travel([r.pose for r in log]),
                                              registration=slam.config.front_end.registration))


def trajectory_figure(path: str | Path, result: ReplayResult, max_points: int = 200000) -> None:
    """The keyframe scans at their optimised poses, the trajectory, and the loop closures."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from slam.registration import transform

    slam = result.slam
    poses = slam.keyframe_poses()
    cloud = np.concatenate([transform(p.compose(slam.laser_offset), s.points())
                            for p, s in zip(poses, slam.keyframe_scans)])
    if len(cloud) > max_points:
        cloud = cloud[np.random.default_rng(0).choice(len(cloud), max_points, replace=False)]
    xy = positions(result.trajectory)
    fig, ax = plt.subplots(figsize=(10, 10))
    ax.scatter(cloud[:, 0], cloud[:, 1], s=0.2, c="0.3", linewidths=0)
    ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:blue", lw=0.8, label="trajectory")
    for loop in slam.loops:
        a, b = poses[loop.candidate.j], poses[loop.candidate.k]
        ax.plot([a.x(), b.x()], [a.y(), b.y()], "-", color="tab:red", lw=0.8)
    ax.plot([], [], "-", color="tab:red", label=f"{len(slam.loops)} loop closures")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
