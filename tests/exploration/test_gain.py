"""The stop's look round: unknown area visible from a goal, against geometry."""

import numpy as np
import pytest

from exploration.gain import visible_unknown_area

RES = 0.1


def closed_room(pocket=None):
    """A known-free 6 m x 6 m room (cells 10-69) inside a one-cell wall, unknown outside;
    ``pocket``: (rows, cols) left unknown inside the room."""
    prob = np.full((80, 80), 0.5)
    prob[9:71, 9:71] = 0.9
    prob[10:70, 10:70] = 0.1
    if pocket is not None:
        prob[pocket] = 0.5
    return prob


def test_a_closed_known_room_shows_nothing():
    assert visible_unknown_area(closed_room(), (0.0, 0.0), RES, (4.0, 4.0), 8.0, 0.65) == 0.0


def test_a_pocket_in_plain_view_shows_its_area():
    """A 1 m x 0.5 m unknown pocket (10 x 5 cells) 1.5 m from the goal, nothing between: every
    cell of it is crossed by some ray (1 degree apart: under 4 cm at 2 m), so its 0.5 m²."""
    pocket = (slice(50, 55), slice(50, 60))
    area = visible_unknown_area(closed_room(pocket), (0.0, 0.0), RES, (4.0, 3.5), 8.0, 0.65)
    assert area == pytest.approx(0.5, abs=1e-9)


def test_a_wall_hides_what_is_behind_it_and_range_bounds_the_rest():
    """A door-less wall: the unknown outside is not seen. Open the room's right wall: the
    unknown beyond it is seen up to 8 m, a region bounded by the circle of radius 8 m about the
    goal, less the room; at most π 8² - 36 m², at least the 6 m wide strip 2 m deep beyond."""
    prob = closed_room()
    prob[10:70, 70] = 0.5                  # the right wall was never seen: unknown
    area = visible_unknown_area(prob, (0.0, 0.0), RES, (4.0, 4.0), 8.0, 0.65)
    assert 6 * 2 < area < np.pi * 8**2 - 36
    assert visible_unknown_area(prob, (0.0, 0.0), RES, (4.0, 4.0), 2.0, 0.65) == 0.0   # 3 m to the wall


def test_a_diagonal_wall_has_no_gap():
    """The room's bottom-right corner cut off by a staircase wall of cells that touch only at
    their corners (one per row and column: the hits of a 45-degree wall), unknown past it: a
    ray stepping between two such cells meets wall on both sides and sees nothing past it.
    The same staircase with every other cell missing (a real gap at each step) shows the
    unknown behind it."""
    prob = closed_room()
    tile = prob[10:30, 50:70]                        # a view: x 5.0-6.9 m, y 1.0-2.9 m
    tile[:] = 0.5
    tile[np.tri(20, 20, -1, dtype=bool)] = 0.1       # the room's side of the diagonal
    np.fill_diagonal(tile, 0.9)
    assert visible_unknown_area(prob, (0.0, 0.0), RES, (4.0, 4.0), 8.0, 0.65) == 0.0
    tile[np.arange(0, 20, 2), np.arange(0, 20, 2)] = 0.5
    assert visible_unknown_area(prob, (0.0, 0.0), RES, (4.0, 4.0), 8.0, 0.65) > 0.5
