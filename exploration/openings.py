"""What the hits say about a door-long frontier region: whether it is an opening in a wall.

A door seen edge-on and the stretch of a grazed wall between two of its hits both leave a frontier
region as long as a door, free cells beside unknown space. The laser's endpoints tell them apart:
a beam ended in a grazed wall's cells (``holding_hits``), and the unseen stretch of a block's face that ends in
a concave corner continues that face's line up to a face across it (``unseen_end_of_a_face``),
where a door lies between its jambs' walls or past them.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

#: Degrees between two faces' lines beyond which they meet in a corner
CORNER = 45.0


def holding_hits(hits: np.ndarray, origin, resolution: float, shape: tuple[int, int]) -> np.ndarray:
    """(h, w) bool, the cells of a grid (cell (0, 0)'s centre at ``origin``) that hold one of
    ``hits`` (k, 2), meters."""
    held = np.zeros(shape, dtype=bool)
    cells = np.round((np.asarray(hits, float) - np.asarray(origin, float)) / resolution).astype(int)
    h, w = shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < w) & (cells[:, 1] >= 0) & (cells[:, 1] < h)
    held[cells[inside, 1], cells[inside, 0]] = True
    return held


def unseen_end_of_a_face(points: np.ndarray, hits: cKDTree, reach: float, tolerance: float) -> bool:
    """Is the region ``points`` (k, 2), meters, the unseen end of a face that meets another in
    a concave corner: the hits within ``reach`` m of one of its ends run in a line whose
    continuation holds every point of the region (within ``tolerance`` m), and those by its
    other end run across that line (more than ``CORNER`` degrees off it)? A door's region
    lies in the line of its jambs' walls, or past it where beams went through. An end with
    fewer than three hits near it, or hits in no line, says nothing."""
    axis = _direction(points)
    if axis is None:
        return False
    along = (points - points.mean(axis=0)) @ axis
    lines = []
    for end in (points[np.argmin(along)], points[np.argmax(along)]):
        near = hits.data[hits.query_ball_point(end, reach)]
        direction = _direction(near) if len(near) >= 3 else None
        lines.append(None if direction is None else (near.mean(axis=0), direction))
    for face, other in (lines, lines[::-1]):
        if face is None or other is None:
            continue
        centre, direction = face
        offset = points - centre
        off_line = np.abs(offset[:, 0] * direction[1] - offset[:, 1] * direction[0])
        if off_line.max() <= tolerance and abs(float(other[1] @ direction)) < math.cos(math.radians(CORNER)):
            return True
    return False


def _direction(points: np.ndarray) -> np.ndarray | None:
    """(2,) the unit principal direction of ``points`` (k, 2); None when they spread as much
    across it as along it (no line)."""
    if len(points) < 2:
        return None
    values, vectors = np.linalg.eigh(np.cov(np.asarray(points, float).T))
    if values[1] <= 0 or values[0] > 0.25 * values[1]:
        return None
    return vectors[:, 1]
