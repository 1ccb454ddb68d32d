"""How well a trajectory's scans agree where the robot came back: a map's quality measured without
a reference, as ground-truth-free evaluations of laser maps do (the mean map entropy of Droeschel
et al., Razlaw et al. 2015). A replay of a user's own log has no GMapping poses to agree with,
and agreeing with GMapping is not being right: where a corridor leaves the position along it
unobserved, two trajectories can differ by a metre and both lay the walls on the walls.

Each scan point is set in the world at its scan's pose (composed with the laser's mount) and met
with the nearest point of the scans taken at least ``min_travel`` metres of travel before or after
it: a revisit, not the scans the front end matched it to. Its distance is read along that
neighbour's surface normal (point to line: a wall sampled at other bearings lies on the same line)
or point to point where the neighbour has none. A point with no such neighbour within ``radius``
saw nothing seen again and does not count.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence

import gtsam
import numpy as np
from scipy.spatial import cKDTree

from slam.config import RegistrationConfig
from slam.poses import pose_array
from slam.registration import scan_normals, transform

def travel(poses: Sequence[gtsam.Pose2]) -> np.ndarray:
    """(n,) the distance (m) driven from the first pose to each pose."""
    xy = pose_array(poses)[:, :2]
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])


def revisit_distances(poses: Sequence[gtsam.Pose2], scans: Sequence[np.ndarray],
                      mount: gtsam.Pose2 = gtsam.Pose2(), driven: np.ndarray | None = None,
                      min_travel: float = 5.0, radius: float = 0.5,
                      registration: RegistrationConfig | None = None) -> np.ndarray:
    """(m,) the distance (m) of every point of ``scans`` (beam-ordered, in the laser's frame; one
    per pose) to the scans ``min_travel`` metres of travel away, NaN where none lies within
    ``radius``. ``driven`` (n,): the travel at each scan, never decreasing (default: along
    ``poses``); give the same to compare two trajectories of one log on the same pairs of scans."""
    config = registration or RegistrationConfig()
    driven = travel(poses) if driven is None else np.asarray(driven, float)
    if np.any(np.diff(driven) < 0):
        raise ValueError("driven: the travel at each scan must not decrease")
    world, normal = [], []
    for pose, points in zip(poses, scans, strict=True):
        laser = pose.compose(mount)
        world.append(transform(laser, points))
        normal.append(transform(gtsam.Pose2(0.0, 0.0, laser.theta()), scan_normals(points, config)))
    starts = np.concatenate([[0], np.cumsum([len(points) for points in world])]).astype(np.intp)
    distance = np.full(starts[-1], np.nan)
    if starts[-1] == 0:
        return distance
    world, normal = np.concatenate(world), np.concatenate(normal)
    nearest, index = _nearest_revisits(world, starts, driven, min_travel, radius)
    rows = np.flatnonzero(np.isfinite(nearest))
    offset = world[rows] - world[index[rows]]
    along = np.abs(np.sum(offset * normal[index[rows]], axis=1))
    distance[rows] = np.where(np.isfinite(along), along, np.linalg.norm(offset, axis=1))
    return distance


def _nearest_revisits(world: np.ndarray, starts: np.ndarray, driven: np.ndarray, min_travel: float,
                      radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(n,) the distance to, and (n,) the index of, each of ``world``'s points' (n, 2) nearest
    point within ``radius`` among the scans ``min_travel`` or more of travel from its own (inf
    and n where none). Scan s's points are ``world[starts[s]:starts[s + 1]]``, and ``driven``
    (scans,) the travel at each, never decreasing: the scans far enough from scan s are those
    before ``before[s]`` and from ``after[s]`` on. Each of those two runs of scans is cut into
    aligned blocks of 2^p scans (a segment tree's nodes, at most 2 log2(scans) a run); a tree of
    a block's points is built once and asked by every scan whose runs hold that block. Asking
    for more and more nearest neighbours until one is far enough in travel instead took 41 s on
    CSAIL, whose scans a metre apart see the same walls hundreds of times on one pass."""
    count, n = len(driven), len(world)
    before = np.searchsorted(driven, driven - min_travel, side="right")
    after = np.searchsorted(driven, driven + min_travel, side="left")
    askers: dict[tuple[int, int], list[int]] = defaultdict(list)
    for s in range(count):
        for block in (*_aligned_blocks(0, int(before[s])), *_aligned_blocks(int(after[s]), count)):
            askers[block].append(s)
    nearest, index = np.full(n, np.inf), np.full(n, n)
    for (low, high), asking in askers.items():
        if starts[low] == starts[high]:
            continue
        rows = _points_of(np.asarray(asking), starts)
        d, i = cKDTree(world[starts[low]:starts[high]]).query(world[rows], distance_upper_bound=radius)
        closer = d < nearest[rows]
        nearest[rows[closer]], index[rows[closer]] = d[closer], starts[low] + i[closer]
    return nearest, index


def _aligned_blocks(low: int, high: int):
    """The blocks [m 2^p, (m + 1) 2^p) that cover [low, high), each the largest that starts
    where the last ended and fits."""
    while low < high:
        size = 1 << ((high - low).bit_length() - 1)
        if low:
            size = min(size, low & -low)
        yield low, low + size
        low += size


def _points_of(scans: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """The indices of the points of ``scans`` (k,), scan s's being ``starts[s]:starts[s + 1]``."""
    counts = starts[scans + 1] - starts[scans]
    return np.repeat(starts[scans] - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())


def self_consistency(distances: np.ndarray) -> dict:
    """The share of points seen again, and the median, 90th percentile and mean of their
    distances (m) to what was seen there before or after (``revisit_distances``)."""
    seen = distances[np.isfinite(distances)]
    if seen.size == 0:
        return {"revisited": 0.0, "median_m": None, "p90_m": None, "mean_m": None}
    return {"revisited": float(seen.size / distances.size), "median_m": float(np.median(seen)),
            "p90_m": float(np.percentile(seen, 90)), "mean_m": float(seen.mean())}
