"""What the hits say about a frontier region: whether it is an opening in a wall.

A door seen edge-on and the stretch of a grazed wall between two of its hits both leave a
frontier region as long as a door, free cells beside unknown space. The laser's endpoints tell
them apart: a beam ended in a grazed wall's cells (``holding_hits``), and a door lies in a gap
of a wall's line, the wall running on along that line either side of it (``in_a_wall_gap``),
or flush with a corner, where beams crossed the wall's line into the room behind
(``across_a_corner``).
Beams through a door also leave a longer region, the edge of the wedge they crossed past it,
running from the gap between its jambs into the room (``seen_through_a_gap``).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.spatial import cKDTree


def holding_hits(hits: np.ndarray, origin, resolution: float, shape: tuple[int, int]) -> np.ndarray:
    """(h, w) bool, the cells of a grid (cell (0, 0)'s centre at ``origin``) that hold one of
    ``hits`` (k, 2), meters."""
    held = np.zeros(shape, dtype=bool)
    cells = np.round((np.asarray(hits, float) - np.asarray(origin, float)) / resolution).astype(int)
    h, w = shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < w) & (cells[:, 1] >= 0) & (cells[:, 1] < h)
    held[cells[inside, 1], cells[inside, 0]] = True
    return held


def hits_near(hits: np.ndarray, points: np.ndarray, distance: float) -> np.ndarray:
    """(m, 2) those of ``hits`` (k, 2) in the box of ``points`` (n, 2) widened by ``distance``
    (all within ``distance`` of a point, in their order): a tree of them answers the
    questions below about the points as one of all the hits does, when the hits are read in
    their order (``return_sorted``), for a fraction of the building's cost (a tree of
    office_g's 770 000 hits took 0.1 s)."""
    low, high = points.min(axis=0) - distance, points.max(axis=0) + distance
    x, y = hits[:, 0], hits[:, 1]
    return hits[(x >= low[0]) & (x <= high[0]) & (y >= low[1]) & (y <= high[1])]


def in_a_wall_gap(points: np.ndarray, hits: cKDTree, reach: float, tolerance: float,
                  side: float) -> bool:
    """Does the region ``points`` (k, 2), meters, lie in a gap of a wall's line? The line is
    the principal direction, through their mean, of the hits within ``reach`` m of one of the
    region's ends, or the line that most of those within ``2 * reach`` m hold (``_wall_line``,
    a band ``tolerance`` m wide): by a door's end, the hits within ``reach`` mix the wall's
    face with the jamb's across it, and their line tilts off the wall (lab_a: by 7.5 and 11.5
    degrees, leaving within 0.2 m of a 0.6 m door a wall that runs on for metres; the longer
    line tilts by 1.0 and 0.3 degrees). The region's span on it must be at least ``side`` m
    long (a region across the line is not in it); the hits within ``tolerance`` m of the line,
    out to ``2 * reach`` m of the region, must run along it for at least ``side`` m either side
    of that span (a face across the line is no wall along it), and none lie within it
    (farther than ``tolerance`` from its ends). A door seen edge-on lies so, or its frontier
    runs off into the room past it; the unseen stretch of a block's face that ends in a
    concave corner has the face across it under its end, and a step between two offset faces
    has each face on one side only. The span is read from the region's cells within
    ``tolerance`` of the line as well as from all of them: beams through a door seen edge-on
    free cells on past its far jamb, beside the wall beyond it (held-out building_0027: 0.3 m
    under the 0.45 m of wall to the corridor's corner), and the whole region's span holds the
    jamb's hits. An end with fewer than three hits within ``reach``, or those in no line, says
    nothing; with nothing said at either end, the region is taken for a door."""
    ends = _ends(points)
    if ends is None:
        return True
    around = np.unique(np.concatenate([np.asarray(k, dtype=np.intp)
                                       for k in hits.query_ball_point(points, 2 * reach)]))
    said = False
    for end in ends:
        near = hits.data[hits.query_ball_point(end, reach, return_sorted=True)]
        direction = _direction(near) if len(near) >= 3 else None
        if direction is None:
            continue
        said = True
        wall = hits.data[around]
        if _in_gap(points, wall, near.mean(axis=0), direction, tolerance, side):
            return True
        centre, direction = _wall_line(hits.data[hits.query_ball_point(end, 2 * reach, return_sorted=True)],
                                       tolerance)
        if _in_gap(points, wall, centre, direction, tolerance, side):
            return True
    return not said


def across_a_corner(points: np.ndarray, hits: cKDTree, reach: float, side: float,
                    free_near: Callable[[np.ndarray, float], np.ndarray]) -> bool:
    """Does the region ``points`` (k, 2), meters, lie in a door at a corner: between the end
    of a wall's line (the hits within ``reach`` m of one of its ends) and a face across that
    line (the hits within ``reach`` m of its other end, at 45 degrees or more to it), the
    region or the face's hits reaching past the wall's line, by more than ``side`` m, on the
    side with less free space within ``2 * reach`` m of the region (``free_near(centre,
    radius)``: the (m, 2) free cells' centres there)? Beams crossed the wall's line through the
    gap into the space beyond it: their free cells' edge is the region, and where they ended
    on the face across lie its hits past the line. A door seen from along a corridor is crossed
    at a slant, and its beams free few cells past the line before they end on the face across
    (held-out building_0020: the edge 0.1-0.2 m past the line, the hits 0.27 m).

    A door flush with a corner of its room is no gap of a wall's line (``in_a_wall_gap``): past
    its far jamb the line meets the face across it, not more wall. Seen from the next room, a
    few beams cross the door's line into the room behind, and the door-long frontier they
    leave lies past that line (generated offices, ``sim.buildings``: rooms of 5-27 m² whose one
    door was flush in a corner were left in 5 of 16 runs). The unseen stretch of a block's face
    that ends in a concave corner has the same face across its line, but no beam crossed that
    line: its frontier lies on the near side, where the free space is. A step between two
    offset faces has no face across the line. A face's line is read from its last hits, and a
    scanned face bends: lab_a's slanted face, unseen for its last metre down to a wall across
    it, bent 0.18 m past the line of its seen end, and its GP run (seed 1) drove 40 m to look
    behind it, so a door's beams must cross the line by more than ``side`` (the robot's radius;
    the beams through building_0000's corner door, 0.4 m). The wall across lab_a's face was
    seen 0.40 m past that line, so by its hits the face reads as a door and a robot goes to
    look: a trip, where reading the region alone left held-out building_0020's room. A face
    that stands upright where it was seen and slants away unseen down to the wall across it
    still reads as such a door (lab_a, GP seed 2: 0.38 m past the upright line): from the
    room, its hits and its frontier are a corner door's."""
    ends = _ends(points)
    if ends is None:
        return False
    free = None
    for end, other in (ends, ends[::-1]):
        wall = hits.data[hits.query_ball_point(end, reach, return_sorted=True)]
        face = hits.data[hits.query_ball_point(other, reach, return_sorted=True)]
        line = _direction(wall) if len(wall) >= 3 else None
        across = _direction(face) if len(face) >= 3 else None
        if line is None or across is None or abs(line @ across) > math.cos(math.radians(45.0)):
            continue
        free = free_near(points.mean(axis=0), 2 * reach) if free is None else free
        normal, on = np.array([-line[1], line[0]]), wall.mean(axis=0)
        sides = np.sign((free - on) @ normal)
        beyond = -1.0 if np.count_nonzero(sides > 0) > np.count_nonzero(sides < 0) else 1.0
        if max(np.max(beyond * ((points - on) @ normal)), np.max(beyond * ((face - on) @ normal))) > side:
            return True
    return False


def seen_through_a_gap(points: np.ndarray, hits: cKDTree, door: float, side: float, tolerance: float,
                       free_near: Callable[[np.ndarray, float], np.ndarray]) -> bool:
    """Does the region ``points`` (k, 2), meters, run from a gap between two jambs into the
    space past it, as the edge of a wedge of beams seen through a door? One of its ends lies
    between the hit nearest it and the nearest on its far side (at least 120 degrees round from
    the first), ``2 * side`` to ``door`` m apart with no hit between them (farther than
    ``tolerance`` from both, within it of the line joining them), and its other end lies
    ``2 * side`` m or more from the gap, off its line (by ``tolerance`` or more) on the side
    with less free space within ``door`` m of the gap's middle (``free_near(centre, radius)``:
    the (m, 2) free cells' centres there): past the gap lies a wedge of beams, before it the
    space they were cast from. A door seen edge-on leaves a wedge that runs nearly along the
    line of its jambs, and more so where they are offset (office_d: a 0.85 m door whose jambs
    stood 0.23 m apart across the wall, a wedge 3.5 m long whose far end lay 0.43 m off that
    line; the run stopped with the 30 m² room behind it unseen). A frontier running from a gap
    between a wall's hits back into the room it was seen from is no door.
    A door at a room's corner, where the corridor's wall and the room's meet offset or across
    each other, is no gap of a wall's line (``in_a_wall_gap``): lab_a's and lab_e's GP runs saw
    rooms through 0.55 m doors so, as wedges of beams whose frontier ran 1.3-1.5 m into them.
    The unseen stretch of a face between its end and a face across it, or a step between two
    offset faces, runs along the line joining its ends' hits; a block's corner has no jamb
    across from it."""
    ends = _ends(points)
    if ends is None:
        return False
    for end, other in (ends, ends[::-1]):
        near = hits.data[hits.query_ball_point(end, door, return_sorted=True)]
        if len(near) < 2:
            continue
        away = near - end
        length = np.linalg.norm(away, axis=1)
        first = int(np.argmin(length))
        cos = away @ away[first] / np.maximum(length * length[first], 1e-12)
        across = np.flatnonzero(cos <= -0.5)
        if not len(across):
            continue
        second = across[np.argmin(length[across])]
        a, b = near[first], near[second]
        width = float(np.linalg.norm(b - a))
        if not 2 * side <= width <= door:
            continue
        chord = (b - a) / width
        normal = np.array([-chord[1], chord[0]])
        t, off = (near - a) @ chord, np.abs((near - a) @ normal)
        if np.any((off <= tolerance) & (t > tolerance) & (t < width - tolerance)):
            continue
        past = (other - a) @ normal
        beyond = np.linalg.norm(other - (a + min(max((other - a) @ chord, 0.0), width) * chord))
        if abs(past) < tolerance or beyond < 2 * side:
            continue
        middle = (a + b) / 2
        sides = np.sign((free_near(middle, door) - middle) @ normal)
        if np.count_nonzero(sides == np.sign(past)) < np.count_nonzero(sides == -np.sign(past)):
            return True
    return False


def _wall_line(hits: np.ndarray, width: float) -> tuple[np.ndarray, np.ndarray]:
    """(centre, direction), each (2,): the line of the most of ``hits`` (k, 2), meters, that a
    band ``width`` m wide holds (directions every degree), through their mean along their
    principal direction."""
    best, held_by, band = -1, hits, np.array([1.0, 0.0])
    for angle in np.radians(np.arange(0.0, 180.0, 1.0)):
        offset = hits @ np.array([-math.sin(angle), math.cos(angle)])
        order = np.sort(offset)
        held = np.searchsorted(order, order + width, side="right") - np.arange(len(order))
        first = int(np.argmax(held))
        if held[first] > best:
            best, band = held[first], np.array([math.cos(angle), math.sin(angle)])
            held_by = hits[(offset >= order[first]) & (offset <= order[first] + width)]
    direction = _direction(held_by)
    return held_by.mean(axis=0), band if direction is None else direction


def _in_gap(points: np.ndarray, hits: np.ndarray, centre: np.ndarray, direction: np.ndarray,
            tolerance: float, side: float) -> bool:
    """Does the region ``points`` (k, 2), or its points within ``tolerance`` m of the line
    through ``centre`` along ``direction``, span at least ``side`` m of that line, with
    ``hits`` (m, 2) within ``tolerance`` m of the line running along it for ``side`` m either
    side of the span and none within it? Meters."""
    def on_line(xy: np.ndarray) -> np.ndarray:
        offset = xy - centre
        return np.abs(offset[:, 0] * direction[1] - offset[:, 1] * direction[0]) <= tolerance

    at = (hits[on_line(hits)] - centre) @ direction
    span = (points - centre) @ direction
    on = on_line(points)
    for along in (span, span[on]) if 0 < np.count_nonzero(on) < len(on) else (span,):
        low, high = along.min(), along.max()
        before, after = at[at < low], at[at > high]
        inside = (at > low + tolerance) & (at < high - tolerance)
        if (high - low >= side and not inside.any() and len(before) and len(after)
                and np.ptp(before) >= side and np.ptp(after) >= side):
            return True
    return False


def _ends(points: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The two points of ``points`` (k, 2) farthest apart along their principal direction;
    None when they have none (``_direction``)."""
    axis = _direction(points)
    if axis is None:
        return None
    along = (points - points.mean(axis=0)) @ axis
    return points[np.argmin(along)], points[np.argmax(along)]


def _direction(points: np.ndarray) -> np.ndarray | None:
    """(2,) the unit principal direction of ``points`` (k, 2); None when they spread as much
    across it as along it (no line)."""
    if len(points) < 2:
        return None
    values, vectors = np.linalg.eigh(np.cov(np.asarray(points, float).T))
    if values[1] <= 0 or values[0] > 0.25 * values[1]:
        return None
    return vectors[:, 1]
