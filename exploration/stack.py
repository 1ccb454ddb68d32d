"""The onboard system as one object: (odometry, scan) in; pose, map, goal and command out.

A simulated exploration run, a log replay and a log mapping all drive this one object; they
differ only in where scans come from, whether anything moves the robot, and which parts are
switched on (``mapping``, ``planning``). ``Stack.step`` is Algorithm 1 of the paper, one scan
at a time: localise → update the map → on a SLAM correction, check the map's drift and
regenerate it → plan when a goal is needed → follow the path.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from exploration.explorer import Explorer, ExplorerConfig, Plan
from exploration.navigation import Command, NavigationConfig, Navigator
from mapping.com import ContinuousOccupancyMap
from mapping.config import COMConfig
from mapping.logodds import LogOddsConfig, LogOddsGrid
from mapping.occupancy import MapSnapshot, OccupancyMap
from slam.config import SlamConfig
from slam.localiser import GivenPoses, Localisation, Localiser
from slam.pose_slam import PoseSlam
from slam.poses import positions
from slam.registration import transform
from slam.scan import LaserScan


class StackConfig(BaseModel):
    """Everything the onboard system needs, grouped the way the code is grouped."""

    model_config = ConfigDict(extra="forbid")

    poses: Literal["slam", "truth"] = Field("slam", description="Pose SLAM, or poses given with "
                                            "each scan (ground truth in simulation, for ablations; "
                                            "a log's own poses when mapping it)")
    slam: SlamConfig = SlamConfig()
    com: COMConfig = COMConfig()
    grid: LogOddsConfig = Field(
        LogOddsConfig(resolution=0.1, l_occ=2.5, l_free=-0.85, max_range=8.0),
        description="the baseline's grid: 0.1 m cells, the COM's, so that both methods plan "
        "with the same precision (on 0.2 m cells, as in the paper's Fig. 6, a 0.8 m door "
        "leaves no cell a 0.25 m robot may cross); one free observation makes a cell free, a "
        "hit outweighs two free passes")
    explorer: ExplorerConfig = ExplorerConfig()
    navigation: NavigationConfig = NavigationConfig()
    map_every: int = Field(0, ge=0, description="map every n-th scan instead of the keyframes "
                           "(0: the keyframes, as the method does; log mapping sets it)")
    plan_every: int = Field(3, ge=1, description="re-check the goal every this many keyframes")


@dataclass
class StackStep:
    """What one scan did: the pose estimate, the keyframe index (or None), the loops closed,
    whether the map was regenerated, the plan made at this scan (None when none was), the
    command for the robot (None without planning) and, once exploration is over, why."""

    pose: gtsam.Pose2
    keyframe: int | None = None
    loops: int = 0
    regenerated: bool = False
    plan: Plan | None = None
    command: Command | None = None
    done: str | None = None


class Stack:
    """Localiser → occupancy map → explorer → navigator, one scan at a time.

    Args:
        config: the stack's configuration; ``poses`` picks the localiser, ``explorer.method``
            the map (the COM for ``gp``, the log-odds grid for ``grid``).
        seed: k-means' seed.
        mapping: ``online`` keeps the map up to date at every mapped scan (Algorithm 1, what
            planning needs); ``final`` only records the mapped scans, and ``final_map`` learns
            the map once from them at their final poses (offline log mapping, where nothing
            reads the map before the end); ``off`` keeps no map (SLAM only, as in log replay).
        planning: choose goals and drive (off: log replay and log mapping).
        occupancy: a map to use instead of the one the configuration names.
        localiser: a localiser to use instead of the one the configuration names.
        speed_limits: the robot's top speed (m/s) and turn rate (rad/s), for the navigator.
    """

    def __init__(self, config: StackConfig | None = None, seed: int = 0, *,
                 mapping: Literal["online", "final", "off"] = "online", planning: bool = True,
                 occupancy: OccupancyMap | None = None, localiser: Localiser | None = None,
                 speed_limits: tuple[float, float] = (0.5, math.pi / 2)):
        self.config = c = config or StackConfig()
        if mapping not in ("online", "final", "off"):
            raise ValueError(f"Stack: mapping is online, final or off, not {mapping!r}")
        if planning and mapping != "online":
            raise ValueError("Stack: planning needs the map online (mapping='online')")
        self.mapping = mapping
        #: the laser's pose on the base (the configuration's): scans are mapped at
        #: pose ∘ laser_offset
        self.laser_offset = c.slam.laser_mount()
        self.localiser: Localiser = localiser or (PoseSlam(c.slam) if c.poses == "slam"
                                                  else GivenPoses(c.slam.keyframes))
        self.map: OccupancyMap | None = None if mapping == "off" else occupancy or self._new_map()
        # where the robot may drive: the raw evidence of the same scans (beams free their cells,
        # hits occupy theirs). The COM's smoothing closes doors a robot fits through
        self.costmap: LogOddsGrid | None = None
        if planning:
            self.costmap = self.map if isinstance(self.map, LogOddsGrid) else LogOddsGrid(c.grid)
        self.explorer = Explorer(c.explorer, seed=seed) if planning else None
        self.navigator = (Navigator(c.navigation, *speed_limits, c.explorer.robot_radius)
                          if planning else None)
        self.plan: Plan | None = None
        self.scans = self.regenerations = self.costmap_regenerations = self.goals_abandoned = 0
        self._mapped: list[tuple[int, LaserScan]] = []   # (scan index, scan) in the map
        self._since_plan = 0
        self._looked_round = True    # the initial spin is the first look round
        self._stale = False          # corrections the map was not relearnt under (``_navigate``)

    def step(self, odometry: gtsam.Pose2 | None, scan: LaserScan,
             truth: gtsam.Pose2 | None = None) -> StackStep:
        """One scan (Algorithm 1).

        Args:
            odometry: the wheel odometry pose (None when there is none).
            scan: the laser scan.
            truth: the scan's known pose, read only when ``poses="truth"``.
        """
        here = self.localiser.step(odometry, scan, truth)                    # localise
        out = StackStep(here.pose, here.keyframe, len(here.loops))
        self.scans += 1
        if self.map is not None and self._maps(here):
            self._map(here.pose, scan)                                       # update the map
        if here.corrected and self._drifted(here):                           # drift check
            self.regenerate()
            out.regenerated = True
        elif here.corrected and self.mapping == "online":
            self._stale = True
            if self.costmap not in (None, self.map):
                self.costmap.regenerate(self.mapped_scans())   # the planner's hits follow every correction
                self.costmap_regenerations += 1
        if self.explorer is not None:
            self._navigate(here, scan, out)                                  # plan and drive
        return out

    def _maps(self, here: Localisation) -> bool:
        """Does this scan go into the map: a keyframe, or every ``map_every``-th scan."""
        every = self.config.map_every
        return here.keyframe is not None if every == 0 else (self.scans - 1) % every == 0

    def _map(self, pose: gtsam.Pose2, scan: LaserScan) -> None:
        """Keep the scan for regeneration, and fuse it now when the map is online, at the
        laser's pose (the base ``pose`` ∘ ``laser_offset``)."""
        self._mapped.append((self.scans - 1, scan))
        if self.mapping == "online":
            laser = pose.compose(self.laser_offset)
            self.map.update(laser, scan)
            if self.costmap is not None and self.costmap is not self.map:
                self.costmap.update(laser, scan)

    def _drifted(self, here: Localisation) -> bool:
        """After a correction: did the online map drift past its threshold (the COM's
        Jensen–Shannon drift, eqs. 12-13; a grid always counts as drifted), or were loops it
        may have been relearnt under withdrawn? The drift is measured where the robot maps,
        and a false loop bends the map everywhere it moved (lab_f_scan: a loop 2.2 m down a
        corridor, withdrawn 180 scans later, left the map relearnt under it, and the run
        stopped with two rooms unseen)."""
        return self.mapping == "online" and (here.withdrawn > 0 or self.map.needs_regeneration)

    def _navigate(self, here: Localisation, scan: LaserScan, out: StackStep) -> None:
        """Re-plan when a goal is needed (none yet, every ``plan_every`` keyframes, the goal
        reached or abandoned, and before stopping, so that the stop is decided on the current
        map), then command the robot along the plan's path, kept off the scan's hits. Before
        stopping, the robot turns once on the spot if it has not since its last goal: what lies
        behind it may open a way (a corridor it drove into) or close the frontier. And a map
        that corrections under its drift check left where the scans were fused is relearnt at
        their corrected poses, and the stop decided on that: the drift is measured only where
        the robot maps, and office_g's GP run (seed 1) ended with a wall of the COM 0.45 m
        inside a room it had left, a strip of the room unknown behind it."""
        stamp, obstacles = scan.timestamp, transform(self.laser_offset, scan.points())
        self._since_plan += here.keyframe is not None
        spinning = self.navigator.spinning(stamp)
        if (self.plan is None or (here.keyframe is not None and self._since_plan >= self.config.plan_every)
                or (self.plan.goal is None and not spinning)):
            out.plan = self.replan(here.pose)
        command = self.navigator.command(here.pose, self.plan, stamp, obstacles)
        if command.event is not None:
            if command.event == "reached":
                self.explorer.reached()
            else:
                self.explorer.stuck(np.array([here.pose.x(), here.pose.y()]), self.plan.path)
                self.goals_abandoned += 1
            out.plan = self.replan(here.pose)
            command = self.navigator.command(here.pose, self.plan, stamp, obstacles)
        out.command = command
        if self.plan.goal is None and not spinning:
            if not self._looked_round:          # the laser sees half the circle: look once more
                self._looked_round = True
                self.navigator.spin(stamp)
                out.command = self.navigator.command(here.pose, self.plan, stamp, obstacles)
                return
            if self._stale:
                self.regenerate()
                out.regenerated = True
                out.plan = self.replan(here.pose)
                out.command = self.navigator.command(here.pose, self.plan, stamp, obstacles)
                if self.plan.goal is not None:
                    return
            out.done = self.plan.done

    def replan(self, pose: gtsam.Pose2) -> Plan:
        """Ask the explorer where to go from ``pose`` on the current map."""
        self._since_plan = 0
        self.plan = self.explorer.plan(self.snapshot(), pose)
        if self.plan.new_goal:
            self.navigator.new_goal()
            self._looked_round = False
        return self.plan

    def snapshot(self) -> MapSnapshot:
        """The map as the explorer reads it, with the robot's trail, and with the costmap
        grid's free space and hits when the map is not that grid (resampled onto the map's
        cells)."""
        snapshot = dataclasses.replace(self.map.snapshot(), trail=self.trail())
        if self.costmap is self.map:
            return snapshot
        traversable = self.costmap.frame.resampled(self.costmap.prob(), self.map.frame)
        return dataclasses.replace(snapshot, hits=self.costmap.hits(), traversable=traversable)

    def trail(self) -> np.ndarray:
        """(k, 2) where the robot's centre has been: the base at each mapped scan, as
        corrected now, meters."""
        return self.localiser.positions(np.array([i for i, _ in self._mapped], int))

    def regenerate(self) -> None:
        """Relearn the map from every mapped scan at its corrected pose (Section VII)."""
        scans = self.mapped_scans()
        self.map.regenerate(scans)
        if self.costmap is not None and self.costmap is not self.map:
            self.costmap.regenerate(scans)
        self.regenerations += 1
        self._stale = False

    def final_map(self) -> OccupancyMap:
        """Learn the map once from every mapped scan at its final pose (``mapping="final"``)."""
        self.map.regenerate(self.mapped_scans())
        return self.map

    def mapped_scans(self) -> list[tuple[gtsam.Pose2, LaserScan]]:
        """(current laser pose, scan) of every scan in the map."""
        return [(self.localiser.pose(i).compose(self.laser_offset), scan)
                for i, scan in self._mapped]

    def keyframe_poses(self) -> list[gtsam.Pose2]:
        return self.localiser.keyframe_poses()

    @property
    def keyframes(self) -> int:
        return len(self.localiser.keyframe_scans)

    @property
    def loops(self) -> int:
        """Loop closures accepted so far."""
        return len(self.localiser.loop_pairs())

    def loop_segments(self) -> np.ndarray:
        """(m, 2, 2) the loop closures as segments between their keyframes' current estimates."""
        pairs = self.localiser.loop_pairs()
        if len(pairs) == 0:
            return np.zeros((0, 2, 2))
        return positions(self.keyframe_poses())[pairs]

    def _new_map(self) -> OccupancyMap:
        c = self.config
        return ContinuousOccupancyMap(c.com) if c.explorer.method == "gp" else LogOddsGrid(c.grid)
