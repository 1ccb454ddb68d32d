"""Door-long frontier regions read against the hits: an opening in a wall, or a grazed surface."""

import math

import numpy as np
from scipy.spatial import cKDTree

from exploration.frontier_methods import cells_within
from exploration.openings import across_a_corner, hits_near, holding_hits, in_a_wall_gap, seen_through_a_gap

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


def door(hits, points):
    return in_a_wall_gap(points, cKDTree(hits), 0.5, TOLERANCE, 0.25)


def test_the_hits_near_a_region_say_what_all_the_hits_say():
    """Each region of the tests here, with its walls among 20 000 hits scattered over a
    40 m x 40 m building: read in a tree of the hits within twice the reach of its box
    (``hits_near``, every hit within that distance of a point, in order), the answer is the
    one a tree of all the hits gives."""
    rng = np.random.default_rng(0)
    clutter = rng.uniform(-20, 20, size=(20000, 2))
    clutter = clutter[np.hypot(*clutter.T) > 6]
    cases = [(np.vstack([wall((0, 0), (0, 2.0)), wall((0, 2.8), (0, 5))]), region(0.0, 2.1, 2.7)),
             (np.vstack([wall((0, 2.8), (0, 5)), wall((0, 2.0), (2.0, 2.0))]), region(0.0, 2.1, 2.7)),
             (np.vstack([wall((-2.0, 2.0), (0, 2.0)), wall((0.6, 2.5), (2.6, 2.5))]),
              np.array([0.05, 2.05]) + np.linspace(0.0, 1.0, 7)[:, None] * np.array([0.5, 0.4]))]
    answers = []
    for walls, points in cases:
        hits = np.vstack([clutter[:len(clutter) // 2], walls, clutter[len(clutter) // 2:]])
        near = hits_near(hits, points, 1.0)
        inside = np.all((hits >= points.min(axis=0) - 1.0) & (hits <= points.max(axis=0) + 1.0), axis=1)
        np.testing.assert_array_equal(near, hits[inside])
        assert len(near) < len(hits) // 100
        answers.append(door(hits, points))
        assert in_a_wall_gap(points, cKDTree(near), 0.5, TOLERANCE, 0.25) == answers[-1]
    assert answers == [True, False, False]


def test_a_gap_in_a_straight_wall_is_a_door():
    """A wall along x = 0 with a 0.8 m gap (y 2.0-2.8 m): the frontier lies in the gap."""
    hits = np.vstack([wall((0, 0), (0, 2.0)), wall((0, 2.8), (0, 5))])
    assert door(hits, region(0.0, 2.1, 2.7))


def test_a_door_whose_frontier_runs_on_past_its_far_jamb_is_a_door():
    """A wall along x = 0 with a 0.9 m door (y 2.0-2.9 m), 0.45 m of wall past it (a 0.15 m
    thick stub, its end seen through the door) to a face across at y = 3.35 m, as held-out
    building_0027's door was seen edge-on from along the corridor (x < 0): the beams freed cells
    in the doorway and on past the jamb, stepping off the line under the stub. The whole
    region's span along the line holds the stub's hits; its cells on the line lie in the gap."""
    hits = np.vstack([wall((0, 0), (0, 2.0)), wall((0, 2.9), (0, 3.35)), wall((0, 2.9), (0.15, 2.9)),
                      wall((0, 3.35), (-2.0, 3.35))])
    points = np.vstack([region(0.0, 2.05, 2.45), region(0.1, 2.55, 2.65), region(0.2, 2.75, 3.15)])
    assert door(hits, points)
    assert not door(hits, points[points[:, 1] > 2.5])      # its part under the stub alone


def test_the_unseen_end_of_a_face_meeting_a_face_across_it_is_no_door():
    """A face along x = 0 down to y = 2.8 m, unseen from there to the face along y = 2.0 m
    that it meets in a concave corner at (0, 2), that face running on beyond the corner or not:
    along x = 0 nothing but the face across lies below the gap, and along y = 2 the face runs
    under the frontier's end or on one side of it only."""
    face = wall((0, 2.8), (0, 5))
    for across in (wall((0, 2.0), (2.0, 2.0)), wall((-2.0, 2.0), (2.0, 2.0))):
        assert not door(np.vstack([face, across]), region(0.0, 2.1, 2.7))


def test_a_step_between_two_offset_faces_is_no_door():
    """Faces along y = 2.0 m (x < 0) and y = 2.5 m (x > 0.6 m) with the frontier running
    between their ends: each face's line has wall on one side of it only."""
    hits = np.vstack([wall((-2.0, 2.0), (0, 2.0)), wall((0.6, 2.5), (2.6, 2.5))])
    t = np.linspace(0.0, 1.0, 7)[:, None]
    assert not door(hits, np.array([0.05, 2.05]) + t * np.array([0.5, 0.4]))


def test_a_door_beside_a_corner_is_a_door():
    """A door 0.8 m wide in a wall along y = 2 m, between the corner where a wall along x = 0
    rises from it and the wall's end at x = 0.8 m: beams through the door left a frontier
    running from (0.05, 2.5) to (0.75, 2.05) in the room past it. Along y = 2 the wall runs on
    either side of the door."""
    hits = np.vstack([wall((0, 2.0), (0, 5)), wall((0.8, 2.0), (3, 2.0)), wall((-3, 2.0), (0, 2.0))])
    t = np.linspace(0.0, 1.0, 8)[:, None]
    assert door(hits, np.array([0.05, 2.5]) + t * np.array([0.7, -0.45]))


def cells(x0, x1, y0, y1):
    """(k, 2) the centres of 0.1 m cells in the box, meters."""
    x, y = np.meshgrid(np.arange(x0, x1 + 1e-9, 0.1), np.arange(y0, y1 + 1e-9, 0.1))
    return np.column_stack([x.ravel(), y.ravel()])


#: The free space the beams were cast from: a corridor below y = 1.8 m
CORRIDOR = cells(-3.0, 4.0, 0.5, 1.7)


def through(hits, points, free=CORRIDOR):
    """``seen_through_a_gap`` with the free cells ``free`` (k, 2) and the region's own."""
    free = np.vstack([free, points])

    def free_near(centre, radius):
        return free[np.linalg.norm(free - centre, axis=1) <= radius]

    return seen_through_a_gap(points, cKDTree(hits), 1.0, 0.25, TOLERANCE, free_near)


def line(start, end, step=0.1):
    """(k, 2) cell centres every ``step`` m from ``start`` to ``end`` (m)."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    n = int(round(np.linalg.norm(end - start) / step)) + 1
    return start + np.linspace(0.0, 1.0, n)[:, None] * (end - start)


def corner_door(gap):
    """lab_a's room: a corridor's wall along y = 1.8 m up to x = 0, the room's wall along
    x = 0 from y = 2.2 m up, and the room's front wall along y = 2.0 m from x = ``gap`` on:
    the door, ``gap`` m wide, meets the corner; the two walls along it are 0.2 m apart."""
    return np.vstack([wall((-3, 1.8), (0, 1.8)), wall((0, 2.2), (0, 5)), wall((gap, 2.0), (4, 2.0))])


#: The room the beams were cast from: x > 0
ROOM = cells(0.1, 3.0, 0.1, 3.0)


def at_a_corner(hits, points, free=ROOM):
    """``across_a_corner`` with the free cells ``free`` (k, 2) and the region's own."""
    free = np.vstack([free, points])
    return across_a_corner(points, cKDTree(hits), 0.5, 0.25,
                           lambda centre, radius: free[np.linalg.norm(free - centre, axis=1) <= radius])


def test_a_door_flush_with_a_corner_is_a_door_at_a_corner():
    """A wall along x = 0 down to y = 1.0 m, and the face along y = 0 across its line: the
    door between them, 1 m wide, is flush with the corner. Beams from the room at x > 0 crossed
    the wall's line into the room behind, and their frontier runs from the wall's end down to
    the face 0.35 m past the line. Along x = 0 no wall runs on past the door."""
    hits = np.vstack([wall((0, 1.0), (0, 5)), wall((-3, 0), (3, 0))])
    points = line((-0.05, 0.95), (-0.35, 0.15))
    assert at_a_corner(hits, points)
    assert not door(hits, points)


def test_the_unseen_end_of_a_face_at_a_concave_corner_is_not_a_door_at_a_corner():
    """The face along x = 0 unseen from y = 1.0 m down to the corner, where the face along
    y = 0 ends (past the corner lies the block's inside, which no beam reaches): its frontier
    lies on the room's side of the line, where the free space is; and a frontier past the line
    of a face whose other end meets no face across it (a step to a face along x = -0.4 m) is no
    door at a corner either."""
    hits = np.vstack([wall((0, 1.0), (0, 5)), wall((0, 0), (3, 0))])
    assert not at_a_corner(hits, region(0.05, 0.1, 0.9))
    step = np.vstack([wall((0, 1.0), (0, 5)), wall((-0.4, -3), (-0.4, 0.6))])
    assert not at_a_corner(step, line((-0.1, 0.95), (-0.35, 0.65)))


def test_a_face_bending_off_the_line_of_its_seen_end_is_not_a_door_at_a_corner():
    """lab_a: a face seen along x = 0 from y = 1.0 m up, unseen below, bending 0.18 m past that
    line by the time it meets the face along y = 0, seen up to where the bend meets it: its
    frontier follows the bend, and beams must cross the line by more than the robot's radius
    (0.25 m); the corner door's crossed it by 0.35 m. (lab_a's face across was seen 0.40 m past
    the line, from beyond it: that face reads as a door, and the robot goes to look.)"""
    bent = np.vstack([wall((0, 1.0), (0, 5)), wall((-0.18, 0), (3, 0))])
    assert not at_a_corner(bent, line((-0.02, 0.95), (-0.18, 0.15)))
    door_behind = np.vstack([wall((0, 1.0), (0, 5)), wall((-3, 0), (3, 0))])
    assert at_a_corner(door_behind, line((-0.05, 0.95), (-0.35, 0.15)))


def test_a_corner_door_seen_from_along_a_corridor_is_a_door_at_a_corner():
    """Held-out building_0020: a 0.85 m door flush with the corridor's end wall, seen from 4 m
    along the corridor. The beams crossed the door's line at 15 degrees, and their free cells'
    edge lies 0.1-0.2 m past it, less than the robot's radius; but they ended on the end wall
    0.27 m past it (hits on the face across, behind the line), which no beam reaches round a
    block's concave corner. The GP run stopped with the 10.6 m² room behind unseen."""
    hits = np.vstack([wall((0, 0.85), (0, 5)), wall((-0.27, 0), (3, 0))])
    edge = line((-0.1, 0.8), (-0.2, 0.1))
    assert not at_a_corner(hits[hits[:, 0] >= 0], edge)
    assert at_a_corner(hits, edge)


def test_the_free_space_behind_a_wall_does_not_decide_a_corner_door_s_side():
    """building_0008's GP run: a robot in a passage (x < 0) beside a wall along x = 0 looked
    down through a 0.85 m door flush with the corner of the room's front wall along y = 0, and
    saw a wedge of the room past it (x > 0). Behind the front wall runs a corridor (y < 0),
    most of it under the room. Within a metre of the wedge's edge, the free cells on the
    room's side (the wedge and the corridor) outnumber the passage's, and the door's side reads
    wrong; counted where they join the region (``cells_within``'s ``joined``), the corridor's
    drop out: the beams crossed the wall's line from the passage."""
    res, origin = 0.05, np.array([-3.0, -2.0])
    yy, xx = np.mgrid[0:100, 0:120]
    x, y = origin[0] + res * xx, origin[1] + res * yy
    free = (((x >= -0.8) & (x <= -0.05) & (y >= 0.05) & (y <= 2.0))      # the passage
            | ((x > -0.05) & (y >= 0.05) & (x + y <= 0.85))               # the door and the wedge
            | ((x >= -0.3) & (x <= 2.5) & (y >= -1.0) & (y <= -0.1)))     # the corridor
    hits = np.vstack([wall((0, 0.85), (0, 3)), wall((-3, 0), (3, 0))])
    edge = line((0.05, 0.75), (0.75, 0.05), step=res)
    cells = np.round((edge - origin) / res).astype(int)
    assert free[cells[:, 1], cells[:, 0]].all()

    def at_the_door(joined):
        return across_a_corner(edge, cKDTree(hits), 0.5, 0.25,
                               lambda centre, radius: cells_within(free, origin, res, centre, radius, joined))

    assert not at_the_door(None)
    assert at_the_door(cells)
    near = cells_within(free, origin, res, edge.mean(axis=0), 1.0, cells)
    assert len(near) and np.all(near[:, 1] > 0)
    everything = cells_within(free, origin, res, edge.mean(axis=0), 1.0)
    inside = free[np.linalg.norm(np.stack([x, y], axis=-1) - edge.mean(axis=0), axis=-1) <= 1.0]
    assert len(everything) == inside.sum() > len(near)


def test_a_wedge_of_beams_through_a_door_at_a_room_s_corner_is_seen_through_a_gap():
    """Beams through the door left a wedge of free space whose frontier runs from the front
    wall's end 1.4 m into the room, read from either end."""
    hits, wedge = corner_door(0.75), line((0.65, 2.05), (0.1, 3.4))
    assert through(hits, wedge) and through(hits, wedge[::-1])


def test_a_wedge_of_beams_through_a_door_seen_edge_on_is_seen_through_a_gap():
    """office_d's door: a wall along x = 0 up to y = 0 and on along x = 0.23 m from y = 0.79 m
    (the jambs offset across the wall), seen from the corridor at x < 0 at a grazing angle;
    the wedge's frontier runs from the lower jamb 3.5 m into the room at 22 degrees to the
    wall, its far end 0.37 m off the line of the jambs, 3.3 m past the gap."""
    hits = np.vstack([wall((0, -3.0), (0, 0)), wall((0.23, 0.79), (0.23, 4.0))])
    corridor = cells(-3.0, -0.5, -3.0, 4.0)
    far = 3.5 * np.array([math.sin(math.radians(22)), math.cos(math.radians(22))])
    wedge = line((0.05, 0.05), far)
    assert through(hits, wedge, corridor) and through(hits, wedge[::-1], corridor)
    # the same frontier running back into the corridor it was seen from is no door
    assert not through(hits, line((-0.05, 0.05), far * [-1, 1]), corridor)


def test_a_gap_narrower_than_the_robot_or_wider_than_a_door_is_not_seen_through():
    wedge = line((0.25, 2.05), (0.1, 3.4))
    assert not through(corner_door(0.3), wedge)
    assert not through(corner_door(1.5), line((1.4, 2.05), (0.1, 3.4)))


def test_a_frontier_along_the_line_of_its_jambs_is_not_seen_through():
    """The step between two offset faces, and the unseen stretch of a face between its end
    and a face across it: the frontier runs along the line joining its ends' hits."""
    step = np.vstack([wall((-2.0, 2.0), (0, 2.0)), wall((0.6, 2.5), (2.6, 2.5))])
    assert not through(step, line((0.05, 2.05), (0.55, 2.45)))
    stretch = np.vstack([wall((0, 2.8), (0, 5)), wall((-2.0, 2.0), (2.0, 2.0))])
    assert not through(stretch, region(0.05, 2.1, 2.7))


def test_a_frontier_running_from_a_gap_back_into_the_space_it_was_seen_from_is_not_seen_through():
    """A wall along y = 2 m whose hits leave a 0.7 m gap (grazed, or a door never seen
    through), nothing seen past it, and a frontier running from the gap 1 m back down into the
    corridor: it lies on the side of the gap with the more free space."""
    hits = np.vstack([wall((-3, 2.0), (0, 2.0)), wall((0.7, 2.0), (4, 2.0))])
    free = cells(-3.0, 4.0, 0.5, 1.9)
    assert not through(hits, region(0.35, 0.9, 1.9), free)


def test_the_unseen_face_of_a_block_s_corner_is_not_seen_through():
    """A block's face along y = 2 m seen up to its corner at x = 0; its face along x = 0,
    unseen, leaves a frontier from the corner up: no jamb lies across from the corner."""
    assert not through(wall((0, 2.0), (3, 2.0)), region(-0.05, 2.1, 3.5))


def test_a_door_through_a_thick_wall_whose_jambs_were_seen_is_a_door():
    """A wall along x = 0 to 0.2 m, 0.8 m gap (y 2.0-2.8 m) with the jambs' faces across the
    wall seen along y = 2.0 and y = 2.8: within 0.5 m of the frontier's ends those faces tilt
    the line of the hits off the wall, which runs on either side of the gap."""
    hits = np.vstack([wall((0, 0), (0, 2.0)), wall((0, 2.8), (0, 5)),
                      wall((0, 2.0), (0.2, 2.0)), wall((0, 2.8), (0.2, 2.8))])
    assert door(hits, region(0.1, 2.1, 2.7))


def test_ends_without_a_wall_line_say_nothing():
    """Two hits by one end (fewer than three) and none by the other, or no hit anywhere
    near: a door."""
    assert door(np.array([[0.3, 2.0], [0.6, 2.0], [5.0, 5.0]]), region(0.0, 2.1, 2.7))
    assert door(np.array([[5.0, 5.0]]), region(0.0, 2.1, 2.7))


def test_a_region_partly_out_of_reach_of_every_hit_is_read():
    """A frontier running 1.5 m off a wall along x = 0, its far points more than 1 m from every
    hit: no crash (an empty neighbourhood once made the indices floats), and the wall runs
    across it, not along it: no door."""
    points = np.column_stack([np.linspace(-1.5, 0.0, 8), np.full(8, 1.5)])
    assert not door(wall((0, 0), (0, 3)), points)


def test_cells_holding_hits():
    """Hits round to their cells' centres; those off the grid are left out."""
    held = holding_hits(np.array([[0.04, 0.06], [0.26, 0.14], [5.0, 0.0], [-0.2, 0.0]]),
                        (0.0, 0.0), 0.1, (3, 4))
    assert np.array_equal(np.argwhere(held), [[1, 0], [1, 3]])
