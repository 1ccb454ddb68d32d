import numpy as np
import pytest

from sim.robot import RobotConfig
from sim.worlds import BUILTIN_WORLDS

RADIUS = RobotConfig().radius


@pytest.fixture(scope="module", params=sorted(BUILTIN_WORLDS))
def builtin(request):
    return BUILTIN_WORLDS[request.param]()


def test_generation_is_deterministic(builtin):
    again = BUILTIN_WORLDS[builtin.world.name]()
    np.testing.assert_array_equal(builtin.world.occupied, again.world.occupied)
    np.testing.assert_array_equal(builtin.tour, again.tour)


def test_sizes():
    assert BUILTIN_WORLDS["cave"]().world.size == pytest.approx((20.0, 20.0))
    assert BUILTIN_WORLDS["office"]().world.size == pytest.approx((40.0, 30.0))
    assert BUILTIN_WORLDS["room"]().world.size == pytest.approx((10.0, 8.0))


def test_room_is_the_same_turned_by_half_a_turn():
    occupied = BUILTIN_WORLDS["room"]().world.occupied
    np.testing.assert_array_equal(occupied, np.rot90(occupied, 2))
    assert 0.02 < occupied[20:-20, 20:-20].mean() < 0.1      # the box, 1 m in from the walls


def test_boundary_is_closed(builtin):
    grid = builtin.world.occupied
    assert grid[0].all() and grid[-1].all() and grid[:, 0].all() and grid[:, -1].all()


def test_tour_is_drivable_and_closed(builtin):
    world, tour = builtin.world, builtin.tour
    start = np.array([builtin.start.x(), builtin.start.y()])
    assert np.allclose(tour[0], start) and np.allclose(tour[-1], start)
    for a, b in zip(tour[:-1], tour[1:]):
        for s in np.linspace(0.0, 1.0, int(np.linalg.norm(b - a) / 0.02) + 2):
            assert not world.collides(a + s * (b - a), RADIUS), f"tour leg {a} -> {b} is blocked"


def test_cave_has_obstacles_inside():
    world = BUILTIN_WORLDS["cave"]().world
    inner = world.occupied[60:-60, 60:-60]  # 3 m in from the border
    assert 0.05 < inner.mean() < 0.4


def test_office_rooms_are_reachable_through_doors():
    office = BUILTIN_WORLDS["office"]()
    reach = office.world.reachable((office.start.x(), office.start.y()), RADIUS)
    # a point in every room, below and above the corridor, and the lobby
    for x in (4.0, 12.0, 20.0, 28.0):
        for y in (6.0, 24.0):
            ix, iy = office.world.cell_of(np.array([x, y]))
            assert reach[iy, ix], f"room at ({x}, {y}) is not reachable"
