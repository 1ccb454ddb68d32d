"""Goal extraction (Section VI, eq. 11): threshold F, cluster with k-means, pick the best cluster."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from sklearn.cluster import KMeans

from exploration.paths import Approach, best_cell_near, near_distance


class GoalConfig(BaseModel):
    """How frontier points become goals."""

    model_config = ConfigDict(extra="forbid")

    threshold: float = Field(0.6, ge=0, description="keep points with F above this: the desired sensitivity")
    min_points: int = Field(20, ge=1, description="fewer frontier points than this (the C-frontier "
                            "method: in significant clusters) means no frontier is left (20 "
                            "points of 0.1 m: 2 m of frontier); a goal is kept while half "
                            "this many (half its cluster's, when fewer) remain near it")
    points_per_cluster: int = Field(40, ge=1, description="k = ceil(n / points_per_cluster)")
    alpha: float = Field(3.0, ge=0, description="weight of information against sqrt(distance); "
                         "the paper gives no value. n/N grows as frontiers run out, so a large α "
                         "sends the robot across the map late in a run for the biggest remnant")
    reach: float = Field(0.6, gt=0, description="meters from a frontier point to a goal cell")
    view: float = Field(4.0, ge=0, description="meters: a cluster with no reachable cell within "
                        "reach is approached from the reachable cell nearest to it in a straight "
                        "line, when that is within this (the far side of a door seen as a few "
                        "beams); 0 turns this off")
    blacklist_radius: float = Field(0.75, gt=0, description="meters around a failed goal")


@dataclass(frozen=True)
class FrontierCluster:
    """One k-means cluster of frontier points, scored by eq. 11.

    ``goal`` is the reachable cell nearest (by path) to the cluster, in meters, or None when
    no passable cell lies within ``reach`` of any of its points; ``distance`` is the path
    length to it (inf when unreachable).
    """

    points: np.ndarray
    centroid: np.ndarray
    mean_value: float
    distance: float
    goal: np.ndarray | None
    utility: float

    def served_from(self, goal: np.ndarray, distance: float) -> FrontierCluster:
        """The same cluster with its goal at ``goal`` (m), ``distance`` m of path away; its
        utility changes by eq. 11's √d term. The cluster must have a goal already."""
        return dataclasses.replace(self, goal=goal, distance=distance,
                                   utility=self.utility + math.sqrt(self.distance) - math.sqrt(distance))


class Blacklist:
    """Goals that could not be reached: frontier points near them are not offered again."""

    def __init__(self, radius: float):
        self.radius = radius
        self.centres: list[np.ndarray] = []

    def add(self, xy) -> None:
        self.centres.append(np.asarray(xy, dtype=float))

    def joined(self, other: Blacklist) -> Blacklist:
        """Both blacklists' goals, at this one's radius."""
        both = Blacklist(self.radius)
        both.centres = self.centres + other.centres
        return both

    def covers(self, points: np.ndarray) -> np.ndarray:
        """(n,) bool: points within ``radius`` of a blacklisted goal."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if not self.centres:
            return np.zeros(len(points), dtype=bool)
        d = np.linalg.norm(points[:, None, :] - np.array(self.centres)[None], axis=2)
        return (d < self.radius).any(axis=1)


def utility(mean_value: float, size: int, total: int, distance: float, alpha: float) -> float:
    """Eq. 11: α·m̄ᵢ·nᵢ/N − √dᵢ."""
    return alpha * mean_value * size / total - math.sqrt(distance)


def extract_goals(frontier: np.ndarray, origin, resolution: float, dist: np.ndarray,
                  config: GoalConfig, blacklist: Blacklist | None = None,
                  seed: int = 0, approach: Approach | None = None) -> list[FrontierCluster]:
    """Frontier clusters, best first (eq. 11); empty when fewer than ``min_points`` points of F
    are above the threshold outside the blacklist.

    Args:
        frontier: (h, w) C-frontier map F.
        origin: (x, y) of the centre of cell (0, 0), meters.
        resolution: cell size, meters.
        dist: (h, w) path length in meters from the robot to each cell (inf if unreachable),
            e.g. ``paths.distance_field`` over the passable cells.
        config: threshold, cluster size, α, reach.
        blacklist: goals to avoid.
        seed: for k-means.
        approach: where to look at a cluster no reachable cell is within reach of (else it
            has no goal); its ``blocked`` cells, when given, must not hide a cluster's nearest
            point from its goal (``best_cell_near``).
    """
    iy, ix = np.nonzero(frontier > config.threshold)
    points = np.asarray(origin) + resolution * np.column_stack([ix, iy])
    values = frontier[iy, ix]
    if blacklist is not None:
        keep = ~blacklist.covers(points)
        points, values, ix, iy = points[keep], values[keep], ix[keep], iy[keep]
    if len(points) < config.min_points:
        return []
    k = math.ceil(len(points) / config.points_per_cluster)
    labels = KMeans(n_clusters=k, n_init=1, random_state=seed).fit_predict(points)
    # path length to the best reachable cell within reach of each frontier point
    radius = max(1, round(config.reach / resolution))
    near = near_distance(dist, radius, np.column_stack([ix, iy]))
    clusters = []
    for label in range(k):
        members = labels == label
        if not members.any():
            continue
        d_points = near[members]
        best = int(np.argmin(d_points))
        distance = float(d_points[best])
        cell = None
        if np.isfinite(distance):
            cell = best_cell_near(dist, (ix[members][best], iy[members][best]), radius,
                                  None if approach is None else approach.blocked)
            distance = float(dist[cell[1], cell[0]])
        elif approach is not None:
            cell = approach.goal(np.column_stack([ix[members], iy[members]]))
            distance = math.inf if cell is None else float(dist[cell[1], cell[0]])
        goal = None if cell is None else np.asarray(origin) + resolution * cell
        mean_value = float(values[members].mean())
        score = utility(mean_value, int(members.sum()), len(points), distance, config.alpha)
        clusters.append(FrontierCluster(points[members], points[members].mean(axis=0), mean_value,
                                        distance, goal, score))
    clusters.sort(key=lambda c: -c.utility)
    return clusters

