import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.raycast import cast_rays
from sim.world import World


def reference_ranges(world: World, origin, angles, max_range):
    """Ray-box (slab) intersection against every occupied cell and the grid's outside."""
    h, w = world.shape
    (x0, y0), (rx, ry) = world.origin, world.resolution
    iy, ix = np.nonzero(world.occupied)
    lo = np.column_stack([x0 + ix * rx, y0 + iy * ry])
    hi = lo + (rx, ry)
    out = []
    for a in angles:
        d = np.array([math.cos(a), math.sin(a)])
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (lo - origin) / d
            t2 = (hi - origin) / d
        t1 = np.where(np.isnan(t1), -np.inf, t1)
        t2 = np.where(np.isnan(t2), np.inf, t2)
        tmin = np.minimum(t1, t2).max(axis=1)
        tmax = np.maximum(t1, t2).min(axis=1)
        inside_box = (tmax >= tmin) & (tmax > 0)
        best = np.maximum(tmin[inside_box], 0.0).min(initial=np.inf)
        # leaving the grid counts as a hit
        with np.errstate(divide="ignore"):
            exits = [((x0 if d[0] < 0 else x0 + w * rx) - origin[0]) / d[0] if d[0] else np.inf,
                     ((y0 if d[1] < 0 else y0 + h * ry) - origin[1]) / d[1] if d[1] else np.inf]
        best = min(best, min(exits))
        out.append(best if best < max_range else np.inf)
    return np.array(out)


def test_axis_aligned_wall_exact():
    grid = np.zeros((100, 100), dtype=bool)
    grid[:, 70] = True  # wall face at x = 7.0 with 0.1 m cells
    world = World(grid, (0.1, 0.1))
    r = cast_rays(world, (2.345, 5.0), np.array([0.0, np.pi]), 20.0)
    assert r[0] == pytest.approx(7.0 - 2.345, abs=1e-12)
    assert r[1] == pytest.approx(2.345, abs=1e-12)  # the grid edge behind counts as a wall


def test_diagonal_ray_to_corner_wall():
    grid = np.zeros((200, 200), dtype=bool)
    grid[150:, :] = True  # wall face at y = 7.5 (0.05 m cells)
    world = World(grid, (0.05, 0.05))
    angle = np.deg2rad(30.0)
    r = cast_rays(world, (1.0, 2.5), np.array([angle]), 20.0)[0]
    assert r == pytest.approx(5.0 / math.sin(angle), abs=1e-9)


def test_thin_diagonal_wall_is_never_missed():
    n = 200
    grid = np.zeros((n, n), dtype=bool)
    idx = np.arange(n)
    grid[idx, idx] = True  # one-cell staircase wall along y = x, touching only at corners
    world = World(grid, (0.05, 0.05))
    rng = np.random.default_rng(3)
    origins = rng.uniform(0.5, 9.5, (300, 2))
    origins = origins[origins[:, 0] > origins[:, 1] + 0.2]  # below the wall
    for o in origins:
        angles = rng.uniform(np.pi / 2, np.pi, 20)  # up-left: every such ray crosses y = x
        r = cast_rays(world, o, angles, 50.0)
        # the wall lies within one cell diagonal of the line y = x
        hit = o + r[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])
        assert np.all(np.isfinite(r))
        assert np.all(np.abs(hit[:, 1] - hit[:, 0]) <= 0.05 + 1e-9)


def test_sensor_inside_wall_reads_zero_and_nothing_in_range_reads_inf():
    grid = np.zeros((10, 10), dtype=bool)
    grid[5, 5] = True
    world = World(grid, (1.0, 1.0))
    assert cast_rays(world, (5.5, 5.5), np.array([0.3]), 10.0)[0] == 0.0
    assert cast_rays(world, (1.5, 1.5), np.array([0.0]), 3.0)[0] == np.inf


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), rx=st.floats(0.05, 0.5), ry=st.floats(0.05, 0.5),
       density=st.floats(0.0, 0.3))
def test_matches_exact_geometry_on_random_grids(seed, rx, ry, density):
    rng = np.random.default_rng(seed)
    h, w = rng.integers(3, 30, 2)
    world = World(rng.random((h, w)) < density, (rx, ry), origin=tuple(rng.uniform(-5, 5, 2)))
    xmin, xmax, ymin, ymax = world.extent
    origin = np.array([rng.uniform(xmin, xmax), rng.uniform(ymin, ymax)])
    if world.is_occupied(origin):
        return
    angles = rng.uniform(-np.pi, np.pi, 16)
    max_range = float(rng.uniform(0.5, 20))
    expected = reference_ranges(world, origin, angles, max_range)
    got = cast_rays(world, origin, angles, max_range)
    finite = np.isfinite(expected)
    assert np.array_equal(finite, np.isfinite(got))
    np.testing.assert_allclose(got[finite], expected[finite], atol=1e-9)
