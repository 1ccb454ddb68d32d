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

from collections.abc import Sequence

import gtsam
import numpy as np
from scipy.spatial import cKDTree

from slam.config import RegistrationConfig
from slam.poses import pose_array
from slam.registration import scan_normals, transform

#: nearest neighbours asked for at first; a point whose neighbours within the radius are all too
#: near in travel asks for this many times more, until one is far enough or none is left
FIRST_NEIGHBOURS = 16


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
    ``radius``. ``driven`` (n,): the travel at each scan (default: along ``poses``); give the
    same to compare two trajectories of one log on the same pairs of scans."""
    config = registration or RegistrationConfig()
    driven = travel(poses) if driven is None else np.asarray(driven, float)
    world, normal, at = [], [], []
    for pose, points, metres in zip(poses, scans, driven, strict=True):
        laser = pose.compose(mount)
        world.append(transform(laser, points))
        normal.append(transform(gtsam.Pose2(0.0, 0.0, laser.theta()), scan_normals(points, config)))
        at.append(np.full(len(points), metres))
    world, normal, at = np.concatenate(world), np.concatenate(normal), np.concatenate(at)
    n = len(world)
    distance = np.full(n, np.nan)
    if n == 0:
        return distance
    tree = cKDTree(world)
    todo, k = np.arange(n), FIRST_NEIGHBOURS
    while todo.size:
        k = min(k, n)
        d, index = tree.query(world[todo], k=k, distance_upper_bound=radius)
        d, index = d.reshape(len(todo), -1), index.reshape(len(todo), -1)
        within = np.isfinite(d)
        index = np.where(within, index, 0)
        far = within & (np.abs(at[index] - at[todo, None]) >= min_travel)
        found = far.any(axis=1)
        rows, q = todo[found], index[found, far[found].argmax(axis=1)]
        offset = world[rows] - world[q]
        along = np.abs(np.sum(offset * normal[q], axis=1))
        distance[rows] = np.where(np.isfinite(along), along, np.linalg.norm(offset, axis=1))
        if k == n:
            break
        todo, k = todo[~found & within[:, -1]], 8 * k     # every neighbour within reach too near
    return distance


def self_consistency(distances: np.ndarray) -> dict:
    """The share of points seen again, and the median, 90th percentile and mean of their
    distances (m) to what was seen there before or after (``revisit_distances``)."""
    seen = distances[np.isfinite(distances)]
    if seen.size == 0:
        return {"revisited": 0.0, "median_m": None, "p90_m": None, "mean_m": None}
    return {"revisited": float(seen.size / distances.size), "median_m": float(np.median(seen)),
            "p90_m": float(np.percentile(seen, 90)), "mean_m": float(seen.mean())}
