"""One closed-loop exploration run: the robot moves, scans and explores the true world by itself."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from tqdm import tqdm

from exploration.explorer import Plan
from exploration.follower import FollowerConfig, PathFollower
from mapping.drift import binary_entropy
from mapping.metrics import roc_auc
from sim.animation import Frame, FrameRecorder
from sim.lidar import Lidar, LidarConfig
from sim.odometry import Odometry, OdometryNoise
from sim.robot import Robot, RobotConfig
from sim.stack import Stack, StackConfig, StackStep
from sim.world import World
from slam.scan import LaserScan

# Evaluation constants: they define the metrics (comparable across runs and methods), so they
# are not part of the run's configuration.
#: Map entropy is measured on cells of this size (m), the paper's metric.
ENTROPY_CELL = 0.2
#: A cell of the reachable free space is covered when |Λ − 0.5| exceeds this (the COM's free
#: space sits at 0.2-0.36, a grid cell seen free once at 0.3).
KNOWN = 0.1


class EpisodeConfig(BaseModel):
    """A run: robot, sensor, odometry noise, stack, path follower, and when to stop.

    The root of gpexplore's configuration: ``gpexplore config dump`` writes it as TOML, and
    ``--config`` reads it for every command (``replay`` and ``map`` use its ``stack.slam`` and
    ``stack.com`` sections).
    """

    model_config = ConfigDict(extra="forbid")

    robot: RobotConfig = RobotConfig()
    lidar: LidarConfig = LidarConfig()
    odometry: OdometryNoise = OdometryNoise()
    stack: StackConfig = StackConfig()
    follower: FollowerConfig = FollowerConfig()
    max_steps: int = Field(6000, ge=1, description="scans before the run stops (step_budget)")
    metrics_every: int = Field(25, ge=1, description="steps between coverage/entropy samples")
    initial_spin: bool = Field(True, description="turn once on the spot before exploring (the "
                               "laser sees only 180 degrees)")
    stuck_steps: int = Field(150, ge=1, description="steps without getting stuck_progress closer to "
                             "the goal along the path before it is abandoned and blacklisted")
    stuck_progress: float = Field(0.2, gt=0, description="progress along the path (m) that restarts "
                                  "the stuck count")
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

    @model_validator(mode="after")
    def _planner_fits_the_robot(self):
        if self.stack.explorer.robot_radius < self.robot.radius:
            raise ValueError(f"stack.explorer.robot_radius {self.stack.explorer.robot_radius} m is "
                             f"smaller than robot.radius {self.robot.radius} m: its paths would collide")
        return self


@dataclass
class Snapshot:
    step: int
    pose: gtsam.Pose2
    plan: Plan
    origin: np.ndarray
    resolution: float


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


class _Evaluator:
    """Coverage of the reachable free space and map entropy over the world, from the true map."""

    def __init__(self, world: World, start_xy, radius: float):
        reach = world.reachable(start_xy, radius)
        iy, ix = np.nonzero(reach)
        self.free_xy = world.center_of(np.column_stack([ix, iy]))
        xmin, xmax, ymin, ymax = world.extent
        gx = np.arange(xmin + ENTROPY_CELL / 2, xmax, ENTROPY_CELL)
        gy = np.arange(ymin + ENTROPY_CELL / 2, ymax, ENTROPY_CELL)
        self.entropy_xy = np.stack(np.meshgrid(gx, gy), axis=-1).reshape(-1, 2)
        self.world = world

    def coverage(self, stack: Stack, prob: np.ndarray) -> float:
        p = stack.map.frame.sample(prob, self.free_xy)
        return float(np.mean(np.abs(p - 0.5) > KNOWN))

    def entropy(self, stack: Stack, prob: np.ndarray) -> float:
        """Nats over the world's extent on 0.2 m cells (unseen cells count ln 2)."""
        return float(binary_entropy(stack.map.frame.sample(prob, self.entropy_xy)).sum())

    def auc(self, stack: Stack, prob: np.ndarray) -> float:
        """ROC AUC of the map against the true occupancy, over the map's observed cells."""
        frame = stack.map.frame
        iy, ix = np.nonzero(np.abs(prob - 0.5) > 0.01)
        xy = frame.origin + frame.resolution * np.column_stack([ix, iy])
        return roc_auc(self.world.is_occupied(xy), prob[iy, ix])


def run_episode(world: World, start: gtsam.Pose2, config: EpisodeConfig | None = None,
                seed: int = 0, progress: bool = False,
                watch: Callable[[int, float, Stack, StackStep, LaserScan, gtsam.Pose2], None]
                | None = None) -> EpisodeResult:
    """Explore ``world`` from ``start`` until no frontier is left, or the step budget ends.

    Every random draw (lidar noise, odometry noise, k-means) comes from ``seed``. ``watch``,
    when given, sees every scan: ``watch(step, t, stack, out, scan, true_pose)``.
    """
    c = config or EpisodeConfig()
    lidar_seed, odom_seed, stack_seed = np.random.SeedSequence(seed).spawn(3)
    robot = Robot(world, start, c.robot)
    lidar = Lidar(c.lidar, seed=lidar_seed)
    # the odometry frame is the world frame at the start: the robot knows where it starts
    odometry = Odometry(c.odometry, seed=odom_seed, start=start)
    stack = Stack(c.stack, seed=int(stack_seed.generate_state(1)[0]))
    follower = PathFollower(c.robot.max_speed, c.robot.max_turn_rate, c.follower)
    evaluator = _Evaluator(world, (start.x(), start.y()), c.robot.radius)
    dt = 1.0 / c.lidar.rate_hz
    result = EpisodeResult(metrics={}, stack=stack, config=c, world=world)
    recorder = FrameRecorder(c.animate_every) if c.animate_every else None
    spin = 2 * math.pi if c.initial_spin else 0.0
    replan, reason = False, "step_budget"
    best_distance, since_progress, goals_abandoned = math.inf, 0, 0
    keyframes = loops = 0
    tic = time.perf_counter()
    bar = tqdm(total=c.max_steps, desc=f"explore {world.name} ({c.stack.explorer.method})",
               unit="scan", disable=not progress)
    for step in range(c.max_steps):
        t = step * dt
        scan = lidar.scan(world, robot.pose, t)
        out = stack.step(odometry.pose, scan, truth=robot.pose, replan=replan)
        replan = False
        keyframes += out.keyframe is not None
        loops += out.loops
        result.stamps.append(t)
        result.truth.append(robot.pose)
        result.estimate.append(out.pose)
        if recorder is not None:
            recorder.observe(step, stack, out)
        if watch is not None:
            watch(step, t, stack, out, scan, robot.pose)
        if out.plan is not None and out.plan.new_goal and len(result.snapshots) < c.snapshots \
                and stack.explorer.goals_chosen in (1, 3, 6, 10, 15, 21)[:c.snapshots]:
            result.snapshots.append(Snapshot(step, out.pose, out.plan, stack.map.origin.copy(),
                                             stack.map_resolution))
        if step % c.metrics_every == 0:
            prob = stack.map.prob()
            result.curve.append((step, robot.distance, evaluator.coverage(stack, prob),
                                 evaluator.entropy(stack, prob)))
        bar.update()
        plan = stack.plan
        if spin > 0:
            v, w = 0.0, c.robot.max_turn_rate
            spin -= w * dt
        elif plan.goal is None:
            reason = plan.done
            break
        else:
            if out.plan is not None and out.plan.new_goal:
                best_distance, since_progress = math.inf, 0
            v, w, reached = follower.command(out.pose, plan.path)
            distance = follower.remaining(out.pose, plan.path)
            if distance < best_distance - c.stuck_progress:
                best_distance, since_progress = distance, 0
            else:
                since_progress += 1
            if reached or since_progress > c.stuck_steps:
                if reached:
                    stack.explorer.reached()
                else:
                    stack.explorer.give_up()
                    goals_abandoned += 1
                replan = True
                continue
        odometry.update(robot.move(v, w, dt))
    bar.close()
    wall = time.perf_counter() - tic
    prob = stack.map.prob()
    steps = len(result.stamps)
    if recorder is not None:
        recorder.finish(steps - 1, stack, result.estimate[-1])
        result.frames = recorder.frames
    result.curve.append((steps, robot.distance, evaluator.coverage(stack, prob),
                         evaluator.entropy(stack, prob)))
    curve = np.array(result.curve)
    est = np.array([[p.x(), p.y()] for p in result.estimate])
    tru = np.array([[p.x(), p.y()] for p in result.truth])
    result.metrics = {
        "world": world.name,
        "method": c.stack.explorer.method,
        "poses": c.stack.poses,
        "seed": seed,
        "start": [start.x(), start.y(), start.theta()],
        "termination_reason": reason,
        "steps": steps,
        "travel_distance_m": robot.distance,
        "sim_time_s": steps * dt,
        "wall_time_s": wall,
        "keyframes": keyframes,
        "loop_closures": loops,
        "regenerations": stack.regenerations,
        "goals": stack.explorer.goals_chosen,
        "goals_abandoned": goals_abandoned,
        "final_map_entropy_nats": float(curve[-1, 3]),
        "entropy_rate_nats_per_step": float((curve[-1, 3] - curve[0, 3]) / max(steps, 1)),
        "coverage": float(curve[-1, 2]),
        "travel_at_coverage_m": {f"{q:.2f}": _first_at(curve, q) for q in (0.90, 0.95, 0.99)},
        "auc": evaluator.auc(stack, prob),
        "ate_rmse_m": float(np.sqrt(np.mean(np.sum((est - tru) ** 2, axis=1)))),
        "collisions": robot.collisions,
    }
    return result


def _first_at(curve: np.ndarray, coverage: float) -> float | None:
    """Travel (m) when coverage first reached ``coverage``; None if it never did."""
    hit = np.flatnonzero(curve[:, 2] >= coverage)
    return float(curve[hit[0], 1]) if hit.size else None
