"""Getting to the goal: the progress monitor, the initial spin, path following and its events."""

import math

import gtsam
import numpy as np
import pytest

from exploration.explorer import Plan
from exploration.follower import FollowerConfig
from exploration.navigation import Command, NavigationConfig, Navigator, ProgressMonitor, guarded
from sim.lidar import Lidar, LidarConfig
from sim.robot import Robot, RobotConfig
from sim.world import World

MAX_SPEED, MAX_TURN = 0.5, math.pi / 2      # the spin takes 2π / (π/2) = 4 s
T0 = 100.0                                  # the first scan's stamp: the spin's clock starts there
DT = 0.5                                    # scan period; multiples of 0.5 s are exact in binary


def ahead_plan():
    """A goal 2 m straight ahead of a robot at the origin facing +x."""
    return Plan(np.array([2.0, 0.0]), np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]), new_goal=True)


HERE = gtsam.Pose2(0.0, 0.0, 0.0)
RADIUS = 0.25


# ---------------------------------------------------------------- ProgressMonitor

def test_monitor_is_stuck_on_the_sixth_scan_without_progress():
    """steps=5, progress=0.2: the first reading sets the best (10 m); readings that stay within
    0.2 m below it (each 0.03 m less, 9.82 m at worst) count 1, 2, ... scans without progress;
    the count passes 5 on the 6th such scan."""
    monitor = ProgressMonitor(steps=5, progress=0.2)
    assert not monitor.stuck(10.0)
    results = [monitor.stuck(10.0 - 0.03 * k) for k in range(1, 7)]
    assert results == [False] * 5 + [True]
    assert monitor.best == 10.0


def test_monitor_counts_progress_against_the_best_not_the_last_reading():
    """Shrinking 0.15 m a scan never shrinks 0.2 m in one scan, but the second such scan is
    0.3 m below the best: progress, the count restarts."""
    monitor = ProgressMonitor(steps=5, progress=0.2)
    monitor.stuck(10.0)
    assert not monitor.stuck(9.85) and monitor.since_progress == 1
    assert not monitor.stuck(9.70) and monitor.since_progress == 0 and monitor.best == 9.70


def test_real_progress_restarts_the_count():
    monitor = ProgressMonitor(steps=5, progress=0.2)
    monitor.stuck(10.0)
    assert [monitor.stuck(10.0) for _ in range(5)] == [False] * 5      # 5 scans: not yet stuck
    assert not monitor.stuck(9.75)                                       # 0.25 m closer
    assert monitor.best == 9.75 and monitor.since_progress == 0
    assert [monitor.stuck(9.7) for _ in range(6)] == [False] * 5 + [True]


def test_reset_forgets_the_best():
    """After a reset a reading farther than the old best (a new, farther goal) is progress."""
    monitor = ProgressMonitor(steps=5, progress=0.2)
    monitor.stuck(10.0)
    for _ in range(4):
        monitor.stuck(10.0)
    monitor.reset()
    assert monitor.best == math.inf and monitor.since_progress == 0
    assert not monitor.stuck(50.0) and monitor.best == 50.0 and monitor.since_progress == 0
    assert [monitor.stuck(50.0) for _ in range(6)] == [False] * 5 + [True]


# ---------------------------------------------------------------- Navigator

def navigator(**config):
    return Navigator(NavigationConfig(**config), MAX_SPEED, MAX_TURN, RADIUS)


def test_initial_spin_lasts_one_turn_then_the_path_is_followed():
    """From the first stamp T0, turn at the top rate while stamp < T0 + 2π/max_turn_rate
    (T0 + 4 s: stamps T0 .. T0 + 3.5 s, 8 scans); then follow the path: the carrot 0.4 m ahead
    on a straight path is dead ahead, so w = 0 and v = min(top speed, 2 m to go) = 0.5 m/s."""
    nav = navigator()
    stamps = T0 + DT * np.arange(10)
    commands = [nav.command(HERE, ahead_plan(), t) for t in stamps]
    assert commands[:8] == [Command(0.0, MAX_TURN)] * 8
    assert [nav.spinning(t) for t in stamps] == [True] * 8 + [False] * 2
    for c in commands[8:]:
        assert c.event is None
        assert c.v == pytest.approx(MAX_SPEED, abs=1e-12) and c.w == pytest.approx(0.0, abs=1e-12)


def test_spin_ignores_the_plan():
    """While spinning, no goal (exploration over) and a goal both give the turn; after it, no
    goal gives a standstill."""
    nav = navigator()
    assert nav.command(HERE, Plan(None, done="frontiers_exhausted"), T0) == Command(0.0, MAX_TURN)
    assert nav.command(HERE, ahead_plan(), T0 + 3.5) == Command(0.0, MAX_TURN)
    assert nav.command(HERE, Plan(None, done="frontiers_exhausted"), T0 + 4.0) == Command(0.0, 0.0)


def test_without_initial_spin_the_first_command_follows_the_path():
    nav = navigator(initial_spin=False)
    assert not nav.spinning(T0)
    c = nav.command(HERE, ahead_plan(), T0)
    assert c.v == pytest.approx(MAX_SPEED, abs=1e-12) and c.w == pytest.approx(0.0, abs=1e-12)
    assert nav.command(HERE, Plan(None, done="no_reachable_goal"), T0 + DT) == Command(0.0, 0.0)


def test_goal_within_the_follower_tolerance_is_reached():
    """Tolerance 0.15 m: 0.1 m short of the goal it is reached; 0.2 m short it is not (the
    follower slows to the 0.2 m left)."""
    nav = navigator(initial_spin=False, follower=FollowerConfig(tolerance=0.15))
    assert nav.command(gtsam.Pose2(1.9, 0.0, 0.0), ahead_plan(), T0) == Command(0.0, 0.0, "reached")
    short = nav.command(gtsam.Pose2(1.8, 0.0, 0.0), ahead_plan(), T0 + DT)
    assert short.event is None and short.v == pytest.approx(0.2, abs=1e-9)


def test_standing_still_in_front_of_the_goal_is_stuck():
    """stuck_steps = 3: the first scan sets the best (2 m to go); the robot does not move, so
    scans 2, 3, 4 count 1, 2, 3 scans without progress, and scan 5 (the 4th = stuck_steps + 1
    after the first) is stuck. A new goal starts the count afresh."""
    nav = navigator(initial_spin=False, stuck_steps=3, stuck_progress=0.2)
    events = [nav.command(HERE, ahead_plan(), T0 + DT * k).event for k in range(5)]
    assert events == [None] * 4 + ["stuck"]
    stuck = nav.command(HERE, ahead_plan(), T0 + 5 * DT)
    assert stuck == Command(0.0, 0.0, "stuck")                   # still stuck: no progress since
    nav.new_goal()
    events = [nav.command(HERE, ahead_plan(), T0 + DT * k).event for k in range(6, 11)]
    assert events == [None] * 4 + ["stuck"]


def test_stuck_count_waits_for_the_spin():
    """The monitor is not fed while spinning: a robot that spins 4 s then stands still is stuck
    only stuck_steps + 1 scans after the first scan following the spin."""
    nav = navigator(stuck_steps=3, stuck_progress=0.2)
    events = [nav.command(HERE, ahead_plan(), T0 + DT * k).event for k in range(13)]
    assert events == [None] * 12 + ["stuck"]


# ---------------------------------------------------------------- the guard

def wall_at(x: float) -> np.ndarray:
    """Scan points of a wall across the robot's way, x meters ahead, 1 cm apart."""
    ys = np.linspace(-2.0, 2.0, 401)
    return np.column_stack([np.full_like(ys, x), ys])


def test_guard_slows_to_the_fastest_speed_that_stays_clear():
    """Wall 0.45 m ahead, radius 0.25, 0.5 s horizon: at 0.5 m/s the disc would end 0.20 m from
    it; at 0.25 m/s 0.325 m: the guard keeps the heading and halves the speed."""
    assert guarded(0.5, 0.0, wall_at(0.45), 0.25, 0.0, 0.5, MAX_TURN) == (0.25, 0.0)


def test_guard_turns_on_the_spot_when_every_arc_hits():
    """Wall 0.3 m ahead: straight at 0.125 m/s (the slowest) ends 0.2375 m from it; the
    tightest arc, 0.125 m/s at π/2 rad/s, reaches x = 0.125 / (π/2) = 0.08 m, 0.22 m from it.
    Every arc comes within the radius: stop, keep turning."""
    assert guarded(0.5, 0.3, wall_at(0.3), 0.25, 0.0, 0.5, MAX_TURN) == (0.0, 0.3)


def test_guard_lets_the_robot_move_away_from_what_it_already_touches():
    """A point 0.2 m behind (range noise put it inside the radius): driving away is allowed."""
    assert guarded(0.5, 0.0, np.array([[-0.2, 0.0]]), 0.25, 0.0, 0.5, MAX_TURN) == (0.5, 0.0)


def test_a_point_read_within_the_radius_does_not_let_the_disc_into_the_opposite_wall():
    """Range noise reads a point of the right-hand wall 0.24 m away, within the radius; the
    left-hand wall is 0.275 m away, its points exact. Turning left at 0.5 m/s and 0.5 rad/s
    for the 0.5 s horizon moves the centre (v/w)(1 - cos(w t)) = 0.031 m to the left, to
    0.244 m from that wall: the disc would overlap it. Whatever command the guard returns,
    its arc keeps the centre at least the radius from the left wall, and moving away from
    the point within the radius stays allowed."""
    xs = np.linspace(-1.0, 1.0, 401)
    left = np.column_stack([xs, np.full_like(xs, 0.275)])
    obstacles = np.vstack([left, [[0.0, -0.24]]])
    v, w = guarded(0.5, 0.5, obstacles, RADIUS, 0.02, 0.5, MAX_TURN)
    t = np.linspace(0.0, 0.5, 50)
    lateral = v / w * (1.0 - np.cos(w * t)) if w else np.zeros_like(t)
    assert v > 0 and 0.275 - lateral.max() >= RADIUS


def test_navigator_commands_are_guarded():
    nav = navigator(initial_spin=False)
    command = nav.command(HERE, ahead_plan(), T0, wall_at(0.45))
    assert (command.v, command.w) == (0.25, 0.0)


# ---------------------------------------------------------------- a narrow door

def door_world() -> World:
    """A one-pixel wall at x = 4.10-4.15 m with a 0.6 m door, y 1.8-2.4 m (5 cm cells): 5 cm
    to spare on each side of a 0.25 m robot in the middle of it."""
    grid = np.zeros((90, 120), dtype=bool)
    grid[:, 82] = True
    grid[36:48, 82] = False
    return World(grid, (0.05, 0.05), name="door")


#: the robot short of the door, 0.14 m off its middle line, as a planner's path left it; the
#: path turns onto the middle line before the door
BEFORE_DOOR = gtsam.Pose2(3.876, 1.962, 0.4)
THROUGH_DOOR = np.array([[3.876, 1.962], [3.95, 2.05], [4.0, 2.1], [4.2, 2.1], [4.8, 2.1]])


def test_the_carrot_is_a_point_the_robot_can_drive_straight_to():
    """Pure pursuit's carrot 0.4 m ahead lies past the path's turn, straight through the
    door's near jamb (4.10, 1.80): every arc towards it comes within the radius + 0.02 m of
    the jamb and the guard stops the robot, scan after scan. With the carrot drawn in until
    the straight drive to it is clear, the robot turns onto the middle line and passes the
    door without touching it, in the scans its 1 m at 0.5 m/s and the turns take."""
    world, lidar = door_world(), Lidar(LidarConfig(fov_deg=360, beams=720), seed=0)
    nav = navigator(initial_spin=False)
    obstacles = lidar.scan(world, BEFORE_DOOR).points()
    v, w, _ = nav.follower.command(BEFORE_DOOR, THROUGH_DOOR)
    assert guarded(v, w, obstacles, RADIUS, 0.02, 0.5, MAX_TURN)[0] == 0.0

    robot = Robot(world, BEFORE_DOOR, RobotConfig(radius=RADIUS))
    plan = Plan(THROUGH_DOOR[-1], THROUGH_DOOR, new_goal=True)
    for k in range(40):
        command = nav.command(robot.pose, plan, T0 + DT * k, lidar.scan(world, robot.pose).points())
        assert command.event != "stuck"
        if command.event == "reached":
            break
        robot.move(command.v, command.w, DT)
    assert command.event == "reached" and robot.collisions == 0


def test_a_guard_that_refuses_every_way_forward_for_a_full_turn_s_time_is_stuck():
    """A wall 0.3 m ahead across the path: every arc comes within the radius (the test above),
    so the guard turns the robot on the spot, scan after scan. After 2π / (π/2) = 4 s of that
    (stamps T0 .. T0 + 4 s: the 9th scan) the goal is abandoned, long before the monitor's
    stuck_steps (150 scans); a new goal starts the clock afresh."""
    nav = navigator(initial_spin=False)
    events = [nav.command(HERE, ahead_plan(), T0 + DT * k, wall_at(0.3)).event for k in range(10)]
    assert events == [None] * 8 + ["stuck", "stuck"]
    nav.new_goal()
    assert nav.command(HERE, ahead_plan(), T0 + 5.0, wall_at(0.3)).event is None


# ---------------------------------------------------------------- a passage barely wider

def passage_world() -> World:
    """A 0.55 m wide, 1 m long passage (y 1.00-1.55 m, x 2.00-3.00 m, 5 cm cells) between two
    rooms: 2.5 cm to spare on each side of a 0.25 m robot on its middle line (lab_e's doors)."""
    grid = np.zeros((60, 100), dtype=bool)
    grid[:20, 40:60] = True
    grid[31:, 40:60] = True
    return World(grid, (0.05, 0.05), name="passage")


@pytest.mark.parametrize("seed, heading", [(0, 0.0), (1, 0.0), (2, 0.0), (3, 0.15), (4, -0.15)])
def test_a_passage_with_centimetres_to_spare_is_driven_through_despite_range_noise(seed, heading):
    """The robot on the passage's middle line stands 0.275 m from both walls, within the
    guard's radius + clearance (0.27 m) only by what the 1 cm range noise takes off the nearest
    of many hits. Driving on sweeps past hits the robot has not had beside it, the nearest of
    which reads a centimetre or two nearer again (the minimum of more noisy readings): a guard
    that lets no arc come nearer than the robot already stands refuses them all, scan after
    scan, and the goal is abandoned at the passage. The passage is driven through, also from
    a heading 0.15 rad off its axis, and no move touches a wall."""
    world, lidar = passage_world(), Lidar(LidarConfig(), seed=seed)
    nav = navigator(initial_spin=False)
    start = gtsam.Pose2(1.5, 1.275, heading)
    path = np.array([[1.5, 1.275], [3.5, 1.275], [4.0, 1.275]])
    plan = Plan(path[-1], path, new_goal=True)
    robot = Robot(world, start, RobotConfig(radius=RADIUS))
    for k in range(60):
        command = nav.command(robot.pose, plan, T0 + DT * k, lidar.scan(world, robot.pose).points())
        assert command.event != "stuck", f"stuck at x = {robot.pose.x():.2f} m"
        if command.event == "reached":
            break
        robot.move(command.v, command.w, DT)
    assert command.event == "reached" and robot.collisions == 0
