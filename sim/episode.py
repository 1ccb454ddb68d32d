"""One closed-loop exploration run: the robot moves, scans and explores the true world by itself.

``run_episode`` is a plain loop over (scan, ``Stack.step``, move); what a run records (the
coverage/entropy curve, frontier snapshots, animation frames, a Rerun log) are observers called
after every step with ``observer(step, t, stack, out, scan, truth)``.
"""

from __future__ import annotations

import time
from array import array
from collections.abc import Callable
from dataclasses import dataclass, field

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from scipy import ndimage
from tqdm import tqdm

from exploration.explorer import Plan
from exploration.stack import Stack, StackConfig, StackStep
from mapping.drift import binary_entropy
from mapping.grid import FixedPoints
from mapping.metrics import KNOWN, coverage, entropy_cells, roc_auc
from sim.animation import Frame, FrameRecorder
from sim.lidar import Lidar, LidarConfig
from sim.odometry import Odometry, OdometryNoise
from sim.robot import Robot, RobotConfig
from sim.world import World
from slam.agreement import agreement, se2_alignment
from slam.poses import positions
from slam.scan import LaserScan

#: Unknown reachable regions smaller than this (m²) are not missed area: the scattered unknown cells
#: of a seen room (1 m² is 400 cells of 5 cm, a corner or a niche the robot could stand in).
MISSED_REGION_M2 = 1.0

#: What observes a run: called after every step with (step, t, stack, out, scan, true pose).
Observer = Callable[[int, float, Stack, StackStep, LaserScan, gtsam.Pose2], None]


class EpisodeConfig(BaseModel):
    """A run: robot, sensor, odometry noise, the onboard stack, and when to stop.

    The root of gpexplore's configuration: ``gpexplore config dump`` writes it as TOML, and
    ``--config`` reads it for every command (``replay`` and ``map`` use its ``stack.slam`` and
    ``stack.com`` sections).
    """

    model_config = ConfigDict(extra="forbid")

    robot: RobotConfig = RobotConfig()
    lidar: LidarConfig = LidarConfig()
    odometry: OdometryNoise = OdometryNoise()
    stack: StackConfig = StackConfig()
    max_steps: int = Field(6000, ge=1, description="scans before the run stops (step_budget)")
    metrics_every: int = Field(25, ge=1, description="steps between coverage/entropy samples")
    snapshots: int = Field(4, ge=0, description="frontier-map snapshots kept for figures")
    animate_every: int = Field(0, ge=0, description="steps between the animation's frames "
                               "(0: no animation)")

    def overridden(self, method: str | None = None, poses: str | None = None,
                   max_steps: int | None = None) -> EpisodeConfig:
        """This configuration with the explorer's method, the pose source and the step budget
        replaced where given (None keeps this one's), validated again."""
        data = self.model_dump()
        if method is not None:
            data["stack"]["explorer"]["method"] = method
        if poses is not None:
            data["stack"]["poses"] = poses
        if max_steps is not None:
            data["max_steps"] = max_steps
        return self.model_validate(data)

    @model_validator(mode="before")
    @classmethod
    def _planner_plans_for_the_robot(cls, data):
        """``stack.explorer.robot_radius`` is derived: the robot's ``robot.radius``. A value the
        user gives for it is accepted only when it is the robot's."""
        if not isinstance(data, dict):
            return data
        robot = data.get("robot", {})
        radius = (robot.get("radius", RobotConfig.model_fields["radius"].default) if isinstance(robot, dict)
                  else robot.radius)
        stack = data.get("stack", {})
        stack = dict(stack) if isinstance(stack, dict) else stack.model_dump(exclude_unset=True)
        explorer = stack.get("explorer", {})
        explorer = dict(explorer) if isinstance(explorer, dict) else explorer.model_dump(exclude_unset=True)
        given = explorer.get("robot_radius")
        if given is not None and given != radius:
            raise ValueError(f"stack.explorer.robot_radius {given} m differs from robot.radius {radius} m: "
                             "the explorer plans for the robot's radius, set robot.radius only")
        explorer["robot_radius"] = radius
        return {**data, "stack": {**stack, "explorer": explorer}}


#: Settings derived from others (``EpisodeConfig``'s validator sets them): not written to
#: configuration files, as a user does not set them.
DERIVED_SETTINGS = {"stack": {"explorer": {"robot_radius"}}}


@dataclass
class Snapshot:
    """The explorer at a goal choice, for ``sim.figures.frontier_figure``: the plan (frontier,
    clusters, goal), the map's frame (``origin`` of cell (0, 0)'s centre, ``resolution`` in m)
    and, when kept, the map then (``prob`` (h, w), float32)."""

    step: int
    pose: gtsam.Pose2
    plan: Plan
    origin: np.ndarray
    resolution: float
    prob: np.ndarray | None = None


@dataclass
class EpisodeResult:
    """Everything a run produced; ``metrics`` is what goes into metrics.json."""

    metrics: dict
    stamps: list[float] = field(default_factory=list)
    truth: list[gtsam.Pose2] = field(default_factory=list)
    estimate: list[gtsam.Pose2] = field(default_factory=list)
    curve: list[tuple[int, float, float, float]] = field(default_factory=list)  # step, m, coverage, H
    snapshots: list[Snapshot] = field(default_factory=list)
    frames: list[Frame] = field(default_factory=list)
    stack: Stack | None = None
    config: EpisodeConfig | None = None
    world: World | None = None


class Evaluator:
    """A map against the true world: coverage of the reachable free space, the area of it missed,
    map entropy over the world's extent, and ROC AUC over the observed cells (``mapping.metrics``'
    definitions).

    The world is read in the map's frame through ``moved`` (``align``): the rigid move that
    best takes the true trajectory onto the estimated one. A run starts at its known pose, but
    a heading error gathered before any loop turns the whole map, which no loop can see: a
    map right in its own shape but turned 0.7° reads 1.5 % of lab_f_scan's floor as unknown
    (the free cells along its walls read the walls), read in the world's frame."""

    def __init__(self, world: World, start_xy, radius: float, margin: float = 0.0):
        self.reachable = world.reachable(start_xy, radius, margin)
        self.cells = np.nonzero(self.reachable)                       # (iy, ix)
        self.free = FixedPoints(world.center_of(np.column_stack(self.cells[::-1])))
        self.entropy_at = FixedPoints(entropy_cells(world.extent))
        self.start = world.cell_of(np.asarray(start_xy, float))       # (ix, iy)
        self.world = world
        self.cell_m2 = world.resolution[0] * world.resolution[1]
        self.area_m2 = self.cells[0].size * self.cell_m2
        self.moved: tuple[float, np.ndarray] = (0.0, np.zeros(2))   # angle (rad), shift (m)

    def align(self, estimate: np.ndarray, truth: np.ndarray) -> None:
        """Read the world in the map's frame from now on: ``moved`` becomes the rigid planar
        move that best takes the true positions ``truth`` (n, 2) onto the estimated positions
        ``estimate`` (n, 2) of the same scans, as ``ate_final_aligned_rmse_m`` aligns them."""
        self.moved = se2_alignment(np.asarray(truth, float), np.asarray(estimate, float))

    def coverage(self, stack: Stack, prob: np.ndarray) -> float:
        return coverage(self.free.sample(stack.map.frame, prob, moved=self.moved))

    def missed_regions(self, stack: Stack, prob: np.ndarray,
                       min_region_m2: float = MISSED_REGION_M2) -> list[dict]:
        """The reachable free space (the cells ``coverage`` reads) that the map ``prob`` does not
        know (|p − 0.5| ≤ ``KNOWN``), as 4-connected regions of at least ``min_region_m2``: a
        missed room, not the scattered unknown cells of a seen one. Each is a dict: ``area_m2``,
        ``x``, ``y`` (its centroid, m) and ``door_m``, the narrowest gap on the widest way to it
        from the start (``door_to``), largest first."""
        known = np.abs(self.free.sample(stack.map.frame, prob, moved=self.moved) - 0.5) > KNOWN
        unknown = np.zeros_like(self.reachable)
        unknown[self.cells[0][~known], self.cells[1][~known]] = True
        labels, n = ndimage.label(unknown)
        areas = np.bincount(labels.ravel(), minlength=n + 1)[1:] * self.cell_m2
        regions = []
        for label in np.flatnonzero(areas >= min_region_m2) + 1:
            region = labels == label
            x, y = self.world.center_of(np.argwhere(region)[:, ::-1]).mean(axis=0)
            regions.append({"area_m2": float(areas[label - 1]), "x": float(x), "y": float(y),
                            "door_m": self.door_to(region)})
        return sorted(regions, key=lambda r: -r["area_m2"])

    def door_to(self, region: np.ndarray) -> float:
        """Meters: the width of the narrowest door the robot must pass on the widest way from the
        start to the (h, w) bool ``region``: twice the least clearance along it, read on the
        lattice of half cells (``lattice_clearance``), where a door of any number of cells has a
        point at its middle (at cell centres alone, a door an even number of cells wide read a
        cell narrower: lab buildings' 0.8 m doors as 0.75 m). A room missed behind a door as
        narrow as the robot's diameter and margins tells another story than one behind a wide
        door."""
        rows, cols = self.cells
        resolution, (h, w) = self.world.resolution[0], self.world.occupied.shape
        # the reachable cells' box, widened by the start's clearance: its edge counts as a wall
        margin = int(np.ceil(self.world.clearance()[self.start[1], self.start[0]] / resolution)) + 2
        box = (slice(max(rows.min() - margin, 0), min(rows.max() + margin + 1, h)),
               slice(max(cols.min() - margin, 0), min(cols.max() + margin + 1, w)))
        clearance = lattice_clearance(self.world.occupied[box], resolution)
        # cell (i, j) of the box is lattice point (2i + 1, 2j + 1)
        start = 2 * (self.start[1] - box[0].start) + 1, 2 * (self.start[0] - box[1].start) + 1
        inside = np.zeros(clearance.shape, bool)
        inside[1::2, 1::2] = region[box]
        levels = np.unique(clearance[clearance <= clearance[start]])

        def joined(level: float) -> bool:
            labels, _ = ndimage.label(clearance >= level)
            return labels[start] > 0 and bool((labels[inside] == labels[start]).any())

        lo, hi = 0, len(levels) - 1      # joined at levels[0], the least clearance
        while lo < hi:
            mid = (lo + hi + 1) // 2
            lo, hi = (mid, hi) if joined(levels[mid]) else (lo, mid - 1)
        return float(2.0 * levels[lo])

    def entropy(self, stack: Stack, prob: np.ndarray) -> float:
        """Nats over the world's extent on 0.2 m cells (unseen cells count ln 2)."""
        return float(binary_entropy(self.entropy_at.sample(stack.map.frame, prob, moved=self.moved)).sum())

    def auc(self, stack: Stack, prob: np.ndarray) -> float:
        """ROC AUC of the map against the true occupancy, over the map's observed cells."""
        frame = stack.map.frame
        iy, ix = np.nonzero(np.abs(prob - 0.5) > 0.01)
        angle, shift = self.moved
        c, s = np.cos(angle), np.sin(angle)
        xy = (frame.origin + frame.resolution * np.column_stack([ix, iy]) - shift) @ np.array([[c, -s], [s, c]])
        return roc_auc(self.world.is_occupied(xy), prob[iy, ix])


def lattice_clearance(occupied: np.ndarray, resolution: float) -> np.ndarray:
    """(2h + 1, 2w + 1) meters from each point of the half-cell lattice of the (h, w)
    ``occupied`` grid (the cells' corners, the middles of their sides and their centres; point
    (2i + 1, 2j + 1) is cell (i, j)'s centre) to the nearest occupied cell or the grid's border,
    exactly: the point of a cell nearest to a lattice point is a lattice point."""
    h, w = occupied.shape
    walled = np.pad(np.asarray(occupied, bool), 1, constant_values=True)
    # the padded cells each lattice point touches: one across a centre, two across a side
    rows = [(np.arange(2 * h + 1) - 1) // 2 + 1, np.arange(2 * h + 1) // 2 + 1]
    cols = [(np.arange(2 * w + 1) - 1) // 2 + 1, np.arange(2 * w + 1) // 2 + 1]
    touching = np.zeros((2 * h + 1, 2 * w + 1), bool)
    for r in rows:
        for c in cols:
            touching |= walled[np.ix_(r, c)]
    return ndimage.distance_transform_edt(~touching) * (resolution / 2)


def stop_failed(reason: str, missed_area_m2: float) -> bool:
    """Whether a run's end is a failure: it ran out of steps (``step_budget``), or it stopped by
    itself (``no_reachable_goal`` or ``frontiers_exhausted``) while a reachable region of at
    least ``MISSED_REGION_M2`` was still unknown (``missed_area_m2`` > 0 then)."""
    return reason == "step_budget" or missed_area_m2 >= MISSED_REGION_M2


class CurveRecorder:
    """Samples (step, travel, coverage, entropy) every ``every`` steps into ``curve``, each read
    with the evaluator aligned to the trajectory so far (``Evaluator.align``)."""

    def __init__(self, evaluator: Evaluator, robot: Robot, every: int, curve: list):
        self.evaluator, self.robot, self.every, self.curve = evaluator, robot, every, curve
        self.truth = array("d")                     # x, y (m) of each step's true pose in turn

    def __call__(self, step, t, stack, out, scan, truth) -> None:
        self.truth.extend((truth.x(), truth.y()))
        if step % self.every == 0:
            self.sample(step, stack)

    def sample(self, step: int, stack: Stack) -> None:
        truth = np.array(self.truth).reshape(-1, 2)
        self.evaluator.align(stack.localiser.positions(np.arange(len(truth))), truth)
        prob = stack.map.prob()
        self.curve.append((step, self.robot.distance, self.evaluator.coverage(stack, prob),
                           self.evaluator.entropy(stack, prob)))


class SnapshotRecorder:
    """Frontier snapshots spread over the whole run, whose length is not known in advance.

    Every goal choice is buffered as it comes; past ``2 * count`` buffered, one is dropped, never
    the first or the latest: the one whose neighbours are closest in steps (its loss leaves the
    smallest gap), so the buffer thins out evenly as the run grows. ``finish`` then puts ``count``
    of them in ``snapshots``: the first, the last goal choice of the run, and between them those
    nearest to evenly spaced steps (``count`` 1: the last only).
    """

    def __init__(self, count: int, snapshots: list):
        self.count, self.snapshots, self.buffer = count, snapshots, []

    def __call__(self, step, t, stack, out, scan, truth) -> None:
        if self.count == 0 or out.plan is None or not out.plan.new_goal:
            return
        self.buffer.append(Snapshot(step, out.pose, out.plan, stack.map.frame.origin.copy(),
                                    stack.map.frame.resolution, stack.map.prob().astype(np.float32)))
        if len(self.buffer) > max(2 * self.count, 2):
            steps = np.array([s.step for s in self.buffer])
            self.buffer.pop(1 + int(np.argmin(steps[2:] - steps[:-2])))

    def finish(self) -> None:
        """Put the chosen snapshots, in step order, in ``snapshots``."""
        steps = np.array([s.step for s in self.buffer])
        if len(steps) <= self.count:
            chosen = list(range(len(steps)))
        elif self.count == 1:
            chosen = [len(steps) - 1]
        else:
            chosen = [0, len(steps) - 1]
            for target in np.linspace(steps[0], steps[-1], self.count)[1:-1]:
                free = [i for i in range(len(steps)) if i not in chosen]
                chosen.append(min(free, key=lambda i: abs(steps[i] - target)))
        self.snapshots[:] = [self.buffer[i] for i in sorted(chosen)]


def run_episode(world: World, start: gtsam.Pose2, config: EpisodeConfig | None = None,
                seed: int = 0, progress: bool = False, watch: Observer | None = None) -> EpisodeResult:
    """Explore ``world`` from ``start`` until the stack says exploration is over, or the step
    budget ends.

    Every random draw (lidar noise, odometry noise, k-means) comes from ``seed``. ``watch``,
    when given, observes every step: ``watch(step, t, stack, out, scan, true_pose)``.
    """
    c = config or EpisodeConfig()
    lidar_seed, odom_seed, stack_seed = np.random.SeedSequence(seed).spawn(3)
    robot = Robot(world, start, c.robot)
    lidar = Lidar(c.lidar, seed=lidar_seed)
    # the odometry frame is the world frame at the start: the robot knows where it starts
    odometry = Odometry(c.odometry, seed=odom_seed, start=start)
    stack = Stack(c.stack, seed=int(stack_seed.generate_state(1)[0]),
                  speed_limits=(c.robot.max_speed, c.robot.max_turn_rate))
    explorer = c.stack.explorer
    # both methods are scored on the space a robot keeping the planners' margin reaches
    evaluator = Evaluator(world, (start.x(), start.y()), c.robot.radius,
                          max(explorer.costmap.margin, explorer.grid_costmap.margin))
    result = EpisodeResult(metrics={}, stack=stack, config=c, world=world)
    curve = CurveRecorder(evaluator, robot, c.metrics_every, result.curve)
    recorder = FrameRecorder(c.animate_every) if c.animate_every else None
    snapshots = SnapshotRecorder(c.snapshots, result.snapshots)
    observers = [curve, snapshots]
    observers += [o for o in (recorder, watch) if o is not None]
    dt = 1.0 / c.lidar.rate_hz
    reason = "step_budget"
    tic = time.perf_counter()
    onboard = 0.0       # the stack's own time: the robot's cost, without the evaluator's sampling
    bar = tqdm(total=c.max_steps, desc=f"explore {world.name} ({c.stack.explorer.method})",
               unit="scan", disable=not progress)
    for step in range(c.max_steps):
        t = step * dt
        scan = lidar.scan(world, robot.pose, t)
        before = time.perf_counter()
        out = stack.step(odometry.pose, scan, truth=robot.pose)
        onboard += time.perf_counter() - before
        result.stamps.append(t)
        result.truth.append(robot.pose)
        result.estimate.append(out.pose)
        for observe in observers:
            observe(step, t, stack, out, scan, robot.pose)
        bar.set_postfix_str(run_state(stack, result.curve), refresh=False)
        bar.update()
        if out.done is not None:
            reason = out.done
            break
        odometry.update(robot.move(out.command.v, out.command.w, dt))
    steps = len(result.stamps)
    curve.sample(steps, stack)
    bar.total = bar.n          # a run that stopped by itself is complete, not an abort at n / max_steps
    bar.set_postfix_str(f"{run_state(stack, result.curve)}, {reason}", refresh=False)
    bar.refresh()
    bar.close()
    wall = time.perf_counter() - tic
    snapshots.finish()
    if recorder is not None:
        recorder.finish(steps - 1, stack, result.estimate[-1])
        result.frames = recorder.frames
    result.metrics = _metrics(result, evaluator, robot, seed, start, reason, steps * dt, wall, onboard)
    return result


def run_state(stack: Stack, curve: list) -> str:
    """The run's state for its progress bar: the goal (x, y) m or "spin", the keyframes and
    loop closures so far, and the coverage of the curve's last sample (``CurveRecorder``)."""
    plan = stack.plan
    goal = "spin" if plan is None or plan.goal is None else f"goal ({plan.goal[0]:.1f}, {plan.goal[1]:.1f})"
    coverage = f", coverage {100 * curve[-1][2]:.0f} %" if curve else ""
    return f"{goal}, {stack.keyframes} keyframes, {stack.loops} loops{coverage}"


def _metrics(result: EpisodeResult, evaluator: Evaluator, robot: Robot, seed: int,
             start: gtsam.Pose2, reason: str, sim_time: float, wall: float, onboard: float) -> dict:
    """metrics.json of a run: ``wall`` is the run's wall time (s), ``onboard`` the part of it
    spent in the stack (the robot's own cost, without the simulator and the evaluator).
    ``ate_rmse_m`` is the error of the pose each step acted on, as the robot then knew it;
    ``ate_final_rmse_m`` that of every step's pose after the run's last correction (the final
    trajectory, as SLAM benchmarks score one). Neither is aligned: the run starts at its known
    start pose, and a heading error gathered before any loop turns the whole map, which no later
    loop can see. ``ate_final_aligned_rmse_m`` is the final trajectory's after the best rigid
    planar alignment to the truth: the map's own shape; ``map_alignment`` that move (the
    rotation in degrees, the shift in m), through which coverage, the missed area, entropy and
    AUC read the map (``Evaluator``)."""
    c, stack = result.config, result.stack
    curve = np.array(result.curve)
    steps = len(result.stamps)
    truth = positions(result.truth)
    error = positions(result.estimate) - truth
    trajectory = stack.localiser.trajectory()
    final = positions(trajectory) - truth
    prob = stack.map.prob()
    missed_regions = evaluator.missed_regions(stack, prob)
    missed = float(sum(r["area_m2"] for r in missed_regions))
    return {
        "world": result.world.name,
        "method": c.stack.explorer.method,
        "poses": c.stack.poses,
        "seed": seed,
        "start": [start.x(), start.y(), start.theta()],
        "termination_reason": reason,
        "steps": steps,
        "travel_distance_m": robot.distance,
        "sim_time_s": sim_time,
        "wall_time_s": wall,
        "onboard_time_s": onboard,
        "keyframes": stack.keyframes,
        "loop_closures": stack.loops,
        "regenerations": stack.regenerations,
        "costmap_regenerations": stack.costmap_regenerations,
        "goals": stack.explorer.goals_chosen,
        "goals_abandoned": stack.goals_abandoned,
        "final_map_entropy_nats": float(curve[-1, 3]),
        "entropy_rate_nats_per_step": float((curve[-1, 3] - curve[0, 3]) / max(steps, 1)),
        "coverage": float(curve[-1, 2]),
        "missed_area_m2": missed,
        "missed_regions": missed_regions,
        "stop_failed": stop_failed(reason, missed),
        "travel_at_coverage_m": {f"{q:.2f}": _first_at(curve, q) for q in (0.90, 0.95, 0.99)},
        "travel_at_last_gain_m": _last_gain(curve, evaluator.area_m2),
        "auc": evaluator.auc(stack, prob),
        "ate_rmse_m": float(np.sqrt(np.mean(np.sum(error ** 2, axis=1)))),
        "ate_final_rmse_m": float(np.sqrt(np.mean(np.sum(final ** 2, axis=1)))),
        "ate_final_aligned_rmse_m": agreement(trajectory, result.truth)["rmse_m"],
        "map_alignment": {"rotation_deg": float(np.degrees(evaluator.moved[0])),
                          "shift_m": [float(v) for v in evaluator.moved[1]]},
        "collisions": robot.collisions,
    }


def _first_at(curve: np.ndarray, level: float) -> float | None:
    """Travel (m) when coverage first reached ``level``; None if it never did."""
    hit = np.flatnonzero(curve[:, 2] >= level)
    return float(curve[hit[0], 1]) if hit.size else None


def _last_gain(curve: np.ndarray, area_m2: float) -> float:
    """Travel (m) at the first sample whose coverage of the reachable ``area_m2`` is within
    ``MISSED_REGION_M2`` of the run's final coverage: the robot saw less than a missed region's
    worth after it, so what it drove after it is how late the stop came."""
    seen = curve[:, 2] * area_m2
    return float(curve[np.flatnonzero(seen >= seen[-1] - MISSED_REGION_M2)[0], 1])
