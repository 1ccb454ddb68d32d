"""Where to go next: goal choice and goal keeping, shared by the C-frontier explorer (the
paper's method) and the nearest-frontier baseline.

Both read the map as a snapshot and the robot's pose, and differ only in how they find frontiers
and rank them (``frontier_methods.py``). Both keep their goal until its frontier is gone or its
path is blocked: re-selecting at every update makes the goal switch dozens of times a run. A goal
the robot cannot reach is blacklisted, with a radius, rather than retried forever.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy import ndimage
from scipy.spatial import cKDTree

from exploration.costmap import CostmapConfig, driven, passable
from exploration.follower import rest_of_path
from exploration.frontier_methods import (CFrontier, DoorFrontier, Frontier, GridFrontier, MissedByF,
                                          Reachable, evidence)
from exploration.goals import Blacklist, FrontierCluster, GoalConfig
from exploration.paths import distance_field
from mapping.occupancy import MapSnapshot


class ExplorerConfig(BaseModel):
    """How the explorer reads the map and picks goals."""

    model_config = ConfigDict(extra="forbid")

    method: Literal["gp", "grid"] = Field("gp", description="C-frontier on the COM, or "
                                          "nearest grid frontier (Yamauchi) on the log-odds grid")
    beta: float = Field(2.5, ge=0, description="β of eq. 10")
    smoothing: float = Field(0.1, ge=0, description="Gaussian smoothing of Λ, Λo before eq. 10, m")
    goals: GoalConfig = GoalConfig()
    costmap: CostmapConfig = Field(CostmapConfig(), description="the C-frontier method's, on the "
                                   "stack's costmap grid")
    grid_costmap: CostmapConfig = Field(
        CostmapConfig(near_wall_cost=2.0), description="the grid method's, on its log-odds grid: "
        "paths keep off walls where there is room")
    min_frontier_cells: int = Field(5, ge=1, description="grid method: smallest frontier region, "
                                    "cells (0.5 m of 0.1 m cells, the robot's diameter: the "
                                    "narrowest gap it passes; a region whose look shows less than "
                                    "min_gain is not significant either). 10 dropped the frontiers "
                                    "of 0.85-0.95 m doors seen at a slant or past a jamb, and rooms "
                                    "of held-out buildings with them")
    door_width: float = Field(1.0, gt=0, description="m, the widest door the stop's checks look "
                              "for: the door check's longest region, the gap a wedge of beams is "
                              "seen through")
    robot_radius: float = Field(0.25, gt=0, description="m")
    min_goal_distance: float = Field(0.3, ge=0, description="a goal closer than this (m) to the "
                                     "robot is one it cannot observe better: blacklisted")
    min_gain: float = Field(1.0, ge=0, description="m², both methods: a frontier cluster (a grid "
                            "region) whose goal, and the goals by its other points, would show "
                            "less unknown area than this, looking round to sensor_range, is not "
                            "significant (the stop's sensitivity; missed_area_m2 counts regions "
                            "of 1 m²). 0: every cluster counts (for the grid, Yamauchi's stop: "
                            "no frontier region of min_frontier_cells left)")
    sensor_range: float = Field(8.0, gt=0, description="m, the laser's, for that look")
    closed_stretch: float = Field(0.75, gt=0, description="meters of path ahead of a robot that "
                                  "got stuck closed to later paths: a passage the map reads "
                                  "passable that the robot cannot pass (a gap narrower than it, "
                                  "read wider through pose error or the costmap's squeeze) is "
                                  "tried once, not once for every frontier behind it")


Done = Literal["frontiers_exhausted", "no_reachable_goal"]


@dataclass
class Plan:
    """The explorer's answer for one map snapshot.

    ``goal`` (2,) and ``path`` (k, 2) are in meters; ``goal`` is None when exploration is
    over, and ``done`` then says why: ``frontiers_exhausted`` (no significant frontier left)
    or ``no_reachable_goal`` (frontiers remain, none reachable). ``clusters`` are the ranked
    frontier clusters of a new goal choice, and ``frontier`` the map it was made on: the
    C-frontier map F (gp), or 1 on the grid's frontier cells (grid); a plan that kept its goal
    has neither (empty, None).
    """

    goal: np.ndarray | None
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    done: Done | None = None
    new_goal: bool = False
    clusters: list[FrontierCluster] = field(default_factory=list)
    frontier: np.ndarray | None = None


class Explorer:
    """Keeps a goal and a path to it, and chooses a new goal when needed.

    Call ``plan`` after map updates with the map snapshot; call ``reached`` when the robot
    arrived, and ``stuck`` when it cannot follow the path, which closes the path's stretch
    ahead of it and blacklists the goal.
    """

    def __init__(self, config: ExplorerConfig | None = None, seed: int = 0):
        self.config = config or ExplorerConfig()
        c = self.config
        self.method = CFrontier(c) if c.method == "gp" else GridFrontier(c)
        self.doors = DoorFrontier(c, self.method.costmap)
        # the stop's checks, once the method finds no goal: doors, and for the C-frontier the
        # grid's regions, which F can miss (``_choose``)
        self.checks: tuple[GridFrontier, ...] = ((self.doors,) if c.method == "grid"
                                                 else (self.doors, MissedByF(c, self.method.costmap)))
        self.source: CFrontier | GridFrontier = self.method  # what found the goal
        self.blacklist = Blacklist(c.goals.blacklist_radius)
        self.looked = Blacklist(c.goals.blacklist_radius)   # checks looked at (``_looked_at``)
        self.goal: np.ndarray | None = None
        self.target: np.ndarray = np.zeros((0, 2))  # the frontier points the goal serves
        self.goals_chosen = 0
        self.closed = np.zeros((0, 2))              # points of paths the robot could not follow
        self._rng = np.random.default_rng(seed)

    def reached(self) -> None:
        """The robot arrived at the goal: the next ``plan`` chooses a new one."""
        self.goal = None

    def stuck(self, here: np.ndarray, path: np.ndarray) -> None:
        """The robot at ``here`` (2,) could not follow ``path`` (k, 2): the stretch of it from
        the robot's front edge (its radius ahead) to ``closed_stretch`` m ahead is closed to
        later paths, with the cells beside it, and the goal is blacklisted, but not its
        frontier, which another way may reach. The robot's own cell and those behind it stay
        open: it can back out."""
        rest = rest_of_path(np.asarray(here, float), np.asarray(path, float).reshape(-1, 2))
        step = np.linalg.norm(np.diff(rest, axis=0), axis=1)
        along = np.concatenate([[0.0], np.cumsum(step)])
        # every 5 cm: half a cell of the costmap grid
        at = np.arange(self.config.robot_radius, min(self.config.closed_stretch, along[-1]) + 1e-9, 0.05)
        stretch = np.column_stack([np.interp(at, along, rest[:, 0]), np.interp(at, along, rest[:, 1])])
        self.closed = np.vstack([self.closed, stretch])
        self.give_up()

    def give_up(self) -> None:
        """The current goal cannot be reached: blacklist it (and the frontier near it)."""
        if self.goal is not None:
            self.blacklist.add(self.goal)
        self.goal = None

    def plan(self, snapshot: MapSnapshot, pose: gtsam.Pose2) -> Plan:
        """A goal and a path for the robot at ``pose`` on this map snapshot: keep the goal while
        its frontier remains and its path is open, else choose the best frontier cluster.

        A goal is kept, or not, on the frontier that keeps it (``_keeping``) and a search that
        ends at the goal (``paths.distance_field`` ``until``), as the whole map would keep it:
        a kept goal's plan (most plans) then costs a fraction of a new choice on a big map."""
        costmap = self._passable(snapshot)
        frontier = None
        if self.goal is not None:
            cells, frontier = self._keeping(snapshot)
            reachable = self._reachable(snapshot, pose, costmap, until=self.goal)
            if self._goal_still_valid(cells, reachable):
                return Plan(self.goal, reachable.path(self.goal))
            self._looked_at(cells, reachable)
        reachable = self._reachable(snapshot, pose, costmap)
        frontier = self.method.frontier(snapshot) if frontier is None else frontier
        plan = self._choose(snapshot, frontier, reachable)
        if plan.done == "no_reachable_goal" and self._reopen(snapshot):
            plan = self._choose(snapshot, frontier, self._reachable(snapshot, pose, costmap))
        return plan

    def _looked_at(self, cells: np.ndarray, reachable: Reachable) -> None:
        """A goal of the stop's checks whose region closed (``_closed`` on the frontier
        ``cells`` that kept it) with the robot within its laser's range: the robot looked, and
        the checks are blacklisted there (``looked``). A region that opens there again later is
        the map's noise about a face already seen (a map relearnt at corrected poses, a costmap
        following a correction), not a way on: lab_a's GP run (seed 2) drove 30-33 m three
        times to a door check at the unseen end of a slanted face, each time closed as the
        robot came within 1-4 m of it, open again after a regeneration or a trip elsewhere.
        The method's own frontier there stays open: a check's visit may reveal a room behind
        a door, whose C-frontier lies within a blacklist radius of the check's goal (lab_a's
        GP seed 2: 4.7 m² left behind a 0.6 m door when this blacklist was the method's too)."""
        if (self.source is not self.method and self._closed(cells, reachable)
                and np.linalg.norm(self.goal - reachable.here) <= self.config.sensor_range):
            self.looked.add(self.goal)

    def _keeping(self, snapshot: MapSnapshot) -> tuple[np.ndarray, Frontier | None]:
        """The frontier cells (n, 2) that keep the current goal, and the method's whole
        frontier when they are its: a C-frontier goal's are F round its target alone
        (``CFrontier.cells_near``), a check's its regions near the target (``keeping``); the
        grid method's are the whole frontier, which a new choice then reads as well."""
        targets, reach = self._targets(), self.config.goals.reach
        if self.source is not self.method:
            return self.source.keeping(snapshot, targets, reach).cells, None
        if isinstance(self.method, CFrontier):
            return self.method.cells_near(snapshot, targets, reach), None
        frontier = self.method.frontier(snapshot)
        return frontier.cells, frontier

    def _reopen(self, snapshot: MapSnapshot) -> bool:
        """Reopen the closed stretches on the robot's trail (within two cells of it), when no
        frontier is reachable without them: the robot passed there, so a failure there was
        its driving's, not the passage's (a robot in a room whose door it failed to leave by
        was shut in). Those off the trail stay closed. True if any was reopened."""
        if not len(self.closed) or snapshot.trail is None or len(snapshot.trail) < 2:
            return False
        cells, through = driven(snapshot.trail, snapshot.resolution, snapshot.origin, snapshot.prob.shape)
        on = np.asarray(snapshot.origin, float) + snapshot.resolution * cells + through
        gap = cKDTree(on).query(self.closed)[0]
        keep = gap > 2 * snapshot.resolution
        if keep.all():
            return False
        self.closed = self.closed[keep]
        return True

    def _choose(self, snapshot: MapSnapshot, frontier: Frontier, reachable: Reachable) -> Plan:
        """The best reachable cluster's goal, or when the method has none, the nearest goal of
        the stop's checks (``checks``); a goal where the robot already stands is a frontier it
        cannot see from anywhere reachable (e.g. behind a wall gap narrower than the robot):
        blacklist it and choose again. The C-frontier's checks take, as well as doors, the
        grid's regions beside space the COM does not know (``MissedByF``)."""
        self.goal = None
        checked = None
        while True:
            source, clusters = self.method, self.method.clusters(frontier, reachable, self.blacklist, self._rng)
            best = next((k for k in clusters if k.goal is not None), None)
            if best is None:
                checked = [check.frontier(snapshot) for check in self.checks] if checked is None else checked
                found = [(k, check) for check, seen in zip(self.checks, checked)
                         for k in check.clusters(seen, reachable, self.blacklist.joined(self.looked), self._rng)
                         if k.goal is not None]
                if found:
                    best, source = max(found, key=lambda pair: pair[0].utility)
            if best is None and not clusters:
                return Plan(None, done="frontiers_exhausted", frontier=frontier.values)
            if best is None:
                return Plan(None, done="no_reachable_goal", clusters=clusters, frontier=frontier.values)
            self.goal, self.target, self.source = best.goal, best.points, source
            if np.linalg.norm(self.goal - reachable.here) > self.config.min_goal_distance:
                break
            self.give_up()
        self.goals_chosen += 1
        return Plan(self.goal, reachable.path(self.goal), new_goal=True, clusters=clusters,
                    frontier=frontier.values)

    def _passable(self, snapshot: MapSnapshot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``costmap.passable`` on the method's costmap: (ok, cost, offset)."""
        return passable(evidence(snapshot), snapshot.resolution, self.config.robot_radius,
                        self.method.costmap, snapshot.hits, np.asarray(snapshot.origin, float),
                        snapshot.trail)

    def _reachable(self, snapshot: MapSnapshot, pose: gtsam.Pose2,
                   costmap: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                   until: np.ndarray | None = None) -> Reachable:
        """Path lengths from the robot over the ``costmap`` (``_passable``'s, computed when not
        given) with the robot's footprint and without the closed stretches; with ``until``
        (2,) m, only as far as that point's cell (``distance_field``)."""
        c = self.config
        origin, resolution = np.asarray(snapshot.origin, float), snapshot.resolution
        here = np.array([pose.x(), pose.y()])
        start = np.round((here - origin) / resolution).astype(int)
        ok, cost, offset = self._passable(snapshot) if costmap is None else costmap
        h, w = ok.shape
        ok = (ok | self._footprint(snapshot, here, start)) & ~self._closed_cells(ok.shape, origin, resolution)
        goal = None if until is None else np.round((until - origin) / resolution).astype(int)
        inside = goal is not None and 0 <= goal[0] < w and 0 <= goal[1] < h
        dist, parent = distance_field(ok, np.clip(start, 0, [w - 1, h - 1]), resolution, cost,
                                      until=goal if inside else None)
        return Reachable(dist, parent, max(1, round(c.goals.reach / resolution)), origin, resolution,
                         here, offset)

    def _closed_cells(self, shape: tuple[int, int], origin: np.ndarray, resolution: float) -> np.ndarray:
        """(h, w) bool: the cells of the closed stretches (``stuck``) and the cells beside them."""
        closed = np.zeros(shape, dtype=bool)
        if not len(self.closed):
            return closed
        cells = np.round((self.closed - origin) / resolution).astype(int)
        inside = (cells[:, 0] >= 0) & (cells[:, 0] < shape[1]) & (cells[:, 1] >= 0) & (cells[:, 1] < shape[0])
        closed[cells[inside, 1], cells[inside, 0]] = True
        return ndimage.binary_dilation(closed, np.ones((3, 3), bool))

    def _footprint(self, snapshot: MapSnapshot, here: np.ndarray, start: np.ndarray) -> np.ndarray:
        """(h, w) bool: the cells within the robot's radius of its centre at ``here`` (cell
        ``start``) that are no nearer than it is to what the map shows occupied (the hits, or
        occupied cells): the robot stands on free ground even where its sensor has not looked
        (behind it), but a cell beside a door's jamb is not one its centre can move to."""
        c, resolution = self.config, snapshot.resolution
        origin = np.asarray(snapshot.origin, float)
        h, w = snapshot.prob.shape
        r = int(math.ceil(c.robot_radius / resolution))
        yy, xx = np.mgrid[start[1] - r:start[1] + r + 1, start[0] - r:start[0] + r + 1]
        inside = ((np.hypot(xx - start[0], yy - start[1]) * resolution <= c.robot_radius)
                  & (xx >= 0) & (xx < w) & (yy >= 0) & (yy < h))
        iy, ix = yy[inside], xx[inside]
        disc = np.zeros((h, w), dtype=bool)
        obstacles = snapshot.hits
        if obstacles is None:
            oy, ox = np.nonzero(evidence(snapshot) > self.method.costmap.occupied_above)
            obstacles = origin + resolution * np.column_stack([ox, oy])
        needed = c.robot_radius + self.method.costmap.margin
        reach = c.robot_radius + needed + resolution
        # a column at a time: the map's hits (770 000 of them late in office_g's run) are read
        # at every replan
        near = np.flatnonzero(np.abs(obstacles[:, 0] - here[0]) < reach)
        obstacles = obstacles[near[np.abs(obstacles[near, 1] - here[1]) < reach]]
        if len(obstacles):
            needed = min(needed, float(np.linalg.norm(obstacles - here, axis=1).min()))
            cells = origin + resolution * np.column_stack([ix, iy])
            clear = np.linalg.norm(cells[:, None] - obstacles[None], axis=2).min(axis=1) >= needed
            iy, ix = iy[clear], ix[clear]
        disc[iy, ix] = True
        return disc

    def _targets(self) -> np.ndarray:
        """(k, 2) m, the points a kept goal's frontier is looked for near: the goal and (up to
        32 of) the frontier points it serves."""
        targets = np.vstack([self.target, self.goal[None]])
        return targets[::max(1, len(targets) // 32)]

    def _goal_still_valid(self, cells: np.ndarray, reachable: Reachable) -> bool:
        """The goal is still reachable and frontier ``cells`` (n, 2) remain near its target."""
        return bool(np.isfinite(reachable.distance_to(self.goal)) and not self._closed(cells, reachable))

    def _closed(self, cells: np.ndarray, reachable: Reachable) -> bool:
        """Fewer than half the goal's frontier points (half ``min_points`` at most) remain near
        its target among frontier ``cells`` (n, 2)."""
        if len(cells) == 0:
            return True
        points = reachable.origin + reachable.resolution * cells
        near = np.min(np.linalg.norm(points[:, None, :] - self._targets()[None], axis=2), axis=1)
        need = max(1, min(self.config.goals.min_points, len(self.target)) // 2)
        return bool(np.count_nonzero(near < self.config.goals.reach) < need)
