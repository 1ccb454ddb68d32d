"""Small worlds for closed-loop run tests."""

import numpy as np

from sim.world import World


def two_rooms() -> World:
    """10 m x 6 m, walls around, a dividing wall with a 1.2 m door, a block in the right room."""
    res = 0.05
    grid = np.zeros((120, 200), dtype=bool)
    grid[:4], grid[-4:], grid[:, :4], grid[:, -4:] = True, True, True, True
    grid[:, 98:102] = True
    grid[48:72, 98:102] = False          # the door, y in [2.4, 3.6)
    grid[70:90, 150:170] = True          # a 1 m block at x in [7.5, 8.5), y in [3.5, 4.5)
    return World(grid, (res, res), name="two_rooms")
