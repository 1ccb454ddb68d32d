"""Generated buildings: one bitmap per seed, a closed outer wall, every opening at least 0.8 m
(measured on the bitmap, not taken from the generator), and maps the suite reads back."""

import csv

import numpy as np
import pytest
from scipy import ndimage

from sim.buildings import BuildingStyle, building, passage_problems, write_buildings, write_map
from sim.campaign import suite_world_spec
from sim.suite import largest_region, suite_maps
from sim.world import World
from sim.world_io import RosMap, read_ros_map

RES = 0.05
RADIUS = 0.25
#: Small buildings keep the tests fast; the default sizes have a test of their own.
SMALL = BuildingStyle(width=(15.0, 24.0), height=(15.0, 18.0))
SEEDS = [0, 1, 2, 3, 4, 5]


@pytest.fixture(scope="module")
def plans():
    return {seed: building(seed, SMALL) for seed in SEEDS}


# --- measures on the bitmap, independent of the generator ----------------------------------------

def narrowest_run(free: np.ndarray) -> int:
    """Cells: the shortest run of free cells along a row or a column, walls at both ends: the
    width of the narrowest axis-aligned opening (a door, a gap beside furniture)."""
    shortest = np.inf
    for structure in ([[0, 0, 0], [1, 1, 1], [0, 0, 0]], [[0, 1, 0], [0, 1, 0], [0, 1, 0]]):
        labels, n = ndimage.label(free, structure=structure)
        shortest = min(shortest, np.bincount(labels.ravel())[1:].min())
    return int(shortest)


def core_parts(free: np.ndarray, width: float) -> int:
    """Parts of the free space eroded by width/2: the 4-connected regions of cells at least
    width/2 from every wall, on the grid refined 2 x 2 (where a gap of n cells is n·RES wide
    from centre to centre of the wall cells on either side, less one fine cell)."""
    fine = np.kron(free, np.ones((2, 2), dtype=bool))
    to_wall = ndimage.distance_transform_edt(np.pad(fine, 1))[1:-1, 1:-1] * RES / 2
    return ndimage.label(to_wall >= width / 2 - 1e-9)[1]


def two_rooms(door_cells: int) -> np.ndarray:
    """(80, 120) free mask: two 2.9 m x 3.5 m rooms, a wall 2 cells thick between them with a door
    ``door_cells`` wide at its bottom end, against the corner."""
    free = np.zeros((80, 120), dtype=bool)
    free[5:75, 2:60] = True
    free[5:75, 62:118] = True
    free[5:5 + door_cells, 60:62] = True
    return free


@pytest.mark.parametrize("cells, parts", [(15, 2), (16, 1)])
def test_the_measures_tell_a_door_of_0_75_m_from_one_of_0_8_m(cells, parts):
    free = two_rooms(cells)
    assert narrowest_run(free) == cells
    assert core_parts(free, 0.8) == parts
    assert bool(passage_problems(free, RES)) == (cells < 16)      # the generator's own check agrees


def test_the_generator_check_finds_a_closed_pocket_and_a_narrow_dead_end():
    pocket = two_rooms(20)
    pocket[40:42, 10:30] = False
    pocket[40:60, 10:12] = pocket[58:60, 10:30] = pocket[40:60, 28:30] = False     # a closed box in a room
    assert any("2 regions" in p for p in passage_problems(pocket, RES))
    slot = two_rooms(20)
    slot[30:75, 20:32] = False
    slot[30:75, 44:60] = False
    slot[30:75, 32:44] = True                     # a slot 0.6 m wide, 2.25 m deep, open at the bottom
    assert any("from the 0.8 m passages" in p for p in passage_problems(slot, RES))


# --- the generator -----------------------------------------------------------------------------

def test_a_seed_gives_one_bitmap(plans):
    again = building(SEEDS[1], SMALL)
    assert np.array_equal(again.free, plans[SEEDS[1]].free)
    assert np.array_equal(again.inside, plans[SEEDS[1]].inside)


def test_seeds_give_different_buildings(plans):
    bitmaps = [p.free for p in plans.values()]
    for i, a in enumerate(bitmaps):
        for b in bitmaps[i + 1:]:
            assert a.shape != b.shape or not np.array_equal(a, b)


def test_every_opening_admits_0_8_m_and_the_robot_reaches_all_free_space(plans):
    for seed, plan in plans.items():
        assert narrowest_run(plan.free) >= round(0.8 / RES), seed
        assert core_parts(plan.free, 0.8) == 1, seed
        assert ndimage.label(plan.free)[1] == 1, seed                  # no closed pocket
        world = World(~plan.free, (RES, RES))
        fits = world.clearance() >= RADIUS
        assert np.array_equal(largest_region(world, RADIUS), fits), seed    # one region for the robot


def test_the_outer_wall_is_closed_and_thicker_than_the_inner_ones(plans):
    for seed, plan in plans.items():
        free = plan.free
        assert not (free[0].any() or free[-1].any() or free[:, 0].any() or free[:, -1].any()), seed
        assert not (free & ~plan.inside).any(), seed
        # every free cell is at least 0.25 m (5 cells, the thinnest outer wall) from the outside
        from_outside = ndimage.distance_transform_edt(plan.inside)
        assert from_outside[free].min() > 5, seed
        # and the walls between free cells are thinner: some are 1-4 cells across
        thin = ndimage.binary_closing(free, structure=np.ones((1, 5), bool)) | \
            ndimage.binary_closing(free, structure=np.ones((5, 1), bool))
        assert (thin & ~free).any(), seed


def test_parts_keep_to_their_ranges(plans):
    for seed, plan in plans.items():
        for door in plan.doors:
            assert 16 <= max(door.width, door.height) <= 24, (seed, door)     # 0.8-1.2 m
            assert 1 <= min(door.width, door.height) <= 4, (seed, door)       # the wall, 5-20 cm
        for space in plan.spaces:
            side = min(space.rect.width, space.rect.height)
            assert (24 <= side <= 50) if space.kind == "corridor" else side >= 50, (seed, space)


def test_default_sizes_are_offices_and_labs():
    for seed in (0, 1, 2):
        plan = building(seed)
        h, w = plan.free.shape
        assert 15.0 <= w * RES - 1.0 <= 60.0 and 15.0 <= h * RES - 1.0 <= 40.0, seed    # 0.5 m margins
        assert 150.0 <= plan.free_area_m2 <= 2000.0, seed
        assert len(plan.spaces) >= 10 and len(plan.furniture) > 0, seed


# --- written as a suite ----------------------------------------------------------------------

def test_the_written_map_reads_back_as_generated(plans, tmp_path):
    plan = plans[SEEDS[2]]
    ros = read_ros_map(write_map(tmp_path, plan))
    assert ros.resolution == RES and ros.origin == (0.0, 0.0)
    assert np.array_equal(ros.state == RosMap.FREE, plan.free)
    assert np.array_equal(ros.state == RosMap.UNKNOWN, ~plan.inside)
    assert np.array_equal(ros.world().occupied, plan.world().occupied)


def test_the_manifest_is_read_by_the_suite(tmp_path):
    manifest = write_buildings(tmp_path, [4, 0], SMALL)
    assert suite_maps(tmp_path) == [tmp_path / "building_0004.yaml", tmp_path / "building_0000.yaml"]
    assert suite_maps(manifest, ["building_0000"]) == [tmp_path / "building_0000.yaml"]
    with open(manifest, newline="") as f:
        rows = list(csv.DictReader(f))
    plan = building(0, SMALL)
    assert float(rows[1]["free_area_m2"]) == pytest.approx(plan.free_area_m2, abs=0.01)
    spec = suite_world_spec(str(tmp_path / "building_0000.yaml"), RADIUS)
    assert np.array_equal(spec.load().occupied, ~plan.free)
    assert spec.max_steps >= 6000
