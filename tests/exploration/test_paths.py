import math

import numpy as np
import pytest

from exploration.paths import best_cell_near, distance_field, near_distance, path_to, seen_from


def test_open_grid_distances_are_octile():
    dist, _ = distance_field(np.ones((50, 50), dtype=bool), (0, 0), 0.1)
    assert dist[0, 30] == pytest.approx(3.0)
    assert dist[20, 20] == pytest.approx(2.0 * math.sqrt(2.0))
    assert dist[20, 30] == pytest.approx(10 * 0.1 + 20 * 0.1 * math.sqrt(2.0))


def test_path_goes_around_a_wall_and_never_through_blocked_cells():
    passable = np.ones((40, 40), dtype=bool)
    passable[0:30, 20] = False  # a wall from the bottom with a gap at the top
    dist, parent = distance_field(passable, (5, 5), 1.0)
    path = path_to(parent, (35, 5))
    assert tuple(path[0]) == (5, 5) and tuple(path[-1]) == (35, 5)
    assert passable[path[:, 1], path[:, 0]].all()
    assert path[:, 1].max() >= 30  # went over the wall
    steps = np.abs(np.diff(path, axis=0))
    assert steps.max() == 1
    length = np.sum(np.where(steps.sum(axis=1) == 2, math.sqrt(2), 1.0))
    assert length == pytest.approx(dist[5, 35])


def test_no_corner_cutting_and_unreachable_is_inf():
    passable = np.ones((10, 10), dtype=bool)
    passable[:, 5] = False
    dist, parent = distance_field(passable, (1, 1), 1.0)
    assert np.isinf(dist[:, 6:]).all() and np.all(parent[:, 6:] == -1)
    diagonal = np.ones((3, 3), dtype=bool)
    diagonal[0, 1] = diagonal[1, 0] = False
    dist, _ = distance_field(diagonal, (0, 0), 1.0)
    assert np.isinf(dist[1, 1])


@pytest.mark.parametrize("radius", [1, 3, 6])
def test_near_distance_is_the_smallest_value_in_the_disc(radius):
    """Against a brute-force minimum over the cells within ``radius`` of each cell, off the
    map counting as unreachable, on random values with unreachable cells."""
    rng = np.random.default_rng(radius)
    dist = rng.uniform(0, 10, (17, 23))
    dist[rng.random(dist.shape) < 0.7] = np.inf
    h, w = dist.shape
    brute = np.full(dist.shape, np.inf)
    for iy in range(h):
        for ix in range(w):
            for dy in range(-radius, radius + 1):
                for dx in range(-radius, radius + 1):
                    y, x = iy + dy, ix + dx
                    if dx * dx + dy * dy <= radius * radius and 0 <= y < h and 0 <= x < w:
                        brute[iy, ix] = min(brute[iy, ix], dist[y, x])
    iy, ix = np.nonzero(np.ones(dist.shape, bool))
    assert np.array_equal(near_distance(dist, radius, np.column_stack([ix, iy])), brute[iy, ix])


def test_near_distance_and_best_cell():
    passable = np.zeros((20, 20), dtype=bool)
    passable[10, :] = True
    dist, _ = distance_field(passable, (0, 10), 1.0)
    near = near_distance(dist, 2, [(5, 12), (5, 13), (5, 11)])
    assert near[0] == pytest.approx(5.0)  # from (5, 10), the only row cell within 2 of (5, 12)
    assert np.isinf(near[1])
    assert tuple(best_cell_near(dist, (5, 12), 2)) == (5, 10)
    assert near[2] == pytest.approx(4.0)  # (4, 10) is within 2 cells of (5, 11)


def test_the_best_cell_near_a_frontier_cell_sees_it():
    """Path lengths grow with x (and a little with y), every cell reachable; a wall (x = 8,
    y 9-11) stands between the frontier cell (10, 10) and the cheapest cell within 3 cells
    of it, (7, 10). Without the wall's cells that cell is the goal; with them, the cheapest
    that sees (10, 10) past the wall's end: (8, 8), on no wall cell, its segment through (9, 9).
    With every cell blocked none sees it, and the cheapest is the goal again."""
    iy, ix = np.mgrid[:20, :20]
    dist = ix + 0.01 * iy
    blocked = np.zeros((20, 20), dtype=bool)
    blocked[9:12, 8] = True
    assert tuple(best_cell_near(dist, (10, 10), 3)) == (7, 10)
    assert tuple(best_cell_near(dist, (10, 10), 3, blocked)) == (8, 8)
    assert tuple(best_cell_near(dist, (10, 10), 3, np.ones((20, 20), dtype=bool))) == (7, 10)


def test_a_field_until_a_cell_gives_that_cell_its_whole_field_length_and_path():
    """Random walls and costs: the search that stops at a cell gives it the length and path
    of the whole field, and has stopped short (cells farther along read inf that the whole
    field reaches)."""
    rng = np.random.default_rng(9)
    passable = rng.random((60, 80)) > 0.25
    cost = 1.0 + 2.0 * rng.random((60, 80))
    dist, parent = distance_field(passable, (5, 5), 0.1, cost)
    reached = np.argwhere(np.isfinite(dist))
    for iy, ix in reached[rng.choice(len(reached), 20, replace=False)]:
        part, part_parent = distance_field(passable, (5, 5), 0.1, cost, until=(ix, iy))
        assert part[iy, ix] == dist[iy, ix]
        assert np.array_equal(path_to(part_parent, (ix, iy)), path_to(parent, (ix, iy)))
    iy, ix = np.unravel_index(np.argmin(np.where(dist > 0, dist, np.inf)), dist.shape)   # a neighbour
    near, _ = distance_field(passable, (5, 5), 0.1, cost, until=(ix, iy))
    assert np.count_nonzero(np.isfinite(near)) <= 9 * 9 < len(reached) // 10      # cells popped first, and theirs


def test_sight_lines_at_once_are_the_segments_sampled_every_half_cell():
    """``seen_from`` against each segment sampled on its own: ``n`` points evenly from start
    to end (``np.linspace``), n = 2·length + 1 (at least 2), each rounded to its cell."""
    rng = np.random.default_rng(9)
    for _ in range(50):
        blocked = rng.random((40, 50)) < rng.uniform(0.0, 0.15)
        b = rng.integers(0, [50, 40])
        starts = rng.integers(0, [50, 40], size=(60, 2))
        expected = []
        for a in starts:
            t = np.linspace(0.0, 1.0, max(2, int(2 * math.hypot(*(b - a))) + 1))
            cells = np.round(a + t[:, None] * (b - a)).astype(int)
            expected.append(not blocked[cells[:, 1], cells[:, 0]].any())
        np.testing.assert_array_equal(seen_from(blocked, starts, b), expected)
