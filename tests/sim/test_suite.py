"""The suite benchmark's pieces: seeded random starts, the area-based step budget, the manifest."""

import math

import numpy as np
import pytest

from sim.campaign import WorldSpec, plan
from sim.data import shared_data_dir
from sim.episode import EpisodeConfig
from sim.suite import (MIN_STEPS, STEPS_PER_M2, free_area_m2, sample_start, step_budget, suite_maps,
                       world_list)
from sim.world import World

RADIUS = 0.25
RES = 0.05


def two_rooms_with_a_slit() -> World:
    """10 m x 6 m inside walls 0.1 m thick: a 6 m room on the left with a 1 m pillar, a 3.8 m room
    on the right, between them a wall at x 6.0-6.2 with a 0.4 m slit (narrower than the robot)."""
    grid = np.zeros((round(6.2 / RES), round(10.2 / RES)), dtype=bool)
    grid[:2], grid[-2:], grid[:, :2], grid[:, -2:] = True, True, True, True
    grid[:, 120:124] = True
    grid[60:68, 120:124] = False                       # the slit, y in [3.0, 3.4)
    grid[40:60, 40:60] = True                          # the pillar, x and y in [2, 3)
    return World(grid, (RES, RES), name="slit")


@pytest.fixture(scope="module")
def world():
    return two_rooms_with_a_slit()


def test_starts_are_in_the_largest_region_and_clear_of_walls(world):
    for seed in range(30):
        pose = sample_start(world, RADIUS, seed)
        xy = np.array([pose.x(), pose.y()])
        # the left room (x in [0.1, 6.0)), 0.5 m from its walls and the pillar: checked exactly
        assert 0.6 <= xy[0] <= 5.5 and 0.6 <= xy[1] <= 5.6, xy
        assert not world.collides(xy, 0.5), xy
        assert np.hypot(*np.maximum(np.abs(xy - 2.5) - 0.5, 0.0)) >= 0.5, xy     # the pillar
        reach = world.reachable(xy, RADIUS)
        assert not reach[:, 124:].any()                                           # not through the slit
        assert reach.sum() * RES * RES == pytest.approx(free_area_m2(world, RADIUS))
        assert -np.pi <= pose.theta() <= np.pi


def test_starts_are_the_same_for_a_seed_and_differ_across_seeds(world):
    poses = [sample_start(world, RADIUS, seed) for seed in range(10)]
    again = [sample_start(world, RADIUS, seed) for seed in range(10)]
    assert all(a.equals(b, 0.0) for a, b in zip(poses, again))
    xy = {(round(p.x(), 3), round(p.y(), 3)) for p in poses}
    assert len(xy) == 10
    headings = np.array([p.theta() for p in poses])
    assert headings.std() > 1.0                          # uniform on [-π, π) has s.d. 1.81


def test_starts_spread_over_the_region(world):
    xs = np.array([sample_start(world, RADIUS, seed).x() for seed in range(60)])
    # the clear band is x in [0.6, 5.5]: uniform draws land on both halves
    assert (xs < 3.0).sum() > 10 and (xs > 3.0).sum() > 10


def test_a_world_with_no_clear_place_says_so():
    corridor = np.ones((20, 100), dtype=bool)
    corridor[4:16, 2:98] = False                         # 0.6 m wide: the robot fits, 0.5 m clear nowhere
    with pytest.raises(ValueError, match="0.5 m from the walls"):
        sample_start(World(corridor, (RES, RES), name="corridor"), RADIUS, 0)


def test_the_budget_grows_with_the_area_above_todays_floor():
    """The floor is today's 6000 scans; above it the budget is proportional to the area, and
    lab_e's 372 m², whose C-frontier run needed 13 100 scans to stop by itself, get 1.5x that
    at least."""
    assert step_budget(0.0) == step_budget(100.0) == MIN_STEPS == 6000
    assert step_budget(2000.0) == pytest.approx(2 * step_budget(1000.0), abs=1)
    assert step_budget(1000.0) == math.ceil(1000.0 * STEPS_PER_M2)
    assert step_budget(372.0) >= 1.5 * 13_100
    with pytest.raises(ValueError):
        step_budget(float("nan"))


def test_the_free_area_is_the_robots_largest_region(world):
    # left room's interior 5.9 x 6.0 m, less 0.25 m at each wall, less the pillar grown by 0.25 m
    # (1.5 x 1.5 m with rounded corners: (1 + 4 * 0.25) + π 0.25²), on 5 cm cells
    interior = (5.9 - 0.5) * (6.0 - 0.5)
    pillar = 1.0 + 4 * 0.25 * 1.0 + np.pi * 0.25 ** 2
    assert free_area_m2(world, RADIUS) == pytest.approx(interior - pillar, abs=0.1)


def test_plan_gives_every_method_the_same_seeded_start_and_the_worlds_budget(tmp_path, world):
    image = tmp_path / "slit.png"
    from PIL import Image

    Image.fromarray(np.where(np.flipud(world.occupied), 0, 255).astype(np.uint8)).save(image)
    spec = WorldSpec(str(image), None, resolution=RES, max_steps=123)
    base = EpisodeConfig()
    runs = plan(tmp_path / "out", [spec], {m: base.overridden(method=m) for m in ("gp", "grid")}, [0, 1, 2])
    by = {(r.method, r.seed): r for r in runs}
    for seed in (0, 1, 2):
        assert by["gp", seed].world.start == by["grid", seed].world.start
        expected = sample_start(spec.load(), RADIUS, seed)
        assert np.allclose(by["gp", seed].world.start, (expected.x(), expected.y(), expected.theta()))
    assert len({by["gp", s].world.start for s in (0, 1, 2)}) == 3
    assert all(r.config["max_steps"] == 123 for r in runs)


@pytest.mark.skipif(shared_data_dir() is None, reason="shared data not found")
def test_the_suite_manifest_lists_its_maps():
    folder = shared_data_dir() / "maps" / "suite"
    maps = suite_maps(folder)
    assert len(maps) == 16 and maps[0].name == "lab_a.yaml" and all(p.is_file() for p in maps)
    assert suite_maps(folder / "manifest.csv", ["office_g", "lab_c.yaml"]) == [folder / "office_g.yaml",
                                                                            folder / "lab_c.yaml"]
    with pytest.raises(ValueError, match="no map called lab_z"):
        suite_maps(folder, ["lab_z"])


@pytest.mark.skipif(shared_data_dir() is None, reason="shared data not found")
def test_world_list_names_suite_maps_and_the_extras_with_their_sizes():
    """Suite maps by name, then the extras: a built-in world by its name, a Stage bitmap by its
    path in the shared data with the size it is read at."""
    data = shared_data_dir()
    folder = data / "maps" / "suite"
    assert world_list(data, folder, ["stage_cave", "lab_c", "cave"]) == [
        (str(folder / "lab_c.yaml"), None), (str(data / "maps" / "cave.png"), (20.0, 20.0)), ("cave", None)]
    assert len(world_list(data, folder, None)) == 16 + 4
    with pytest.raises(ValueError, match="no map called lab_z"):
        world_list(data, folder, ["lab_z"])


@pytest.mark.skipif(shared_data_dir() is None, reason="shared data not found")
def test_starts_on_a_real_floor_plan_are_reachable_and_clear():
    from sim.world_io import load_world

    world = load_world(shared_data_dir() / "maps" / "suite" / "lab_a.yaml")
    area = free_area_m2(world, RADIUS)
    for seed in range(3):
        pose = sample_start(world, RADIUS, seed)
        assert not world.collides((pose.x(), pose.y()), 0.5)
        assert world.reachable((pose.x(), pose.y()), RADIUS).sum() * RES * RES == pytest.approx(area)


# --- scoring ------------------------------------------------------------------------------------


def fabricated(world, method, seed, travel, coverage=0.995, reason="frontiers_exhausted", at99=None,
               missed=0.0, collisions=0, wall=10.0, steps=1000, area=300.0, onboard=None, doors=(),
               last=None):
    """A finished run's outcome; ``doors``: the door to each missed region, m (``missed`` m² shared);
    ``last``: its travel at the last gain (None: written before that was recorded)."""
    from sim.episode import stop_failed

    own = {} if onboard is None else {"onboard_time_s": onboard}
    if last is not None:
        own["travel_at_last_gain_m"] = last
    if doors:
        own["missed_regions"] = [{"area_m2": missed / len(doors), "door_m": d} for d in doors]
    return {"world": world, "method": method, "seed": seed, "crashed": False, "metrics": {**own,
        "travel_distance_m": travel, "coverage": coverage, "termination_reason": reason,
        "travel_at_coverage_m": {"0.90": None, "0.95": None, "0.99": at99}, "missed_area_m2": missed,
        "stop_failed": stop_failed(reason, missed), "collisions": collisions, "ate_rmse_m": 0.1,
        "wall_time_s": wall, "steps": steps, "reachable_area_m2": area}}


def crashed(world, method, seed):
    return {"world": world, "method": method, "seed": seed, "crashed": True, "metrics": None}


def outcomes():
    return [
        fabricated("cave.png", "gp", 0, 60.0, at99=54.0, wall=10.0, steps=1000),          # ok, tail 10 %
        fabricated("cave.png", "gp", 1, 80.0, at99=60.0, wall=12.0, steps=1000),          # ok, tail 25 %
        fabricated("cave.png", "grid", 0, 50.0, at99=50.0),                               # ok, tail 0
        fabricated("cave.png", "grid", 1, 100.0, coverage=0.97, reason="step_budget", collisions=2),
        fabricated("big.yaml", "gp", 0, 300.0, coverage=0.992, reason="no_reachable_goal", missed=4.0,
                   at99=280.0, wall=40.0, onboard=30.0, steps=2000, area=2500.0,
                   doors=(0.6, 0.75)),                                            # failed stop
        crashed("big.yaml", "gp", 1),
        fabricated("big.yaml", "grid", 0, 200.0, coverage=0.999, reason="no_reachable_goal", at99=190.0),
        crashed("big.yaml", "grid", 1),
    ]


def test_the_summary_counts_successes_failures_and_pairs_the_travel():
    from sim.suite import suite_summary, summary_line

    s = suite_summary(outcomes(), wall_s=600.0)
    assert (s["runs"], s["finished"], s["succeeded"], s["crashed"]) == (8, 6, 4, 2)
    assert (s["collisions"], s["step_budget_stops"], s["failed_stops"]) == (2, 1, 1)
    assert s["failed_behind_narrow_doors"] == 1                 # both its regions behind < 0.8 m
    # pairs (world, seed) with both methods finished: cave 0 (60/50), cave 1 (80/100), big 0 (300/200)
    assert s["pairs"] == 3 and s["travel_ratio"] == pytest.approx((1.2 + 0.8 + 1.5) / 3)
    # tails of the runs that reached 99 %: 6/60, 20/80, 0, 20/300, 10/200
    assert s["tail_share"] == pytest.approx((0.1 + 0.25 + 0.0 + 20 / 300 + 0.05) / 5)
    # GP cost per scan: big (the largest area) 15 ms (its stack's 30 s, not its 40 s of wall time)
    # against the Stage cave's (10 + 12) / 2 ms (wall time: runs that did not record the stack's)
    assert s["largest"] == "big.yaml" and s["largest_ms_per_scan"] == pytest.approx(15.0)
    assert s["reference"] == "cave.png" and s["reference_ms_per_scan"] == pytest.approx(11.0)
    line = summary_line(s)
    assert line.startswith("suite: 4/8 runs (50 %) ended by themselves with >= 99 % coverage; 2 crashed, "
                           "2 collisions, 1 step-budget stops, 1 failed stops (missed >= 1 m²; "
                           "1 only behind doors < 0.8 m)")
    assert "gp/grid travel 1.17 (mean of 3 paired ratios)" in line and "1.36x cave.png" in line
    assert "\n" not in line


def test_the_late_share_is_the_travel_after_the_last_gain_over_runs_that_recorded_it():
    from sim.suite import suite_rows, suite_summary, summary_line

    runs = [fabricated("w", "gp", 0, 80.0, at99=60.0, last=70.0),      # tail 25 %, late 12.5 %
            fabricated("w", "gp", 1, 50.0, at99=50.0, last=50.0),      # ended at its last gain
            fabricated("w", "gp", 2, 40.0, at99=30.0)]                 # written before: not counted
    s = suite_summary(runs, wall_s=60.0)
    assert s["late_share"] == pytest.approx((10 / 80 + 0.0) / 2)
    assert s["tail_share"] == pytest.approx((20 / 80 + 0.0 + 10 / 40) / 3)
    assert suite_rows(runs)[0]["late_share"] == pytest.approx(s["late_share"])
    assert "tail 16.7 % of travel (6.2 % after the last 1 m² seen)" in summary_line(s)
    assert suite_summary(runs[2:], wall_s=60.0)["late_share"] is None


def test_a_failed_stop_is_put_down_to_narrow_doors_only_when_every_missed_region_is_behind_one():
    from sim.suite import behind_narrow_doors

    failed = lambda doors: fabricated("w", "gp", 0, 10.0, missed=4.0, doors=doors)["metrics"]  # noqa: E731
    assert behind_narrow_doors(failed((0.6, 0.79)))
    assert not behind_narrow_doors(failed((0.6, 0.8)))         # one region behind a door it must pass
    assert not behind_narrow_doors(failed(()))                 # written before doors were measured
    assert not behind_narrow_doors(fabricated("w", "gp", 0, 10.0, doors=(0.6,))["metrics"])  # not failed


def test_a_row_per_world_and_method():
    from sim.suite import rows_csv, rows_markdown, suite_rows

    rows = suite_rows(outcomes())
    assert [(r["world"], r["method"]) for r in rows] == [("cave.png", "gp"), ("cave.png", "grid"),
                                                         ("big.yaml", "gp"), ("big.yaml", "grid")]
    grid = rows[1]
    assert (grid["runs"], grid["finished"], grid["succeeded"], grid["crashed"]) == (2, 2, 1, 0)
    assert grid["coverage"] == pytest.approx(0.9825) and grid["coverage_worst"] == pytest.approx(0.97)
    assert grid["ended"] == {"frontiers_exhausted": 1, "step_budget": 1} and grid["collisions"] == 2
    big = rows[2]
    assert (big["finished"], big["crashed"], big["succeeded"]) == (1, 1, 0)
    assert big["missed_area_worst_m2"] == 4.0 and big["ms_per_scan"] == pytest.approx(15.0)
    md = rows_markdown(rows).splitlines()
    assert len(md) == 2 + 4
    assert md[3].startswith("| cave.png | grid | 1/2 | 0 | 98.2 | 97.0 | 75.0 | 0.0 |")
    assert "| big.yaml | gp | 0/2 (1 done) | 1 |" in md[4]
    assert len(rows_csv(rows).splitlines()) == 1 + 4
