"""The two ways of finding and ranking frontiers: the C-frontier map on the COM (the paper's,
eqs. 10-11) and Yamauchi's nearest grid frontier (the baseline).

Each method gives the explorer a ``Frontier`` for a map snapshot and, for a goal choice, its
frontier clusters ranked best first, each with the reachable goal cell that observes it.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
from collections import OrderedDict
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numba
import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from exploration.costmap import CostmapConfig, classify, distance_to_points
from exploration.frontier import FrontierMap, frontier_map_within
from exploration.gain import visible_unknown_area
from exploration.goals import Blacklist, FrontierCluster, extract_goals
from exploration.grid_frontier import grid_frontiers, region_size
from exploration.openings import (across_a_corner, hits_near, holding_hits, in_a_wall_gap,
                                  seen_through_a_gap)
from exploration.paths import Approach, best_cell_near, near_distance, nearest_reachable_cell, path_to
from mapping.metrics import KNOWN
from mapping.occupancy import MapSnapshot

if TYPE_CHECKING:
    from exploration.explorer import ExplorerConfig

#: Points of a cluster whose goal shows too little from which the C-frontier method looks again
VIEWS = 8


@dataclass(frozen=True)
class Reachable:
    """Where the robot can go on one snapshot: path length ``dist`` (h, w) in meters from the
    robot (inf where unreachable) with its Dijkstra ``parent``; ``reach``, cells from a
    frontier cell to its goal; the snapshot's ``origin`` and ``resolution``; the robot's
    position ``here`` (2,); and ``offset`` (h, w, 2), meters from each cell's centre to the
    point a path through it passes (``costmap.passable``'s)."""

    dist: np.ndarray
    parent: np.ndarray
    reach: int
    origin: np.ndarray
    resolution: float
    here: np.ndarray
    offset: np.ndarray

    def cell(self, xy: np.ndarray) -> np.ndarray:
        """The (ix, iy) cell of a point (meters)."""
        return np.round((np.asarray(xy) - self.origin) / self.resolution).astype(int)

    def near(self, cells: np.ndarray) -> np.ndarray:
        """(k,) the path length to the best reachable cell within ``reach`` cells of each of
        ``cells`` (k, 2) (ix, iy) (``paths.near_distance``)."""
        return near_distance(self.dist, self.reach, cells)

    def distance_to(self, xy: np.ndarray) -> float:
        """Path length (m) to the cell of ``xy``; inf when unreachable or off the map."""
        ix, iy = self.cell(xy)
        h, w = self.dist.shape
        return float(self.dist[iy, ix]) if 0 <= ix < w and 0 <= iy < h else math.inf

    def path(self, goal: np.ndarray) -> np.ndarray:
        """(k, 2) the cheapest path from the robot to the cell of ``goal``, meters, through
        each cell's clear point."""
        cells = path_to(self.parent, self.cell(goal))
        path = self.origin + self.resolution * cells + self.offset[cells[:, 1], cells[:, 0]]
        path[0] = self.here
        return path


@dataclass(frozen=True)
class Frontier:
    """A snapshot's frontier: ``values`` (h, w) the frontier map (F, or 1 on grid frontier
    cells), ``cells`` (n, 2) its significant cells (ix, iy), for the grid method its
    ``regions`` (a list of (m, 2) cell arrays), and the map ``evidence`` (h, w) the
    significance test looks round on (``look_map``); ``blocked`` (h, w) bool, the cells the
    laser cannot see through; for the door check, ``seen`` (h, w) the snapshot's evidence
    itself, closed within the robot's radius of a hit as ``evidence`` is; ``hits`` (k, 2) the
    snapshot's laser endpoints (m); ``clearance`` (h, w), meters from each cell to the nearest
    wall were all unknown space free (``within_reach``), by which looks then count unknown space
    (``look``)."""

    values: np.ndarray
    cells: np.ndarray
    regions: tuple[np.ndarray, ...] = ()
    evidence: np.ndarray | None = None
    blocked: np.ndarray | None = None
    seen: np.ndarray | None = None
    hits: np.ndarray | None = None
    clearance: np.ndarray | None = None


class CFrontier:
    """The paper's method: the C-frontier map F (eq. 10) thresholded, clustered with k-means and
    ranked by the utility of eq. 11; a cluster is significant when a look round from its goal,
    or from a goal by another of its points, would show ``min_gain`` m² of unknown space, and
    no frontier is left when the significant clusters hold fewer than ``goals.min_points``
    points (remnant texture no look finds worth a trip does not count towards them)."""

    def __init__(self, config: ExplorerConfig):
        self.config = config
        self.costmap: CostmapConfig = config.costmap
        self._frontier_map = FrontierMap(config.beta, config.smoothing)

    def frontier(self, snapshot: MapSnapshot) -> Frontier:
        c = self.config
        values = self._frontier_map(snapshot.prob, snapshot.prob_occ, snapshot.resolution, snapshot.origin)
        iy, ix = np.nonzero(values > c.goals.threshold)
        return Frontier(values, np.column_stack([ix, iy]),
                        evidence=look_map(snapshot, self.costmap, c.robot_radius),
                        blocked=evidence(snapshot) > self.costmap.occupied_above, hits=snapshot.hits)

    def cells_near(self, snapshot: MapSnapshot, points: np.ndarray, reach: float) -> np.ndarray:
        """(n, 2) the cells (ix, iy) where F is above the threshold, in the box round ``points``
        (k, 2), meters, widened by ``reach`` m and a cell: F computed there alone
        (``frontier_map_within``), equal to the whole map's."""
        c, resolution = self.config, snapshot.resolution
        h, w = snapshot.prob.shape
        at = (np.asarray(points, float) - np.asarray(snapshot.origin, float)) / resolution
        pad = reach / resolution + 1
        x0, y0 = np.maximum(np.floor(at.min(axis=0) - pad).astype(int), 0)
        x1, y1 = np.minimum(np.ceil(at.max(axis=0) + pad).astype(int) + 1, [w, h])
        if x0 >= x1 or y0 >= y1:
            return np.zeros((0, 2), int)
        values = frontier_map_within(snapshot.prob, snapshot.prob_occ, resolution, (y0, y1), (x0, x1),
                                     c.beta, c.smoothing)
        iy, ix = np.nonzero(values > c.goals.threshold)
        return np.column_stack([ix + x0, iy + y0])

    def clusters(self, frontier: Frontier, reachable: Reachable, blacklist: Blacklist,
                 rng: np.random.Generator) -> list[FrontierCluster]:
        c = self.config
        approach = Approach(reachable.dist, frontier.blocked, reachable.resolution, c.goals.view,
                            c.goals.reach)
        clusters = extract_goals(frontier.values, reachable.origin, reachable.resolution,
                                 reachable.dist, c.goals, blacklist, seed=int(rng.integers(2**31)),
                                 approach=approach)
        reached = within_reach(frontier, reachable, c.robot_radius, self.costmap)
        kept = [k for k in (significant(k, frontier, reached, reachable, approach, c, self.costmap)
                            for k in clusters) if k is not None]
        if sum(len(k.points) for k in kept) < c.goals.min_points:
            return []
        return sorted(kept, key=lambda k: -k.utility)


class GridFrontier:
    """The baseline: frontier regions of the log-odds grid (free cells beside unknown ones, at
    least ``min_frontier_cells``), the nearest by path first, each significant as the
    C-frontier method's clusters are (``significant``), on the grid with its unknown cells
    within the robot's radius of a hit occupied (``look_map``). A region's goal sees the cell
    it serves (``best_cell_near`` with ``blocked``).

    Yamauchi's stop alone waits for every region of ``min_frontier_cells`` to go, and in
    clutter some never do: lab_e's grid run reached 99 % at 518 m and drove on to the step
    budget (874 m), 11-58 m a trip to regions of 10-35 cells in slots between furniture
    narrower than the robot and beside gaps of the outer wall, whose looks from their goals
    showed 0.0-0.4 m² (it now stops at 423 m). On the grid alone a look passes through the
    gaps a wall's hits leave and counts the space beyond the building (5-13 m² beside lab_e's
    outer walls)."""

    def __init__(self, config: ExplorerConfig, costmap: CostmapConfig | None = None):
        self.config = config
        self.costmap: CostmapConfig = config.grid_costmap if costmap is None else costmap

    def min_cells(self, resolution: float) -> int:
        """The smallest frontier region kept, cells."""
        return self.config.min_frontier_cells

    def frontier(self, snapshot: MapSnapshot, near: tuple[np.ndarray, float] | None = None) -> Frontier:
        """The frontier; with ``near`` (points (k, 2) m, reach m), only its regions with a cell
        closer than reach to one of the points (a kept goal's, ``keeping``)."""
        regions = grid_frontiers(evidence(snapshot), self.costmap, self.min_cells(snapshot.resolution),
                                 self.surfaces(snapshot))
        if near is not None:
            points, reach = near
            tree = cKDTree(points)              # one tree of the goal's points for every region
            regions = [r for r in regions if _reaches(snapshot, r, tree, reach)]
        cells = np.vstack(regions) if regions else np.zeros((0, 2), int)
        values = np.zeros(snapshot.prob.shape)
        values[cells[:, 1], cells[:, 0]] = 1.0
        return Frontier(values, cells, tuple(regions),
                        evidence=look_map(snapshot, self.costmap, self.config.robot_radius),
                        blocked=evidence(snapshot) > self.costmap.occupied_above, hits=snapshot.hits)

    def surfaces(self, snapshot: MapSnapshot) -> np.ndarray | None:
        """(h, w) bool, cells that are no frontier whatever the grid reads there; None: none."""
        return None

    def keeping(self, snapshot: MapSnapshot, near: np.ndarray, reach: float) -> Frontier:
        """The frontier a goal this found is kept by (``Explorer._goal_still_valid``, which
        counts its cells closer than ``reach`` m to ``near`` (k, 2) m): its regions with such a
        cell, the others not checked (on office_g the stop's checks of every region at each
        replan took a twentieth of a GP run's time)."""
        return self.frontier(snapshot, (near, reach))

    def clusters(self, frontier: Frontier, reachable: Reachable, blacklist: Blacklist,
                 rng: np.random.Generator) -> list[FrontierCluster]:
        """The significant regions (``regions``), the nearest by path first."""
        goals = self.config.goals
        approach = Approach(reachable.dist, frontier.blocked, reachable.resolution, goals.view, goals.reach)
        reached = within_reach(frontier, reachable, self.config.robot_radius, self.costmap)
        kept = (significant(k, frontier, reached, reachable, approach, self.config, self.costmap)
                for k in self.regions(frontier, reachable, blacklist))
        return sorted((dataclasses.replace(k, utility=-k.distance) for k in kept if k is not None),
                      key=lambda k: -k.utility)

    def regions(self, frontier: Frontier, reachable: Reachable, blacklist: Blacklist) -> list[FrontierCluster]:
        """Each region left once blacklisted cells are removed is a cluster; its utility is minus
        the path length to it (Yamauchi's nearest frontier)."""
        origin, resolution = reachable.origin, reachable.resolution
        goals = self.config.goals
        approach = Approach(reachable.dist, frontier.blocked, resolution, goals.view, goals.reach)
        clusters = []
        for region in frontier.regions:
            region = region[~blacklist.covers(origin + resolution * region)]
            if region_size(region) < self.min_cells(resolution):
                continue
            d = reachable.near(region)
            best = int(np.argmin(d))
            distance = float(d[best])
            if np.isfinite(distance):
                cell = best_cell_near(reachable.dist, region[best], reachable.reach, frontier.blocked)
                distance = float(reachable.dist[cell[1], cell[0]])
            else:
                cell = approach.goal(region)
                distance = math.inf if cell is None else float(reachable.dist[cell[1], cell[0]])
            goal = None if cell is None else origin + resolution * cell
            points = origin + resolution * region
            clusters.append(FrontierCluster(points, points.mean(axis=0), 1.0, distance, goal, -distance))
        clusters.sort(key=lambda k: -k.utility)
        return clusters


class MissedByF(GridFrontier):
    """The C-frontier's stop check for frontiers F misses: the grid method's significant
    regions at least a door's longest width long (shorter ones are the door check's), kept
    where the COM does not read the space beside them free either (most of the unknown cells
    next to a region read Λ ≥ 0.5 − ``KNOWN``: unknown, or occupied), or where the region is
    the edge of a wedge of beams seen through a gap (``_seen_through``).

    F is low along a frontier that runs beside a wall, where ‖∇Λo‖ and Λo weigh against it:
    lab_e's GP run looked down a room's 0.3 m wide strip of floor along its wall (Λ 0.35-0.45,
    Λo 0.53-0.7), F stayed below 0.5 over its 2.4 m, and the run stopped with the room unseen;
    the grid's region there showed 9 m², and Λ beside it averaged 0.46. On a block's unseen
    face the costmap grid is unknown too, but the free GP, leaking through the block's other
    faces, reads it free (Λ 0.13-0.20 beside the Stage cave's faces, whose looks showed the
    blocks' insides, 3.4 m²): without the COM's word, every Stage cave run drove 20 m on to
    them. Λ reading occupied there is no such word: the obstacle GP joins a door's jambs
    across it (``DoorFrontier``). lab_a's GP run (seed 2) saw a 4.6 m² room through a 0.55 m
    door at its corner as a wedge of beams; of the unknown cells beside the wedge's 16-cell
    region, 12 were unknown on Λ, 13 free (the free GP leaking past the wedge) and 3 occupied
    (the jambs joined), and the run stopped with the room unseen. Past a door, the free GP
    leaks beside the wedge of beams seen through it as it does round a block: lab_e's GP runs
    (seeds 1 and 2) saw a 2 m² alcove through a 0.55 m door at its corner, 19 of the 20
    unknown cells beside the wedge's region read free, and both runs stopped with it unseen.
    What the hits say tells the two apart: beams passed between two jambs to the wedge, and
    none passes through a block's face. A look from such a region's goal sees through its door
    (``opened_near``, as the door check's): office_d's GP run saw a 30 m² room through a 0.85 m
    door edge-on, the obstacle GP joined the door's jambs on the look map, every look from the
    corridor showed 0 m² (26-40 m² on the evidence), and the run stopped with the room unseen."""

    def min_cells(self, resolution: float) -> int:
        """A door's longest width (``door_width``), cells: shorter regions are the door check's."""
        return door_cells(self.config, resolution)

    def frontier(self, snapshot: MapSnapshot, near: tuple[np.ndarray, float] | None = None) -> Frontier:
        found = super().frontier(snapshot, near)
        unknown = np.abs(evidence(snapshot) - 0.5) <= KNOWN
        not_free_on_com = snapshot.prob >= 0.5 - KNOWN
        through = self._seen_through(snapshot)
        h, w = unknown.shape
        steps = np.array([(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy])
        regions, looked, seen = [], found.evidence, None
        for region in found.regions:
            near = np.unique((region[:, None, :] + steps).reshape(-1, 2), axis=0)
            ix, iy = np.clip(near[:, 0], 0, w - 1), np.clip(near[:, 1], 0, h - 1)
            beside = unknown[iy, ix]
            if not beside.any():
                continue
            if not_free_on_com[iy, ix][beside].mean() > 0.5:
                regions.append(region)
            elif through(region):
                regions.append(region)
                seen = seen_map(snapshot, found.evidence, self.config.robot_radius) if seen is None else seen
                looked = opened_near(looked, seen, region, door_cells(self.config, snapshot.resolution))
        cells = np.vstack(regions) if regions else np.zeros((0, 2), int)
        return dataclasses.replace(found, cells=cells, regions=tuple(regions), evidence=looked)

    def _seen_through(self, snapshot: MapSnapshot) -> Callable[[np.ndarray], bool]:
        """Is a region (k, 2) of cells the edge of a wedge of beams seen through a gap
        (``seen_through_a_gap``, a door's longest width at most)? Beams crossed the gap into
        the space past it, so that space is no block's inside, whatever encloses it: held-out
        building_0014's GP run saw a 6.1 m² room, whose every wall it had seen from outside,
        through its 0.85 m door as such a wedge, and stopped with it unseen while this asked
        for unknown space reaching the map's edge. What it reads (the grid's free cells) is
        built at the first region asked about: a goal this check gave is kept on its regions
        at every replan, and most of them pass on the COM's word. The hits it reads are those
        within a door's width of the region's box, in a tree of their own (``hits_near``): a
        tree of all office_g's 770 000 hits took 7 % of its GP run's time."""
        origin, resolution = np.asarray(snapshot.origin, float), snapshot.resolution
        if snapshot.hits is None or not len(snapshot.hits):
            return lambda region: False
        door = self.config.door_width

        @functools.cache
        def read() -> np.ndarray:
            return classify(evidence(snapshot), self.costmap)[0]

        def through(region: np.ndarray) -> bool:
            points = origin + resolution * region
            return seen_through_a_gap(points, cKDTree(hits_near(snapshot.hits, points, door)), door,
                                      self.config.robot_radius, math.sqrt(2) * resolution,
                                      lambda centre, radius: cells_within(read(), origin, resolution,
                                                                          centre, radius, joined=region))

        return through


class DoorFrontier(GridFrontier):
    """The stop's check, for both methods, once theirs finds no reachable frontier: frontier
    regions of the evidence grid from the robot's diameter (the narrowest way on it can take)
    that the laser's endpoints read as an opening (``exploration.openings``), of any length,
    or without endpoints as long as a door at most (``door_width``, 1 m; its length by
    ``region_size``), reachable, whose look from their goal shows ``min_gain`` of the unknown
    space behind them (``through_door``), the nearest by path first.

    A door passed at right angles is seen through a few beams at the edge of the laser's field
    of view: it leaves a frontier as long as the door is wide, shorter than the C-frontier's
    clusters count and ``MissedByF``'s regions (a door's longest width), and below F's
    threshold where the COM smooths the gap shut. office_f's four end rooms (65 m²) were left
    so by both methods (the grid method's smallest region was then 1 m). Before the endpoints
    were read, longer regions were left to the methods: checking every gap a grazed wall
    leaves in its hits drove the Stage cave's runs farther for nothing (GP 62 -> 83 m). Read
    by them, a door's region may be longer than the door: beams through held-out
    building_0027's 0.9 m door, seen edge-on, freed cells on past its far jamb beside the
    0.45 m of wall to the corridor's corner, a region of 13 cells, and its GP run left the
    10 m² room behind it (95.3 %).

    The unknown space behind a region may be enclosed by seen walls: a room whose every wall
    was seen from outside is enclosed as a block's inside is, and nothing the robot has seen
    tells the two apart. Taking such space for a block left rooms behind 0.80-0.85 m doors on
    held-out buildings (building_0014: 13.8 m² and 17.2 m²); with the rule gone, the Stage
    cave's GP runs drive as far as before (seeds 0-2 to the metre).

    A door is an opening: no cell of its region holds a laser endpoint (``surfaces``). A wall
    grazed from along it is marked free where the beams that ran along it before ending
    farther on crossed its cells, beside the unknown space behind it, so its frontier runs on
    its own line, through cells where other beams ended: office_d's grazed walls left such
    regions, door-long, beside a door seen edge-on whose cells held none.

    The look sees through ``look_map``, but not where the obstacle GP joins a door's jambs (Λo
    high in the unknown cells behind it, within a door's longest width of the region, farther
    than the robot's radius from every hit): it would see nothing past the door (office_d's
    28 m² room behind a 1 m door showed 0.02 m²). Λo still closes what lies within the robot's
    radius of a hit, as the inside of a thick wall between its two faces (office_b: the inside
    of a 0.3 m wall, grazed along one face, opened onto the space beyond the building at its
    junction with another), and the unseen faces of blocks farther on."""

    def min_cells(self, resolution: float) -> int:
        return max(1, math.floor(2 * self.config.robot_radius / resolution + 1e-9))

    def frontier(self, snapshot: MapSnapshot, near: tuple[np.ndarray, float] | None = None) -> Frontier:
        """The regions that read as openings; with ``near``, those near a kept goal
        (``keeping``): a door's region lengthens as the robot nears it and sees past
        (office_d: a 28 m² room was left when its door's region grew from 8 cells as the robot
        came into the doorway)."""
        found = super().frontier(snapshot, near)
        with_hits = snapshot.hits is not None and len(snapshot.hits) > 0
        longest = door_cells(self.config, snapshot.resolution) + 1
        regions = tuple(r for r in found.regions if near is not None or with_hits or region_size(r) <= longest)
        if with_hits and regions:
            free = classify(evidence(snapshot), self.costmap)[0]
            origin, resolution = np.asarray(snapshot.origin, float), snapshot.resolution
            reach, tolerance = 2 * self.config.robot_radius, math.sqrt(2) * resolution

            def in_a_gap(region: np.ndarray) -> bool:
                points = origin + resolution * region
                hits = cKDTree(hits_near(snapshot.hits, points, 2 * reach))
                return (in_a_wall_gap(points, hits, reach, tolerance, self.config.robot_radius)
                        or across_a_corner(points, hits, reach, self.config.robot_radius,
                                           lambda centre, radius: cells_within(free, origin, resolution,
                                                                               centre, radius, joined=region)))

            regions = tuple(r for r in regions if in_a_gap(r))
        cells = np.vstack(regions) if regions else np.zeros((0, 2), int)
        looked = look_map(snapshot, self.costmap, self.config.robot_radius)
        return dataclasses.replace(found, cells=cells, regions=regions, evidence=looked,
                                   seen=seen_map(snapshot, looked, self.config.robot_radius))

    def surfaces(self, snapshot: MapSnapshot) -> np.ndarray | None:
        """(h, w) bool, the cells holding a hit (a beam ended there: a surface); None without
        hits."""
        if snapshot.hits is None:
            return None
        return holding_hits(snapshot.hits, snapshot.origin, snapshot.resolution, snapshot.prob.shape)

    def clusters(self, frontier: Frontier, reachable: Reachable, blacklist: Blacklist,
                 rng: np.random.Generator) -> list[FrontierCluster]:
        """Each region served from the reachable cell nearest in a straight line to one of
        ``VIEWS`` of its points whose look shows ``min_gain`` (the nearest of those by path):
        a door through a thick wall is a tunnel, seen through from within it, not from the
        corridor beside it, where the path to the region is shortest."""
        frontier = within_reach(frontier, reachable, self.config.robot_radius, self.costmap)
        clusters = []
        door = door_cells(self.config, reachable.resolution)
        reach = math.ceil(2 * self.config.sensor_range / reachable.resolution)
        for k in self.regions(frontier, reachable, blacklist):
            through = dataclasses.replace(frontier, evidence=through_door(
                frontier.evidence, frontier.seen, reachable.cell(k.points), door, reach))

            def shows(goal: np.ndarray) -> bool:
                return look(through, reachable, goal, self.config, self.costmap) >= self.config.min_gain

            view = nearest_view(k.points, k.centroid, reachable, nearest_reachable_cell, shows)
            if view is not None:
                clusters.append(dataclasses.replace(k, goal=view[1], distance=view[0], utility=-view[0]))
        return sorted(clusters, key=lambda k: -k.utility)


def cells_within(mask: np.ndarray, origin: np.ndarray, resolution: float, centre: np.ndarray,
                 radius: float, joined: np.ndarray | None = None) -> np.ndarray:
    """(m, 2) meters, the centres of the (h, w) ``mask``'s cells (cell (0, 0)'s at ``origin``)
    within ``radius`` m of ``centre`` (2,); with ``joined`` (k, 2) cells (ix, iy), only those
    joined to one of them through the mask's cells within ``radius`` (4-connected). The free
    space a region's beams came through is joined to the region; the free space on the far
    side of a wall is not (building_0008's GP run saw a room through a 0.85 m door at its
    corner, down the wall beside it: the corridor behind the room's other wall, within a
    metre, outweighed the wedge seen through the door and put the door's side wrong)."""
    low = np.maximum(np.floor((centre - radius - origin) / resolution).astype(int), 0)
    high = np.maximum(np.ceil((centre + radius - origin) / resolution).astype(int) + 1, 0)
    window = mask[low[1]:high[1], low[0]:high[0]]
    yy, xx = np.mgrid[0:window.shape[0], 0:window.shape[1]]
    cells = origin + resolution * (np.stack([xx, yy], axis=-1) + low)
    inside = window & (np.linalg.norm(cells - centre, axis=-1) <= radius)
    if joined is not None:
        labels, _ = ndimage.label(inside)
        j = np.asarray(joined, int) - low
        on = (j[:, 0] >= 0) & (j[:, 0] < window.shape[1]) & (j[:, 1] >= 0) & (j[:, 1] < window.shape[0])
        seeds = labels[j[on, 1], j[on, 0]]
        inside &= np.isin(labels, seeds[seeds > 0])
    return cells[inside]


def opened_near(looked: np.ndarray, seen: np.ndarray, cells: np.ndarray, span: int) -> np.ndarray:
    """(h, w) the look map ``looked`` with the evidence itself (``seen``) within ``span`` cells
    of ``cells`` (k, 2) (ix, iy), a door's region's: where Λo joins the door's jambs across it,
    and a look through the door would see nothing past it."""
    h, w = seen.shape
    x0, y0 = np.maximum(cells.min(axis=0) - span, 0)
    x1, y1 = np.minimum(cells.max(axis=0) + span + 1, [w, h])
    window = np.ones((y1 - y0, x1 - x0), dtype=bool)
    window[cells[:, 1] - y0, cells[:, 0] - x0] = False
    near = ndimage.distance_transform_edt(window) <= span
    opened = looked.copy()
    opened[y0:y1, x0:x1][near] = seen[y0:y1, x0:x1][near]
    return opened


def through_door(looked: np.ndarray, seen: np.ndarray, cells: np.ndarray, span: int,
                 reach: int) -> np.ndarray:
    """(h, w) the look map ``looked`` opened near a door's region (``opened_near``, its
    ``cells`` (k, 2) (ix, iy), ``span`` cells), with the unknown space it does not open onto
    read occupied within ``reach`` cells of it (a look from near the region reads no farther):
    the space the door leads to, unknown cells joined (8-connected, within that window) to one
    beside the region, is what a look through it can show. A region beside a speck of unknown
    between speckled hits opens onto nothing, though a look from its goal may see 1 m² of
    unknown elsewhere: lab_e's GP run drove 50 m after its last gain to such regions once the
    door check looked into unknown space enclosed by seen walls (``DoorFrontier``)."""
    opened = opened_near(looked, seen, cells, span)
    h, w = opened.shape
    x0, y0 = np.maximum(cells.min(axis=0) - reach, 0)
    x1, y1 = np.minimum(cells.max(axis=0) + reach + 1, [w, h])
    window = opened[y0:y1, x0:x1]
    unknown = np.abs(window - 0.5) <= KNOWN
    labels, _ = ndimage.label(unknown, structure=np.ones((3, 3), dtype=bool))
    region = np.zeros(unknown.shape, dtype=bool)
    region[cells[:, 1] - y0, cells[:, 0] - x0] = True
    beside = ndimage.binary_dilation(region, structure=np.ones((3, 3), dtype=bool)) & unknown
    window[unknown & ~np.isin(labels, labels[beside])] = 1.0
    return opened


def door_cells(config: ExplorerConfig, resolution: float) -> int:
    """A door's longest width (``door_width``), cells."""
    return max(1, round(config.door_width / resolution))


def seen_map(snapshot: MapSnapshot, looked: np.ndarray, radius: float) -> np.ndarray:
    """(h, w) the snapshot's evidence, closed as the look map ``looked`` closes it within
    ``radius`` m of a hit (the inside of a thick wall between its two faces) and nowhere
    else."""
    seen = evidence(snapshot)
    if snapshot.hits is None:
        return seen
    near = np.isfinite(distance_to_points(snapshot.hits, snapshot.origin, snapshot.resolution, seen.shape, radius))
    return np.where(near, looked, seen)


def significant(cluster: FrontierCluster, frontier: Frontier, reached: Frontier, reachable: Reachable,
                approach: Approach, config: ExplorerConfig, costmap: CostmapConfig) -> FrontierCluster | None:
    """The cluster when a look round from its goal on ``reached`` (``frontier`` with its
    ``clearance``: ``within_reach``) shows ``config.min_gain``, or with no goal, a look from its
    centroid on ``frontier`` (it is then a frontier out of reach, which ends a run as such,
    whatever lies behind it); else, served from the nearest goal by another
    of its points that does (k-means can join a remnant beside the robot with a corridor's end
    across the building: the goal by the nearest point sees only the remnant), tried at
    ``VIEWS`` points spread over the cluster, each from the best reachable cell within reach of
    it or, with none, from where ``approach`` would look at it (office_b: a room seen as a
    streak of beams through its door, its frontier out of reach from the corridor, shared a
    cluster with remnants 13 m away, and the run stopped with the room unexplored); else None.
    Each of those cells sees its point past ``frontier.blocked`` (``best_cell_near``)."""

    def gain(at: np.ndarray) -> float:
        return look(reached, reachable, at, config, costmap)

    def cell_near(dist: np.ndarray, cell: np.ndarray, reach: int) -> np.ndarray | None:
        best = best_cell_near(dist, cell, reach, frontier.blocked)
        return best if np.isfinite(dist[best[1], best[0]]) else approach.goal(np.asarray(cell)[None])

    if cluster.goal is None:
        shown = look(frontier, reachable, cluster.centroid, config, costmap)
        return cluster if shown >= config.min_gain else None
    if gain(cluster.goal) >= config.min_gain:
        return cluster
    view = nearest_view(cluster.points, cluster.goal, reachable, cell_near,
                        lambda goal: gain(goal) >= config.min_gain)
    return None if view is None else cluster.served_from(view[1], view[0])


def within_reach(frontier: Frontier, reachable: Reachable, radius: float, costmap: CostmapConfig) -> Frontier:
    """``frontier`` with its ``clearance``: meters from each cell's centre to the nearest hit
    (without hits, to the nearest occupied cell's edge), all unknown space taken free (off the
    map too), to ``radius`` + the costmap's margin and infinite beyond; 0 on occupied cells."""
    resolution, shape = reachable.resolution, frontier.blocked.shape
    if frontier.hits is not None and len(frontier.hits):
        clearance = distance_to_points(frontier.hits, reachable.origin, resolution, shape,
                                       radius + costmap.margin)
    else:
        clearance = ndimage.distance_transform_edt(~frontier.blocked) * resolution - resolution / 2
    return dataclasses.replace(frontier, clearance=np.where(frontier.blocked, 0.0, clearance))


def look_map(snapshot: MapSnapshot, costmap: CostmapConfig, radius: float) -> np.ndarray:
    """(h, w) the map a look round (``look``) sees through: the evidence grid, and occupied at
    its unknown cells where the obstacle GP predicts an obstacle (Λo), as at the unseen face
    of a block whose other faces were seen: behind such a face lies the block's inside, not
    space to explore. Cells a beam crossed keep the evidence (Λo smooths over doors a beam
    has passed). A grid has no Λo: its unknown cells within ``radius`` m (the robot's) of a hit
    are occupied instead, a face running on past its hits over the gaps a laser leaves in it
    at grazing angles, narrower than the robot, where a door's middle stays open (lab_c's grid
    run drove 40 m to gaps between sparse hits on the faces of thick walls, whose looks showed
    1.2-5.8 m² of the walls' insides and the outside, and 0.01-0.14 m² so closed)."""
    seen = evidence(snapshot)
    if snapshot.prob_occ is not None:
        return np.where((snapshot.prob_occ > costmap.occupied_above) & (np.abs(seen - 0.5) <= KNOWN),
                        1.0, seen)
    if snapshot.hits is None or not len(snapshot.hits):
        return seen
    near = np.isfinite(distance_to_points(snapshot.hits, snapshot.origin, snapshot.resolution, seen.shape,
                                          radius))
    return np.where(near & (np.abs(seen - 0.5) <= KNOWN), 1.0, seen)


def look(frontier: Frontier, reachable: Reachable, at: np.ndarray, config: ExplorerConfig,
         costmap: CostmapConfig) -> float:
    """m² of unknown space a look round from ``at`` (2,) would show on ``frontier.evidence``,
    out to the laser's range; with the frontier's ``clearance`` (``within_reach``), only of the
    unknown space the robot could drive into from ``at`` within that range were it free
    (``reachable_unknown``): the rest is looked through, not counted. A look that reads what a
    recent one read gives its answer (``_Looks``)."""
    return _LOOKS.area(frontier, reachable, at, config, costmap)


def _look(frontier: Frontier, reachable: Reachable, at: np.ndarray, config: ExplorerConfig,
          costmap: CostmapConfig) -> float:
    """``look``, computed."""
    evidence, origin = frontier.evidence, reachable.origin
    if frontier.clearance is not None:
        evidence, origin = reachable_unknown(frontier, reachable, at, config, costmap)
    return visible_unknown_area(evidence, origin, reachable.resolution, at, config.sensor_range,
                                costmap.occupied_above)


class _Looks:
    """The answers of recent looks, by what each read. A look reads, within the laser's range
    of where it stands, which cells of the evidence are unknown and which occupied and, with a
    clearance, which cells are farther than a passage's half width and than the robot's radius
    from the walls: four bits a cell. Two looks from the same point on the same grid whose
    windows hold the same bits give the same answer, so each answer is kept under those bits
    (their SHA-1 digest: reading the bits costs a tenth of a look). Between two goal choices
    the map changes round the robot, and most clusters, far from it, are looked at from the
    same cells again: on office_g's GP run (seed 1), 72 % of the looks were repeats, and looks
    took a tenth of its time (18 s of its first 12 000 scans; 10 s with this cache, 5 of them
    reading the bits with numpy, since compiled)."""

    def __init__(self, size: int = 8192):
        self.size = size
        self.answers: OrderedDict[tuple, float] = OrderedDict()

    def area(self, frontier: Frontier, reachable: Reachable, at: np.ndarray, config: ExplorerConfig,
             costmap: CostmapConfig) -> float:
        key = self._key(frontier, reachable, np.asarray(at, float), config, costmap)
        if key in self.answers:
            self.answers.move_to_end(key)
            return self.answers[key]
        answer = _look(frontier, reachable, at, config, costmap)
        self.answers[key] = answer
        if len(self.answers) > self.size:
            self.answers.popitem(last=False)
        return answer

    @staticmethod
    def _key(frontier: Frontier, reachable: Reachable, at: np.ndarray, config: ExplorerConfig,
             costmap: CostmapConfig) -> tuple:
        resolution = reachable.resolution
        h, w = frontier.evidence.shape
        half = int(math.ceil(config.sensor_range / resolution)) + 1
        cx, cy = reachable.cell(at)
        passage = _passage(config, costmap, resolution)
        clearance = frontier.clearance
        bits = _bits(frontier.evidence, np.zeros((0, 0)) if clearance is None else clearance,
                     max(cy - half, 0), max(min(cy + half + 1, h), 0), max(cx - half, 0),
                     max(min(cx + half + 1, w), 0), KNOWN, costmap.occupied_above, passage,
                     config.robot_radius, clearance is not None)
        digest = hashlib.sha1(bits.tobytes()).digest()
        return (float(at[0]), float(at[1]), *map(float, reachable.origin), float(resolution), h, w,
                frontier.clearance is not None, config.sensor_range, config.robot_radius, passage,
                costmap.occupied_above, digest)


_LOOKS = _Looks()


@numba.njit(cache=True)
def _bits(evidence, clearance, y0, y1, x0, x1, known, occupied_above, passage, radius, with_clearance):
    """(y1 - y0, x1 - x0) uint8, what a look reads of each cell of that window (``_Looks``):
    1 unknown, 2 occupied, and with the clearance, 4 farther than ``passage``, 8 than
    ``radius``; compared in double precision, as the look compares."""
    bits = np.zeros((max(y1 - y0, 0), max(x1 - x0, 0)), np.uint8)
    for iy in range(y0, y1):
        for ix in range(x0, x1):
            value = np.float64(evidence[iy, ix])
            cell = np.uint8(1) if abs(value - 0.5) <= known else np.uint8(0)
            if value > occupied_above:
                cell |= np.uint8(2)
            if with_clearance:
                if clearance[iy, ix] > passage:
                    cell |= np.uint8(4)
                if clearance[iy, ix] > radius:
                    cell |= np.uint8(8)
            bits[iy - y0, ix - x0] = cell
    return bits


def reachable_unknown(frontier: Frontier, reachable: Reachable, at: np.ndarray, config: ExplorerConfig,
                      costmap: CostmapConfig) -> tuple[np.ndarray, np.ndarray]:
    """(the window of ``frontier.evidence`` within the laser's range of ``at`` (2,), off the map
    unknown, its cell (0, 0)'s centre), its unknown cells marked free (seen through, not
    counted) but for those the robot could drive into from ``at`` were the unknown free, with
    its centre there: farther than its radius from the walls (``frontier.clearance``, off the
    map free), in the regions that join the cells round ``at`` of the cells a passage runs
    through. A passage is as wide as the costmap plans a door (the robot's radius and margin
    each side, less the squeeze): a cell of it along the grid's axes has a centre that clear,
    less half a cell; a 0.3 m gap has none (the costmap's own search for each cell's clearest
    point took 0.8 s on office_g's late map, at every new goal choice).

    Not counted so: the band along a wall within the robot's radius of it (no core coverage
    lies there), and the inside of a wall or block, or the outside of the building, behind a
    gap narrower than the robot (the unseen corner of a junction of two walls, a gap between a
    wall's hits): a room behind such a gap is reached by its own door, which has a frontier of
    its own. The regions are found within the window alone: one gap wide enough anywhere along
    a building's outer wall joins all the outside to its inside. Where no passage cell touches
    ``at``'s cell or those beside it, nothing is marked."""
    resolution = reachable.resolution
    h, w = frontier.evidence.shape
    half = int(math.ceil(config.sensor_range / resolution)) + 1
    cx, cy = reachable.cell(at)
    side = 2 * half + 1
    window, clearance = np.full((side, side), 0.5), np.full((side, side), np.inf)
    x0, x1, y0, y1 = max(cx - half, 0), min(cx + half + 1, w), max(cy - half, 0), min(cy + half + 1, h)
    if x0 < x1 and y0 < y1:
        inside = np.s_[y0 - cy + half:y1 - cy + half, x0 - cx + half:x1 - cx + half]
        window[inside] = frontier.evidence[y0:y1, x0:x1]
        clearance[inside] = frontier.clearance[y0:y1, x0:x1]
    origin = reachable.origin + resolution * np.array([cx - half, cy - half])
    passage = _passage(config, costmap, resolution)
    regions, _ = ndimage.label(clearance > passage, structure=np.ones((3, 3), dtype=bool))
    around = regions[half - 1:half + 2, half - 1:half + 2]
    joined = np.unique(around[around > 0])
    if not len(joined):
        return window, origin
    counted = np.isin(regions, joined) & (clearance > config.robot_radius)
    return np.where((np.abs(window - 0.5) <= KNOWN) & ~counted, 0.0, window), origin


def _passage(config: ExplorerConfig, costmap: CostmapConfig, resolution: float) -> float:
    """Meters: the clearance along the grid's axes of a cell of the narrowest passage the
    costmap plans through (the robot's radius and margin, less the squeeze and half a cell)."""
    return config.robot_radius + costmap.margin - costmap.squeeze - resolution / 2


def nearest_view(points: np.ndarray, first: np.ndarray, reachable: Reachable,
                 cell_near: Callable[[np.ndarray, np.ndarray, int], np.ndarray | None],
                 shows: Callable[[np.ndarray], bool]) -> tuple[float, np.ndarray] | None:
    """(path length, goal in m) of the nearest by path of the goals by ``VIEWS`` of ``points``
    (n, 2), spread from ``first`` (``spread``), that ``shows`` accepts (the first spread of
    those as near); each goal is the cell ``cell_near`` picks within reach of its point. None
    when no reachable one does. The goals are asked nearest first, each cell once: a look is
    the dearest part of a goal choice (a tenth of lab_e's grid run)."""
    views = []
    for point in spread(points, first, VIEWS):
        cell = cell_near(reachable.dist, reachable.cell(point), reachable.reach)
        if cell is not None and np.isfinite(reachable.dist[cell[1], cell[0]]):
            views.append((float(reachable.dist[cell[1], cell[0]]), len(views), (int(cell[0]), int(cell[1]))))
    asked = set()
    for distance, _, cell in sorted(views):
        if cell not in asked:
            asked.add(cell)
            goal = reachable.origin + reachable.resolution * np.array(cell)
            if shows(goal):
                return distance, goal
    return None


def spread(points: np.ndarray, first: np.ndarray, k: int) -> np.ndarray:
    """(≤ k, 2) of ``points`` (n, 2), each the farthest from ``first`` (2,) and those taken
    before it (farthest-point sampling)."""
    gap = np.linalg.norm(points - first, axis=1)
    taken = []
    for _ in range(min(k, len(points))):
        j = int(np.argmax(gap))
        if gap[j] == 0.0:
            break
        taken.append(j)
        gap = np.minimum(gap, np.linalg.norm(points - points[j], axis=1))
    return points[taken]


def _reaches(snapshot: MapSnapshot, region: np.ndarray, points: cKDTree, reach: float) -> bool:
    """Has the region (k, 2) of cells a cell (its centre) closer than ``reach`` m to one of
    the ``points`` (a tree of them, m) (or as close, to within a nanometre)?"""
    centres = np.asarray(snapshot.origin, float) + snapshot.resolution * region
    return bool(points.query(centres)[0].min() < reach + 1e-9)


def evidence(snapshot: MapSnapshot) -> np.ndarray:
    """(h, w) the map the planner reads free, occupied and unknown space from: the stack's
    costmap grid when it gave one, else the map itself."""
    return snapshot.prob if snapshot.traversable is None else snapshot.traversable
