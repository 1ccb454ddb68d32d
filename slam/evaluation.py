"""The relation-based error of Kümmerle et al. 2009 ("On measuring the accuracy of SLAM
algorithms"), as the Freiburg metricEvaluator computes it.

A ``.relations`` file holds ``t1 t2 x y z roll pitch yaw`` per line: the reference pose at t2 in
the robot frame at t1 (m, rad). Each time is matched to the nearest trajectory pose; if that is
more than 0.1 s away, the pose is moved along odometry: T_slam · T_odo(t_slam)⁻¹ · T_odo(t).
The error of a relation is δ = p(T(t1)⁻¹·T(t2)) − p(T_rel): translational ‖(δx, δy)‖ (m),
rotational |wrap(δθ)| (reported in deg).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import gtsam
import numpy as np

from slam.poses import pose_array
from slam.text import read_text

#: A trajectory pose within this of a relation time is used directly (s).
MATCH_TOLERANCE = 0.1
#: Relations whose times are farther than this from every pose are a different time base (s).
TIME_BASE_GAP = 10000.0


class RelationsError(ValueError):
    """A malformed or unusable relations file."""


@dataclass
class Relations:
    """(n,) times t1, t2 and (n, 3) reference relative poses (x, y, yaw)."""

    t1: np.ndarray
    t2: np.ndarray
    delta: np.ndarray


def read_relations(path: str | Path) -> Relations:
    """Read a ``.relations`` file (8 numbers per line, ``#`` comments).

    Raises:
        RelationsError: the file cannot be read, or a line is malformed (the file and line named).
    """
    path = Path(path)
    text = read_text(path, RelationsError)
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        if len(fields) != 8:
            raise RelationsError(f"{path}:{number}: relation line has {len(fields)} fields, expected 8 "
                                 "(t1 t2 x y z roll pitch yaw)")
        try:
            values = [float(f) for f in fields]
        except ValueError:
            raise RelationsError(f"{path}:{number}: relation line has a non-numeric field") from None
        if not np.all(np.isfinite(values)):
            raise RelationsError(f"{path}:{number}: relation line has a non-finite value")
        rows.append(values)
    if not rows:
        raise RelationsError(f"{path}: no relations")
    a = np.array(rows)
    return Relations(a[:, 0], a[:, 1], a[:, [2, 3, 7]])


@dataclass
class RelationError:
    """Per-relation errors and their summary.

    Attributes:
        translational: (n,) m.   rotational: (n,) deg.   duration: (n,) |t2 − t1| s.
        interpolated: how many relation times were bridged with odometry.
    """

    translational: np.ndarray
    rotational: np.ndarray
    duration: np.ndarray
    interpolated: int

    def summary(self, split: float = 5.0) -> dict:
        """Mean ± std (m, deg), and the 95th percentile and largest translational error (m),
        over all relations and split at ``split`` seconds."""
        out = {"relations": int(self.translational.size), "interpolated": self.interpolated}
        for name, mask in (("all", np.ones_like(self.duration, bool)),
                           (f"short_lt_{split:g}s", self.duration < split),
                           (f"long_ge_{split:g}s", self.duration >= split)):
            t, r = self.translational[mask], self.rotational[mask]
            out[name] = {"n": int(mask.sum()),
                         "trans_mean_m": float(t.mean()) if t.size else None,
                         "trans_std_m": float(t.std()) if t.size else None,
                         "trans_p95_m": float(np.percentile(t, 95)) if t.size else None,
                         "trans_max_m": float(t.max()) if t.size else None,
                         "rot_mean_deg": float(r.mean()) if r.size else None,
                         "rot_std_deg": float(r.std()) if r.size else None}
        return out


def _compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a ∘ b for (n, 3) poses."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack([a[:, 0] + c * b[:, 0] - s * b[:, 1], a[:, 1] + s * b[:, 0] + c * b[:, 1],
                            a[:, 2] + b[:, 2]])


def _between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a⁻¹ ∘ b for (n, 3) poses."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, b[:, 2] - a[:, 2]])


def _wrap(theta: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * theta))


def pose_at(times: np.ndarray, stamps: np.ndarray, poses: np.ndarray,
            odometry: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) poses at ``times``: the nearest pose, moved along odometry when it is more than
    ``MATCH_TOLERANCE`` away (and odometry is given). Also returns the (n,) time gaps."""
    order = np.argsort(stamps)
    s = stamps[order]
    pos = np.clip(np.searchsorted(s, times), 1, len(s) - 1)
    left, right = order[pos - 1], order[pos]
    nearest = np.where(np.abs(stamps[left] - times) <= np.abs(stamps[right] - times), left, right)
    gap = np.abs(stamps[nearest] - times)
    result = poses[nearest].copy()
    far = gap > MATCH_TOLERANCE
    if odometry is not None and far.any():
        # odometry at the relation time, linearly interpolated between the two bracketing scans
        lo, hi = order[pos - 1][far], order[pos][far]
        span = np.maximum(stamps[hi] - stamps[lo], 1e-9)
        f = np.clip((times[far] - stamps[lo]) / span, 0, 1)
        step = _between(odometry[lo], odometry[hi])
        odo_t = _compose(odometry[lo], np.column_stack([f[:, None] * step[:, :2], f * _wrap(step[:, 2])]))
        result[far] = _compose(poses[nearest[far]], _between(odometry[nearest[far]], odo_t))
    return result, gap


def check_time_base(relations: Relations, stamps, source: str = "log") -> None:
    """Raise RelationsError when the relation times match none of ``stamps`` (s): a different
    time base, or relations of another log. A trajectory's poses are at some of a log's scans,
    so a log whose scans pass this is worth replaying before ``relation_error``."""
    stamps = np.asarray(stamps, dtype=float)
    if stamps.size < 2:
        raise RelationsError(f"{source}: a trajectory needs at least two poses, got {stamps.size}")
    dummy = np.zeros((stamps.size, 3))
    _, g1 = pose_at(relations.t1, stamps, dummy, None)
    _, g2 = pose_at(relations.t2, stamps, dummy, None)
    _check_gap(np.maximum(g1, g2), source)


def _check_gap(gap: np.ndarray, source: str) -> None:
    if np.median(gap) > TIME_BASE_GAP or gap.min() > 1.0:
        raise RelationsError(f"relation times match no pose of the {source} (median gap {np.median(gap):.3g} s):"
                             " different time bases, or relations of another log")


def relation_error(relations: Relations, stamps, poses: list[gtsam.Pose2],
                   odometry: list[gtsam.Pose2] | None = None, source: str = "trajectory") -> RelationError:
    """Kümmerle et al.'s relation error of a trajectory (``stamps`` (n,), ``poses``), with raw
    ``odometry`` at the same stamps to bridge relation times more than 0.1 s from any pose."""
    stamps = np.asarray(stamps, dtype=float)
    if stamps.size < 2:
        raise RelationsError(f"{source}: a trajectory needs at least two poses, got {stamps.size}")
    xyt = pose_array(poses)
    odo = pose_array(odometry) if odometry is not None else None
    p1, g1 = pose_at(relations.t1, stamps, xyt, odo)
    p2, g2 = pose_at(relations.t2, stamps, xyt, odo)
    gap = np.maximum(g1, g2)
    _check_gap(gap, source)
    rel = _between(p1, p2)
    d = rel - relations.delta
    return RelationError(np.hypot(d[:, 0], d[:, 1]), np.degrees(np.abs(_wrap(d[:, 2]))),
                         np.abs(relations.t2 - relations.t1), int(np.sum(gap > MATCH_TOLERANCE)))
