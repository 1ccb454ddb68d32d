"""The growing grid's frame: reading one grid on another's cells."""

import numpy as np
import pytest

from mapping.grid import FixedPoints, GridFrame, key_cells, unique_keys


def frame(resolution, ix0, iy0, shape):
    f = GridFrame(resolution)
    f.ix0, f.iy0, f.shape = ix0, iy0, shape
    return f


@pytest.mark.parametrize("other", [
    frame(0.1, -7, 4, (9, 12)),      # overlapping, shifted both ways
    frame(0.1, 30, 30, (5, 5)),      # disjoint: all outside
    frame(0.1, 2, 5, (3, 4)),        # inside
    frame(0.05, -3, 9, (20, 30)),    # another resolution: read at its cell centres
])
def test_resampled_is_the_grid_read_at_the_other_frame_s_cell_centres(other):
    """Cell (i, j) of ``other`` lies at its centre ((ix0 + j + 0.5)·r, (iy0 + i + 0.5)·r); the
    value there is that of the grid's cell holding it, found here by brute force over the
    grid's cells' edges, or 0.5 off the grid."""
    grid = frame(0.1, -3, 2, (10, 14))
    values = np.random.default_rng(0).random(grid.shape)
    out = grid.resampled(values, other)
    assert out.shape == other.shape
    for i in range(other.shape[0]):
        for j in range(other.shape[1]):
            x = (other.ix0 + j + 0.5) * other.resolution
            y = (other.iy0 + i + 0.5) * other.resolution
            col = [c for c in range(grid.shape[1]) if (grid.ix0 + c) * 0.1 <= x < (grid.ix0 + c + 1) * 0.1]
            row = [r for r in range(grid.shape[0]) if (grid.iy0 + r) * 0.1 <= y < (grid.iy0 + r + 1) * 0.1]
            assert out[i, j] == (values[row[0], col[0]] if col and row else 0.5)


@pytest.mark.parametrize("spread", [3, 40, 100000])   # dense boxes (the bitmap), a sparse one
def test_unique_keys_are_the_distinct_cells_keys_in_order(spread):
    """Against the distinct cells counted one by one in a set, ordered row by row (y, then x),
    negative coordinates included."""
    rng = np.random.default_rng(spread)
    cells = rng.integers(-spread, spread, size=(500, 2)) + np.array([-2 ** 20, 7])
    expected = sorted({(int(x), int(y)) for x, y in cells}, key=lambda c: (c[1], c[0]))
    keys = unique_keys(cells)
    assert [tuple(c) for c in key_cells(keys)] == expected
    assert np.all(np.diff(keys) > 0)
    assert unique_keys(np.zeros((0, 2), int)).shape == (0,)


def test_fixed_points_read_what_sample_reads_as_the_grid_grows():
    """Points inside, outside and on cell edges, read on an empty frame, then after it grew
    twice (the window moves, so the kept indices must be found again): each read equals
    ``GridFrame.sample`` at the same points, value for value."""
    rng = np.random.default_rng(3)
    xy = np.vstack([rng.uniform(-6, 6, size=(300, 2)), [[0.0, 0.0], [0.1, -0.2], [2.9, 2.9]]])
    points, f = FixedPoints(xy), GridFrame(0.1)
    assert np.all(points.sample(f, np.zeros(f.shape)) == 0.5)
    for lo, hi in [((-5, -5), (5, 5)), ((-40, -8), (3, 30))]:
        f.ensure(np.array(lo), np.array(hi))
        grid = rng.random(f.shape)
        np.testing.assert_array_equal(points.sample(f, grid), f.sample(grid, xy))
        np.testing.assert_array_equal(points.sample(f, grid, outside=-1.0), f.sample(grid, xy, outside=-1.0))
        # turned 30° about the origin, then shifted: read at the moved points
        c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
        moved = np.column_stack([c * xy[:, 0] - s * xy[:, 1] + 0.7, s * xy[:, 0] + c * xy[:, 1] - 1.3])
        np.testing.assert_array_equal(points.sample(f, grid, moved=(np.pi / 6, np.array([0.7, -1.3]))),
                                      f.sample(grid, moved))
        np.testing.assert_array_equal(points.sample(f, grid), f.sample(grid, xy))
