import math

import gtsam
import numpy as np
import pytest
from pydantic import ValidationError
from scipy import ndimage
from scipy.spatial import cKDTree

from exploration import costmap
from exploration.costmap import (CostmapConfig, _disc_offsets, _rooms, classify, clearest_points, distance_to_points,
                                  driven, passable)
from exploration.explorer import Explorer, ExplorerConfig
from exploration.grid_frontier import grid_frontiers
from exploration.paths import distance_field, path_to
from mapping.occupancy import MapSnapshot


def room(n=100):
    """0.1 m cells: known free square [2, 8] m x [2, 8] m, a wall at x = 5 with a door, unknown elsewhere."""
    prob = np.full((n, n), 0.5)
    prob[20:80, 20:80] = 0.1
    prob[20:80, 50] = 0.9
    prob[45:55, 50] = 0.1
    return prob


def test_planner_never_enters_occupied_or_unknown_space():
    prob = room()
    config = CostmapConfig()
    ok, _, _ = passable(prob, 0.1, 0.25, config)
    free, occupied = classify(prob, config)
    dist, parent = distance_field(ok, (30, 50), 0.1)
    path = path_to(parent, (70, 50))
    assert np.isfinite(dist[50, 70])
    # every cell within the robot's radius of the path is known free
    for ix, iy in path:
        window = free[iy - 3:iy + 4, ix - 3:ix + 4]
        assert window.all()
    assert not (ok & ~free).any()


def test_door_narrower_than_the_robot_blocks_the_path():
    prob = room()
    prob[45:55, 50] = 0.9
    prob[49:51, 50] = 0.1  # a 0.2 m door
    ok, _, _ = passable(prob, 0.1, 0.25, CostmapConfig())
    dist, _ = distance_field(ok, (30, 50), 0.1)
    assert np.isinf(dist[50, 70])


def test_clearance_is_measured_to_the_hits_not_their_cells():
    """A 0.85 m door (x = 5.0 m, y in [4.0, 4.85] m) in a wall the map left free (Λ = 0.1, as a
    COM's fused map can be near a wall seen once): only the hits, points along the wall's face
    outside the door, block it. A 0.25 m robot with the 0.05 m margin needs more than 0.3 m
    from each jamb: y in (4.3, 4.55), the cells centred at 4.4 and 4.5 m (cells clear only off
    their centre, 4.3 and 4.6, are not needed to pass). Counted from the hits' 0.1 m cells
    (jamb cells centred at 3.95 and 4.85 m, less half a cell), only the 4.4 m row would
    remain."""
    res, radius = 0.1, 0.25
    prob = np.full((100, 100), 0.1)
    ys = np.r_[np.linspace(0.0, 4.0, 201), np.linspace(4.85, 9.9, 253)]
    hits = np.column_stack([np.full_like(ys, 5.0), ys])
    ok, _, _ = passable(prob, res, radius, CostmapConfig(unknown_clearance=0.0, margin=0.05), hits)
    np.testing.assert_allclose(res * np.flatnonzero(ok[:, 50]), [4.4, 4.5])  # cells at x = 5.0 m
    assert ok[44, 5:-5].all() and ok[45, 5:-5].all()     # the robot crosses the wall there


def test_a_wall_rim_clear_only_off_the_cell_centres_is_not_passable():
    """A wall along x = 5.03 m: the cells centred at x = 4.8 m are 0.23 m from it at their
    centre, and clear of 0.27 m (a 0.25 m robot, 0.02 m margin) only on their far side. They
    join no two regions, so paths do not hug the wall through them; the cells at 4.7 m are
    clear at their centre. An exhaustive 41 x 41 sampling of a rim cell says it has clear
    points."""
    res, radius = 0.1, 0.25
    prob = np.full((100, 100), 0.1)
    ys = np.linspace(0.0, 9.9, 991)
    hits = np.column_stack([np.full_like(ys, 5.03), ys])
    ok, _, offset = passable(prob, res, radius, CostmapConfig(unknown_clearance=0.0), hits)
    u = np.linspace(-res / 2, res / 2, 41)
    samples = np.array([4.8, 5.0]) + np.stack(np.meshgrid(u, u), axis=-1).reshape(-1, 2)
    assert (cKDTree(hits).query(samples)[0] > radius + 0.02).any()
    assert not ok[10:90, 48].any() and ok[10:90, 47].all()
    assert not offset[:, 48].any()


def test_a_door_with_no_clear_cell_centre_is_passed_through_its_clear_points():
    """A 0.56 m door (y in [4.04, 4.60] m) in a wall along x = 5.0 m: a 0.25 m robot with the
    0.02 m margin fits in the 2 cm between 4.31 and 4.33 m, where no 0.1 m cell centre lies.
    The path from one side to the other passes the door at clear points; through the cell
    centres alone there is none."""
    res, radius = 0.1, 0.25
    prob = np.full((100, 100), 0.1)
    ys = np.r_[np.linspace(0.0, 4.04, 405), np.linspace(4.60, 9.9, 531)]
    hits = np.column_stack([np.full_like(ys, 5.0), ys])
    ok, _, offset = passable(prob, res, radius, CostmapConfig(unknown_clearance=0.0), hits)
    dist, parent = distance_field(ok, (30, 43), res)
    cells = path_to(parent, (70, 43))
    assert np.isfinite(dist[43, 70])
    points = res * cells + offset[cells[:, 1], cells[:, 0]]
    assert cKDTree(hits).query(points)[0].min() > radius + 0.02
    assert np.isinf(distance_field(ok & (np.linalg.norm(offset, axis=-1) == 0), (30, 43), res)[0][43, 70])


@pytest.mark.parametrize("door, passed", [(0.46, True), (0.42, False)])
def test_a_door_that_reads_narrower_than_the_robot_by_the_squeeze_is_passed_at_its_middle(door, passed):
    """A door whose hits leave ``door`` m between its jambs, in a wall along x = 5.0 m: a
    0.25 m robot with the 0.02 m margin asks 0.54 m. Pose error puts hits centimetres inside
    free space, so a passage between two clear regions may read up to ``squeeze`` (0.05 m) a
    side narrower: 0.44 m. A 0.46 m door is passed at its middle, costed as off-centre cells;
    without the squeeze it is not. A 0.42 m door is not passed."""
    res, radius = 0.1, 0.25
    prob = np.full((100, 100), 0.1)
    ys = np.r_[np.linspace(0.0, 4.04, 405), np.linspace(4.04 + door, 9.9, 200)]
    hits = np.column_stack([np.full_like(ys, 5.0), ys])
    config = CostmapConfig(unknown_clearance=0.0)
    ok, cost, offset = passable(prob, res, radius, config, hits)
    dist, parent = distance_field(ok, (30, 43), res, cost)
    assert np.isfinite(dist[43, 70]) == passed
    if passed:
        cells = path_to(parent, (70, 43))
        points = res * cells + offset[cells[:, 1], cells[:, 0]]
        middle = 4.04 + door / 2
        crossing = points[np.abs(points[:, 0] - 5.0) < 0.05]
        assert np.abs(crossing[:, 1] - middle).max() < 0.01
        assert cKDTree(hits).query(points)[0].min() > radius + 0.02 - config.squeeze
        tight, _, _ = passable(prob, res, radius, config.model_copy(update={"squeeze": 0.0}), hits)
        assert np.isinf(distance_field(tight, (30, 43), res)[0][43, 70])


@pytest.mark.parametrize("bound", [0.27, 0.6])
def test_distance_to_points_is_the_nearest_point_s_distance_within_the_bound(bound):
    """Against a brute-force minimum over every point, at every cell centre of a 0.1 m grid:
    points in clumps (as hits on a wall) and some off the grid, which still count."""
    rng = np.random.default_rng(3)
    origin, res, shape = np.array([-1.0, 2.0]), 0.1, (30, 40)
    points = np.vstack([rng.uniform([-1.5, 1.5], [3.5, 5.5], (60, 2)),
                        rng.normal([1.0, 3.0], 0.05, (40, 2))])
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    centres = origin + res * np.stack([xx, yy], axis=-1)
    brute = np.linalg.norm(centres[:, :, None] - points[None, None], axis=3).min(axis=2)
    d = distance_to_points(points, origin, res, shape, bound)
    within = brute < bound
    assert within.any() and (~within).any()
    assert np.allclose(d[within], brute[within], rtol=0, atol=1e-12)
    assert np.isinf(d[~within]).all()
    assert np.isinf(distance_to_points(np.zeros((0, 2)), origin, res, shape, bound)).all()


def growing_views(points: np.ndarray, sizes) -> list[np.ndarray]:
    """Read-only views of the first ``sizes`` of ``points`` in one buffer, as
    ``LogOddsGrid.hits`` hands them out."""
    buffer = np.array(points)
    views = [buffer[:n] for n in sizes]
    for view in views:
        view.flags.writeable = False
    return views


@pytest.mark.parametrize("given", ["arrays", "views"])
def test_distance_to_points_of_hits_that_grow_then_move_is_the_brute_force_one(given):
    """A map's hits grow by each update's, and move at a rebuild: each call, on the same grid
    and bound, equals the brute-force minimum over the points it is given (what earlier calls
    scattered is reused only where it is the start of them), given as new arrays, or as
    read-only views of a growing buffer (taken as they are, not copied)."""
    rng = np.random.default_rng(4)
    origin, res, shape, bound = np.array([0.0, 0.0]), 0.1, (30, 40), 0.6
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    centres = origin + res * np.stack([xx, yy], axis=-1)

    def brute(points):
        d = np.linalg.norm(centres[:, :, None] - points[None, None], axis=3).min(axis=2)
        return np.where(d < bound, d, np.inf)

    for points in grown_then_moved(rng, given):
        assert np.allclose(distance_to_points(points, origin, res, shape, bound), brute(points),
                           rtol=0, atol=1e-12)


def grown_then_moved(rng: np.random.Generator, given: str) -> list[np.ndarray]:
    """Points in 0..4 x 0..3 m as a map hands them out: grown twice, moved (a rebuild), grown
    again, then fewer (another run's map); as new arrays, or as views of one buffer until the
    rebuild and of another after it."""
    first = rng.uniform([0.0, 0.0], [4.0, 3.0], (110, 2))
    moved = np.vstack([first + [0.13, -0.07], rng.uniform([0.0, 0.0], [4.0, 3.0], (30, 2))])
    if given == "arrays":
        return [first[:50].copy(), first[:80].copy(), first.copy(), moved[:110].copy(), moved.copy(),
                moved[:40].copy()]
    return growing_views(first, (50, 80, 110)) + growing_views(moved, (110, 140, 40))


def assert_clearest(hits: np.ndarray, origin: np.ndarray, res: float, bound: float,
                    cells: np.ndarray, shift: np.ndarray, clearance: np.ndarray) -> None:
    """``clearest_points``' answer for ``cells``: the point found lies in its cell, its
    clearance is its brute-force distance to the nearest hit (inf at ``bound`` or more), and it
    is the optimum of the same pattern search run on a k-d tree (the best of 3 x 3 lattices of
    steps a third, a ninth and a 27th of a cell)."""
    centres = origin + res * cells
    assert np.all(np.abs(shift) <= res / 2 + 1e-12)
    brute = np.linalg.norm(centres[:, None] + shift[:, None] - hits[None], axis=2).min(axis=1)
    assert np.allclose(np.where(brute < bound, brute, np.inf), clearance, rtol=0, atol=1e-12)
    tree, lattice = cKDTree(hits), np.array([(i, j) for j in (-1, 0, 1) for i in (-1, 0, 1)])
    for centre, found in zip(centres, clearance):
        best, step = centre, res / 3
        value = tree.query(centre, distance_upper_bound=bound)[0]
        for _ in range(3):
            points = np.clip(best + step * lattice, centre - res / 2, centre + res / 2)
            d = tree.query(points, distance_upper_bound=bound)[0]
            if d.max() > value:
                best, value = points[np.argmax(d)], d.max()
            step /= 3
        assert found == pytest.approx(value, abs=1e-12)


def test_clearest_points_climb_to_the_point_farthest_from_the_hits():
    """Cells of a 0.56 m passage between two walls of noisy hits, and cells in the open: the
    pattern search's optimum (``assert_clearest``), inf in the open, and near the middle line
    half the passage."""
    rng = np.random.default_rng(5)
    res, origin, bound, shape = 0.1, np.zeros(2), 0.6, (40, 40)
    ys = rng.uniform(0.0, 4.0, 800)
    hits = np.vstack([np.column_stack([rng.normal(1.72, 0.01, 400), ys[:400]]),
                      np.column_stack([rng.normal(2.28, 0.01, 400), ys[400:]])])
    cells = np.array([(ix, iy) for ix in range(17, 24) for iy in (10, 20, 30)] + [(5, 5), (35, 35)])
    shift, clearance = clearest_points(hits, origin, res, shape, cells, bound)
    assert_clearest(hits, origin, res, bound, cells, shift, clearance)
    assert np.isinf(clearance[-2:]).all() and np.isfinite(clearance[:-2]).all()
    middle = clearance[[i for i, (ix, _) in enumerate(cells[:-2]) if ix == 20]]
    assert np.all(middle > 0.24)                                 # half the passage, less noise


@pytest.mark.parametrize("given", ["arrays", "views"])
def test_clearest_points_of_hits_that_grow_then_move_are_the_optimum_over_them(given):
    """Each call on the same grid, with hits that grow, move and shrink as a map's do, finds
    the optimum over the hits it is given (what earlier calls sorted is reused only where it is
    the start of them), at every cell of the grid, some with hits off the grid beside them."""
    rng = np.random.default_rng(6)
    res, origin, bound, shape = 0.1, np.array([0.5, 0.5]), 0.3, (20, 30)
    cells = np.array([(ix, iy) for ix in range(0, 30, 3) for iy in range(0, 20, 3)])
    for hits in grown_then_moved(rng, given):
        shift, clearance = clearest_points(hits, origin, res, shape, cells, bound)
        assert_clearest(hits, origin, res, bound, cells, shift, clearance)
        assert np.isfinite(clearance).any() and np.isinf(clearance).any()


def test_clearest_points_search_again_only_the_cells_new_hits_fall_within_reach_of(monkeypatch):
    """Hits that grow at one end of a passage: the cells near them are searched again, the
    others keep their answers, and every answer is the one a search from scratch gives, bit for
    bit."""
    rng = np.random.default_rng(8)
    res, origin, bound, shape = 0.1, np.zeros(2), 0.6, (60, 40)
    ys = rng.uniform(0.0, 6.0, 1200)
    walls = np.vstack([np.column_stack([rng.normal(1.72, 0.01, 600), ys[:600]]),
                       np.column_stack([rng.normal(2.28, 0.01, 600), ys[600:]])])
    more = np.column_stack([rng.normal(1.8, 0.01, 50), rng.uniform(0.0, 0.5, 50)])
    cells = np.array([(ix, iy) for ix in range(15, 26) for iy in range(0, 60)])
    searched, search = [], costmap._pattern_search
    monkeypatch.setattr(costmap, "_pattern_search", lambda *a: searched.append(len(a[7])) or search(*a))
    monkeypatch.setattr(costmap, "_FOUND", costmap._Founds())
    hits = np.vstack([walls, more])
    clearest_points(hits[:len(walls)], origin, res, shape, cells, bound)
    shift, clearance = clearest_points(hits, origin, res, shape, cells, bound)
    assert searched[0] == len(cells) and 0 < searched[1] < len(cells) / 4
    monkeypatch.setattr(costmap, "_FOUND", costmap._Founds())
    fresh = clearest_points(hits, origin, res, shape, cells, bound)
    np.testing.assert_array_equal(shift, fresh[0])
    np.testing.assert_array_equal(clearance, fresh[1])


@pytest.mark.parametrize("resolution, distance", [(0.1, 0.0), (0.1, 0.1), (0.1, 0.25), (0.05, 0.3)])
def test_a_room_is_the_free_space_beyond_the_distance_from_unknown_cells(resolution, distance):
    """The free cells farther than ``distance`` from every unknown cell (off the map counting
    as one), against scipy's Euclidean distance transform of the padded map."""
    rng = np.random.default_rng(7)
    free = rng.random((23, 31)) < 0.9
    occupied = ~free & (rng.random((23, 31)) < 0.7)
    unknown = ~free & ~occupied
    edt = ndimage.distance_transform_edt(np.pad(~unknown, 1, constant_values=False),
                                         sampling=resolution)[1:-1, 1:-1]
    room = np.zeros_like(free)
    _rooms(free, occupied, _disc_offsets(resolution, distance), room)
    assert np.array_equal(room, free & (edt > distance))
    assert room.any() and (free & ~room).any() == (distance >= resolution)


def test_bad_thresholds_are_rejected():
    with pytest.raises(ValidationError, match="free_below"):
        CostmapConfig(free_below=0.7, occupied_above=0.6)


def test_grid_frontiers_and_nearest():
    prob = room()
    regions = grid_frontiers(prob, CostmapConfig(), min_size=10)
    cells = np.vstack(regions)
    # frontier cells are free and touch unknown space: the room's outline minus walls
    assert set(np.unique(cells[:, 0])) >= {20, 79}
    assert all(prob[iy, ix] < 0.35 for ix, iy in cells)
    explorer = Explorer(ExplorerConfig(method="grid", grid_costmap=CostmapConfig()))
    plan = explorer.plan(MapSnapshot(prob, None, np.zeros(2), 0.1), gtsam.Pose2(3.0, 5.0, 0.0))
    # the left edge (x = 2 m) is nearest to a robot at (3, 5): the goal is the reachable cell
    # closest to the robot within reach (0.6 m) of the frontier cell (2, 5)
    assert plan.new_goal and plan.goal == pytest.approx([2.6, 5.0])
    # tiny regions are dropped
    speck = np.full((30, 30), 0.1)
    speck[15, 15] = 0.5
    assert grid_frontiers(speck, CostmapConfig(), min_size=10) == []


def test_a_door_seen_on_a_diagonal_is_as_long_as_one_seen_along_an_axis():
    """A wall with an unseen opening between free space and unknown space, along an axis and
    at 45°: the opening's frontier is kept when the opening is 1 m wide (10 cells of 0.1 m) and
    dropped when it is 0.8 m, whichever way the wall runs. On the diagonal the frontier is a
    staircase of one cell a row, 0.14 m apart: 8 cells for the 1 m opening."""

    def axis(opening: int) -> np.ndarray:
        prob = np.full((40, 40), 0.5)
        prob[:20] = 0.05
        prob[20] = 0.95
        prob[20, 10:10 + opening] = 0.5
        return prob

    def diagonal(opening: int) -> np.ndarray:
        iy, ix = np.mgrid[:40, :40]
        prob = np.where(iy < ix, 0.05, 0.5)
        prob[(iy == ix) & ((ix < 10) | (ix >= 10 + opening))] = 0.95
        return prob

    for wide, kept in ((1.0, True), (0.8, False)):
        regions = grid_frontiers(axis(round(wide / 0.1)), CostmapConfig(), min_size=10)
        assert (len(regions) == 1) is kept and (not kept or len(regions[0]) == 10)
        cells = round(wide / (0.1 * math.sqrt(2)))             # 7 and 6 diagonal cells
        regions = grid_frontiers(diagonal(cells), CostmapConfig(), min_size=10)
        assert (len(regions) == 1) is kept and (not kept or len(regions[0]) == cells + 1)


def test_paths_keep_off_walls_where_there_is_room_and_still_pass_a_door():
    """A 3 m tall hall split at x = 5 m by a wall with a 0.8 m door low in it: from the middle
    of the left half to the middle of the right half, the path keeps the preferred clearance
    from every wall except in the doorway, while the shortest path cuts closer to the door
    jambs; ``dist`` is the length of the path taken, not its cost."""
    res = 0.1
    prob = np.full((40, 100), 0.1)
    prob[:5], prob[35:], prob[:, :5], prob[:, 95:] = 0.9, 0.9, 0.9, 0.9   # walls: y in [0.5, 3.5)
    prob[:, 50] = 0.9
    prob[6:14, 50] = 0.1                                                 # door: y in [0.6, 1.4)
    config = CostmapConfig(near_wall_cost=2.0)
    ok, cost, _ = passable(prob, res, 0.25, config)
    assert cost.min() == 1.0 and cost.max() == pytest.approx(1.0 + config.near_wall_cost)
    start, goal = (20, 20), (80, 20)
    dist, parent = distance_field(ok, start, res, cost)
    path = path_to(parent, goal)
    assert (path[:, 0] == 50).any()                                      # through the door
    steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
    assert dist[goal[1], goal[0]] == pytest.approx(res * np.sum(np.where(steps == 2, math.sqrt(2), 1.0)))
    _, occupied = classify(prob, config)
    to_wall = ndimage.distance_transform_edt(~occupied, sampling=res)
    clearance = to_wall[path[:, 1], path[:, 0]]
    outside_door = np.abs(path[:, 0] - 50) > 4
    assert clearance[outside_door].min() >= config.preferred_clearance - 1e-9
    shortest, parent = distance_field(ok, start, res)
    hug = path_to(parent, goal)
    assert to_wall[hug[:, 1], hug[:, 0]][np.abs(hug[:, 0] - 50) > 4].min() < config.preferred_clearance - 0.05
    assert shortest[goal[1], goal[0]] < dist[goal[1], goal[0]]


def test_driven_cells_are_those_the_trail_crosses_at_their_nearest_point():
    """A trail from (1.0, 1.0) to (2.0, 1.0), then (2.0, 1.5), then a 3 m jump: the cells it
    crosses are x 1.0-2.0 at y 1.0 and y 1.0-1.5 at x 2.0, each at its own centre; the jump
    adds none. A cell passed twice is at the point of the nearer pass."""
    cells, offset = driven(np.array([[1.0, 1.0], [2.0, 1.0], [2.0, 1.5], [5.0, 1.5]]), 0.1,
                           (0.0, 0.0), (50, 80))
    expected = {(ix, 10) for ix in range(10, 21)} | {(20, iy) for iy in range(10, 16)}
    assert {tuple(c) for c in cells} == expected
    np.testing.assert_allclose(offset, 0.0, atol=1e-9)
    # off the cell centres: y = 1.03, the point nearest each centre is 3 cm above it
    cells, offset = driven(np.array([[1.0, 1.03], [2.0, 1.03]]), 0.1, (0.0, 0.0), (50, 80))
    assert {tuple(c) for c in cells} == {(ix, 10) for ix in range(10, 21)}
    np.testing.assert_allclose(offset[:, 1], 0.03, atol=1e-9)
    assert np.abs(offset[:, 0]).max() <= 0.0125 + 1e-9
    # two passes along each of two rows, the nearer one first (y 1.51, then 1.53 m) and last
    # (y 1.03, then 1.01 m): each cell once, in row-major order, at its point of the nearer
    trail = np.array([[1.0, 1.03], [2.0, 1.03], [2.0, 1.51], [1.0, 1.51], [1.0, 1.53], [2.0, 1.53],
                      [2.0, 1.01], [1.0, 1.01]])
    cells, offset = driven(trail, 0.1, (0.0, 0.0), (50, 80))
    flat = cells[:, 1] * 80 + cells[:, 0]
    assert np.all(np.diff(flat) > 0)
    between = (cells[:, 0] > 10) & (cells[:, 0] < 20)          # not on the loop's sides
    np.testing.assert_allclose(offset[between & (cells[:, 1] == 10), 1], 0.01, atol=1e-9)
    np.testing.assert_allclose(offset[between & (cells[:, 1] == 15), 1], 0.01, atol=1e-9)
    assert len(driven(np.zeros((1, 2)), 0.1, (0.0, 0.0), (50, 80))[0]) == 0


def test_a_cell_passed_twice_as_near_is_at_the_point_driven_first():
    """0.5 m cells: out along y = 1.125 m from x = 1.0 to 2.0 m, then back along y = 0.875 m,
    a quarter cell each side of the row of centres at y = 1.0 m (binary-exact, so the two
    passes are exactly as near): cells (2, 2) and (3, 2) keep the pass driven first; cell
    (4, 2) is crossed at its centre by the step between the passes."""
    out, back = [[1.0, 1.125], [2.0, 1.125]], [[2.0, 0.875], [1.0, 0.875]]
    for trail, first in ((out + back, 0.125), (back[::-1] + out[::-1], -0.125)):
        cells, offset = driven(np.array(trail), 0.5, (0.0, 0.0), (10, 10))
        np.testing.assert_array_equal(cells, [[2, 2], [3, 2], [4, 2]])
        np.testing.assert_array_equal(offset, [[0.0, first], [0.0, first], [0.0, 0.0]])


def test_a_trail_on_a_diagonal_is_a_way_for_paths():
    """A corridor of free cells too narrow for the costmap's clearance (0.3 m) on the 45° line
    between two open squares, driven from (0.55, 0.55) to (2.55, 2.55) m through the corners
    of its 0.1 m cells: the crossed cells are passable and join side by side (paths take no
    diagonal step past a blocked side cell), and a path from one square to the other follows
    the line, within one cell of it."""
    prob = np.full((40, 40), 0.9)
    prob[:11, :11] = prob[21:, 21:] = 0.05                     # open ends
    iy, ix = np.mgrid[:40, :40]
    prob[np.abs(ix - iy) <= 1] = 0.05                            # the diagonal, 0.3 m wide
    trail = np.linspace(0.55, 2.55, 41)[:, None].repeat(2, axis=1)     # a pose every 7 cm
    cells, _ = driven(trail, 0.1, (0.0, 0.0), prob.shape)
    steps = np.abs(np.diff(cells[np.lexsort([cells[:, 0], cells[:, 0] + cells[:, 1]])], axis=0)).sum(axis=1)
    assert (steps == 1).all()                                    # a chain of side-by-side cells
    assert not passable(prob, 0.1, 0.25, CostmapConfig())[0][15, 15]    # too narrow by clearance alone
    ok, cost, _ = passable(prob, 0.1, 0.25, CostmapConfig(), trail=trail)
    dist, parent = distance_field(ok, (5, 5), 0.1, cost)
    assert np.isfinite(dist[25, 25])
    path = path_to(parent, (25, 25))
    assert np.abs(path[:, 0] - path[:, 1]).max() <= 1
