"""Door-long frontier regions read against the hits: an opening in a wall, or a grazed surface."""

import numpy as np
from scipy.spatial import cKDTree

from exploration.openings import holding_hits, unseen_end_of_a_face

STEP = 0.05                 # a hit every 5 cm along a wall
TOLERANCE = 0.1 * np.sqrt(2)  # a 0.1 m cell's diagonal


def wall(start, end):
    """(k, 2) hits every ``STEP`` m from ``start`` to ``end`` (m)."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    n = int(round(np.linalg.norm(end - start) / STEP)) + 1
    return start + np.linspace(0.0, 1.0, n)[:, None] * (end - start)


def region(x, y0, y1):
    """(k, 2) the centres of 0.1 m cells along x = ``x`` from ``y0`` to ``y1`` (m)."""
    return np.column_stack([np.full(int(round((y1 - y0) / 0.1)) + 1, x), np.arange(y0, y1 + 1e-9, 0.1)])


def test_a_gap_in_a_straight_wall_is_a_door():
    """A wall along x = 0 with a 0.8 m gap (y 2.0-2.8 m): its frontier continues the wall's
    line either side, but the hits by both of its ends run along it."""
    hits = cKDTree(np.vstack([wall((0, 0), (0, 2.0)), wall((0, 2.8), (0, 5))]))
    assert not unseen_end_of_a_face(region(0.0, 2.1, 2.7), hits, 0.5, TOLERANCE)


def test_the_unseen_end_of_a_face_meeting_a_face_across_it_is_a_corner():
    """A face along x = 0 down to y = 2.8 m, unseen from there to the face along y = 2.0 m it
    meets in a concave corner at (0, 2): the frontier continues the upper face's line, and the
    hits by its lower end run across it, at 90 degrees (at 30 degrees, that face would be the
    first's continuation)."""
    face = wall((0, 2.8), (0, 5))
    across = cKDTree(np.vstack([face, wall((0, 2.0), (2.0, 2.0))]))
    assert unseen_end_of_a_face(region(0.0, 2.1, 2.7), across, 0.5, TOLERANCE)
    slant = 2.0 * np.array([np.sin(np.radians(30)), -np.cos(np.radians(30))])
    slanted = cKDTree(np.vstack([face, wall((0, 2.0), slant + (0, 2.0))]))
    assert not unseen_end_of_a_face(region(0.0, 2.1, 2.7), slanted, 0.5, TOLERANCE)


def test_a_door_beside_a_corner_is_seen_past_the_face_s_line():
    """A door 0.8 m wide in a wall along y = 2 m, between the corner where a wall along
    x = 0 rises from it and the wall's end at x = 0.8 m: beams through the door left a frontier
    running from (0.05, 2.5) to (0.75, 2.05) in the room past it. The hits by its ends run
    across each other, but the frontier continues neither wall's line: a door."""
    hits = cKDTree(np.vstack([wall((0, 2.0), (0, 5)), wall((0.8, 2.0), (3, 2.0)), wall((-3, 2.0), (0, 2.0))]))
    t = np.linspace(0.0, 1.0, 8)[:, None]
    points = np.array([0.05, 2.5]) + t * np.array([0.7, -0.45])
    assert not unseen_end_of_a_face(points, hits, 0.5, TOLERANCE)


def test_an_end_without_a_wall_line_says_nothing():
    """Two hits by the lower end (fewer than three) and a line by the upper one: no corner."""
    hits = cKDTree(np.vstack([[[0.3, 2.0], [0.6, 2.0]], wall((0, 2.8), (0, 5))]))
    assert not unseen_end_of_a_face(region(0.0, 2.1, 2.7), hits, 0.5, TOLERANCE)


def test_cells_holding_hits():
    """Hits round to their cells' centres; those off the grid are left out."""
    held = holding_hits(np.array([[0.04, 0.06], [0.26, 0.14], [5.0, 0.0], [-0.2, 0.0]]),
                        (0.0, 0.0), 0.1, (3, 4))
    assert np.array_equal(np.argwhere(held), [[1, 0], [1, 3]])
