"""A run folder read back: its map for `gpexplore figures`."""

import numpy as np

from mapping.export import write_ros_map
from sim.results import read_run_map


def test_a_grid_runs_map_is_read_back_from_map_yaml_over_the_same_extent(tmp_path):
    """A grid run has no com.npz: map.pgm/yaml give its map, free 0, occupied 1, unknown 0.5."""
    prob = np.full((4, 6), 0.5)
    prob[1, 2], prob[2, 4] = 0.05, 0.9
    origin, resolution = np.array([-1.0, 2.0]), 0.1                      # the centre of cell (0, 0)
    write_ros_map(tmp_path / "map.pgm", prob, origin, resolution)
    read, extent = read_run_map(tmp_path)
    expected = np.full((4, 6), 0.5)
    expected[1, 2], expected[2, 4] = 0.0, 1.0
    np.testing.assert_array_equal(read, expected)
    np.testing.assert_allclose(extent, (-1.05, -0.45, 1.95, 2.35))
