"""Where to go next: the C-frontier explorer (the paper's method) and the nearest-frontier baseline.

Both see the map as a snapshot (probability grids, origin, resolution) and the robot's pose,
and both keep their goal until its frontier is gone or its path is blocked: re-selecting at
every update makes the goal switch dozens of times a run. A goal the robot cannot reach is
blacklisted, with a radius, rather than retried forever.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from exploration.costmap import CostmapConfig, passable
from exploration.frontier import frontier_map
from exploration.goals import Blacklist, FrontierCluster, GoalConfig, extract_goals
from exploration.grid_frontier import grid_frontiers, nearest_frontier
from exploration.paths import best_cell_near, distance_field, near_distance, path_to


class ExplorerConfig(BaseModel):
    """How the explorer reads the map and picks goals."""

    model_config = ConfigDict(extra="forbid")

    method: Literal["gp", "grid"] = Field("gp", description="C-frontier on the COM, or "
                                          "nearest grid frontier (Yamauchi) on the log-odds grid")
    beta: float = Field(2.5, ge=0, description="β of eq. 10")
    smoothing: float = Field(0.1, ge=0, description="Gaussian smoothing of Λ, Λo before eq. 10, m")
    goals: GoalConfig = GoalConfig()
    costmap: CostmapConfig = Field(CostmapConfig(), description="the C-frontier method's, on the COM")
    grid_costmap: CostmapConfig = Field(
        CostmapConfig(near_wall_cost=2.0), description="the grid method's, on the log-odds grid: "
        "paths keep off walls where there is room, since on 0.2 m cells a path at the robot's "
        "clearance from a cell's centre can touch the wall the cell hides (on the Stage cave 2 "
        "of 10 runs ended pinned to a corner). The COM needs no such cost: on the office world it "
        "led SLAM into larger errors, and 4 of 8 runs lost a room")
    min_frontier_cells: int = Field(10, ge=1, description="grid method: smallest frontier region, cells")
    robot_radius: float = Field(0.25, gt=0, description="m")
    min_goal_distance: float = Field(0.3, ge=0, description="a goal closer than this (m) to the "
                                     "robot is one it cannot observe better: blacklisted")


@dataclass
class Plan:
    """The explorer's answer for one map snapshot.

    ``goal`` (2,) and ``path`` (k, 2) are in meters; ``goal`` is None when exploration is
    over, and ``done`` then says why: ``frontiers_exhausted`` (no significant frontier left)
    or ``no_reachable_goal`` (frontiers remain, none reachable). ``frontier`` is the map the
    goal came from: the C-frontier map F (gp), or 1 on the grid's frontier cells (grid).
    """

    goal: np.ndarray | None
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    done: str | None = None
    new_goal: bool = False
    clusters: list[FrontierCluster] = field(default_factory=list)
    frontier: np.ndarray | None = None


class Explorer:
    """Keeps a goal and a path to it, and chooses a new goal when needed.

    Call ``plan`` after map updates with the map snapshot; call ``reached`` when the robot
    arrived, and ``give_up`` when it cannot follow the path (e.g. stuck), which blacklists
    the goal.
    """

    def __init__(self, config: ExplorerConfig | None = None, seed: int = 0):
        self.config = config or ExplorerConfig()
        self.blacklist = Blacklist(self.config.goals.blacklist_radius)
        self.goal: np.ndarray | None = None
        self.target: np.ndarray = np.zeros((0, 2))  # the frontier points the goal serves
        self.goals_chosen = 0
        self._rng = np.random.default_rng(seed)

    def reached(self) -> None:
        """The robot arrived at the goal: the next ``plan`` chooses a new one."""
        self.goal = None

    def give_up(self, frontier: bool = True) -> None:
        """The current goal cannot be reached: blacklist it, and with ``frontier`` the frontier
        it serves too (the robot could not get to it; without, only the goal's neighbourhood)."""
        if self.goal is not None:
            self.blacklist.add(self.goal)
            if frontier:
                for p in self.target[:: max(1, len(self.target) // 8)]:
                    self.blacklist.add(p)
        self.goal = None

    def plan(self, prob: np.ndarray, prob_occ: np.ndarray | None, origin, resolution: float,
             pose: gtsam.Pose2) -> Plan:
        """A goal and a path for the robot at ``pose`` on this map snapshot.

        Args:
            prob: (h, w) occupancy probability (Λ, or the log-odds grid's).
            prob_occ: (h, w) Λo for the C-frontier method (None for the grid method).
            origin: (x, y) of the centre of cell (0, 0), meters.
            resolution: cell size, meters.
            pose: the robot's estimated pose.
        """
        c = self.config
        costmap = c.costmap if c.method == "gp" else c.grid_costmap
        origin = np.asarray(origin, dtype=float)
        here = np.array([pose.x(), pose.y()])
        start = np.round((here - origin) / resolution).astype(int)
        ok, cost = passable(prob, resolution, c.robot_radius, costmap, prob_occ)
        # the robot stands on free ground even where its sensor has not looked (behind it)
        h, w = prob.shape
        yy, xx = np.mgrid[0:h, 0:w]
        ok |= np.hypot(xx - start[0], yy - start[1]) * resolution <= c.robot_radius
        dist, parent = distance_field(ok, np.clip(start, 0, [w - 1, h - 1]), resolution, cost)
        reach = max(1, round(c.goals.reach / resolution))
        near = near_distance(dist, reach)

        if c.method == "gp":
            frontier = frontier_map(prob, prob_occ, resolution, c.beta, c.smoothing)
            points = _cells_above(frontier, c.goals.threshold)
        else:
            regions = grid_frontiers(prob, costmap, c.min_frontier_cells)
            points = np.vstack(regions) if regions else np.zeros((0, 2), int)
            frontier = np.zeros(prob.shape)        # the grid's frontier cells, for figures
            frontier[points[:, 1], points[:, 0]] = 1.0

        if self.goal is not None and self._goal_still_valid(points, origin, resolution, dist):
            goal_cell = np.round((self.goal - origin) / resolution).astype(int)
            return Plan(self.goal, self._path(parent, goal_cell, origin, resolution, here),
                        frontier=frontier)

        self.goal = None
        # a goal where the robot already stands is a frontier it cannot see from anywhere
        # reachable (e.g. behind a wall gap narrower than the robot): blacklist and choose again
        while True:
            if c.method == "gp":
                clusters = extract_goals(frontier, origin, resolution, dist, c.goals,
                                         self.blacklist, seed=int(self._rng.integers(2**31)))
                if not clusters:
                    return Plan(None, done="frontiers_exhausted", frontier=frontier)
                best = next((k for k in clusters if k.goal is not None), None)
                if best is None:
                    return Plan(None, done="no_reachable_goal", clusters=clusters, frontier=frontier)
                self.goal, self.target = best.goal, best.points
            else:
                clusters = []
                # blacklisted cells leave their region; what is left must still be a frontier
                regions = [kept for kept in (r[~self.blacklist.covers(origin + resolution * r)]
                                             for r in regions)
                           if len(kept) >= c.min_frontier_cells]
                if not regions:
                    return Plan(None, done="frontiers_exhausted", frontier=frontier)
                found = nearest_frontier(regions, near)
                if found is None:
                    return Plan(None, done="no_reachable_goal", frontier=frontier)
                k, cell = found
                self.goal = origin + resolution * best_cell_near(dist, cell, reach)
                self.target = origin + resolution * regions[k]
            if np.linalg.norm(self.goal - here) > c.min_goal_distance:
                break
            self.give_up(frontier=False)
        self.goals_chosen += 1
        goal_cell = np.round((self.goal - origin) / resolution).astype(int)
        return Plan(self.goal, self._path(parent, goal_cell, origin, resolution, here),
                    new_goal=True, clusters=clusters, frontier=frontier)

    def _goal_still_valid(self, frontier_cells: np.ndarray, origin, resolution, dist) -> bool:
        """The goal is still reachable and frontier points remain near its target."""
        cell = np.round((self.goal - origin) / resolution).astype(int)
        h, w = dist.shape
        if not (0 <= cell[0] < w and 0 <= cell[1] < h) or not np.isfinite(dist[cell[1], cell[0]]):
            return False
        if len(frontier_cells) == 0:
            return False
        points = origin + resolution * frontier_cells
        targets = np.vstack([self.target, self.goal[None]])
        near = np.min(np.linalg.norm(points[:, None, :] - targets[None, :: max(1, len(targets) // 32)],
                                     axis=2), axis=1)
        return bool(np.count_nonzero(near < self.config.goals.reach) >= self.config.goals.min_points // 2)

    @staticmethod
    def _path(parent, goal_cell, origin, resolution, here) -> np.ndarray:
        cells = path_to(parent, goal_cell)
        path = origin + resolution * cells
        path[0] = here
        return path


def _cells_above(grid: np.ndarray, threshold: float) -> np.ndarray:
    iy, ix = np.nonzero(grid > threshold)
    return np.column_stack([ix, iy])
