import numpy as np
import pytest

from sim.world import World


def wall_with_gap(gap_m):
    """10 m x 10 m with a wall at x in [5, 5.1) and a gap of ``gap_m`` centred at y = 5."""
    grid = np.zeros((100, 100), dtype=bool)
    grid[:, 50] = True
    half = int(round(gap_m / 0.1 / 2))
    grid[50 - half:50 + half, 50] = False
    return World(grid, (0.1, 0.1))


def test_reachable_respects_the_robot_radius():
    narrow = wall_with_gap(0.4)  # narrower than a 0.25 m robot
    reach = narrow.reachable((2.0, 5.0), radius=0.25)
    assert reach[50, 20] and not reach[50, 80]
    wide = wall_with_gap(1.0)
    assert wide.reachable((2.0, 5.0), radius=0.25)[50, 80]
    # cells closer to a wall than the radius are not reachable
    assert not reach[50, 48] and reach[50, 46]


def test_a_gap_that_leaves_less_than_the_margin_is_not_reachable():
    """A 0.6 m gap on 0.05 m cells (a wall at x in [5, 5.05)): a 0.25 m robot fits with 5 cm to
    spare, so with a 0.02 m margin the far side is reachable, with 0.06 m it is not. Beside the
    wall, cells with clearance between the radius and radius + margin count (the robot's centre
    goes there), as without a margin."""
    grid = np.zeros((200, 200), dtype=bool)
    grid[:, 100] = True
    grid[94:106, 100] = False                                   # y in [4.7, 5.3)
    world = World(grid, (0.05, 0.05))
    plain = world.reachable((2.0, 5.0), 0.25)
    assert plain[100, 160]
    assert (world.reachable((2.0, 5.0), 0.25, 0.02) == plain).all()
    tight = world.reachable((2.0, 5.0), 0.25, 0.06)
    assert not tight[100, 160] and tight[100, 40]
    # x = 0.275 m: 0.275 m from the map's edge, between 0.25 and 0.25 + 0.06
    assert tight[40, 5] and plain[40, 5] and not plain[40, 4]


def test_reachable_from_a_blocked_start_is_an_error():
    with pytest.raises(ValueError, match="not free"):
        wall_with_gap(1.0).reachable((5.05, 2.0), radius=0.25)


def test_clearance_is_distance_to_the_wall_face():
    world = wall_with_gap(0.0)
    # cell centre at x = 2.05 is 2.95 m from the face at x = 5.0, and 2.05 m from the edge x = 0
    ix, iy = world.cell_of(np.array([2.05, 5.05]))
    assert world.clearance()[iy, ix] == pytest.approx(2.05)
    ix, iy = world.cell_of(np.array([4.05, 5.05]))
    assert world.clearance()[iy, ix] == pytest.approx(0.95)


def test_cell_frame_round_trip():
    world = World(np.zeros((3, 4), dtype=bool), (0.5, 0.25), origin=(-1.0, 2.0))
    cells = np.array([[0, 0], [3, 2]])
    centres = world.center_of(cells)
    np.testing.assert_allclose(centres, [[-0.75, 2.125], [0.75, 2.625]])
    np.testing.assert_array_equal(world.cell_of(centres), cells)


def test_bad_grid_is_rejected():
    with pytest.raises(ValueError, match="resolution"):
        World(np.zeros((2, 2), dtype=bool), (0.0, 0.1))
    with pytest.raises(ValueError, match="2-D"):
        World(np.zeros(4, dtype=bool), (0.1, 0.1))


def test_collides_is_the_exact_disc_test_wherever_the_shortcut_applies():
    """Random points and radii on a cluttered 0.1 x 0.05 m grid: ``collides`` (which skips the
    cell-by-cell test where the centre distance rules a contact out) against the disc tested
    against every occupied cell rectangle and the border's, by brute force."""
    rng = np.random.default_rng(3)
    occupied = rng.random((30, 40)) < 0.05
    world = World(occupied, (0.1, 0.05), origin=(-1.0, 2.0))
    iy, ix = np.nonzero(np.pad(occupied, 1, constant_values=True))
    lo = np.column_stack([(ix - 1) * 0.1 - 1.0, (iy - 1) * 0.05 + 2.0])
    for _ in range(3000):
        xy = rng.uniform([-1.0, 2.0], [3.0, 3.5])
        radius = rng.uniform(0.01, 0.4)
        gap = np.maximum(np.maximum(lo - xy, 0.0), xy - (lo + [0.1, 0.05]))
        assert world.collides(xy, radius) == bool((np.sum(gap**2, axis=1) < radius**2).any())
