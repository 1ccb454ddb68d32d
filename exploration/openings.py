"""What the hits say about a door-long frontier region: whether it is an opening in a wall.

A door seen edge-on and the stretch of a grazed wall between two of its hits both leave a frontier
region as long as a door, free cells beside unknown space. The laser's endpoints tell them apart:
a beam ended in a grazed wall's cells (``holding_hits``), and a door lies in a wall's line, its
jambs' walls running along it, where the unseen stretch of a block's face that ends in a concave
corner meets a face across it (``in_a_wall_line``).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

#: Degrees between a jamb's wall and the opening's line beyond which the two meet in a corner
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


def in_a_wall_line(points: np.ndarray, hits: cKDTree, reach: float) -> bool:
    """Do the hits within ``reach`` m of each end of the region ``points`` (k, 2), meters, run
    along the region's line (within ``CORNER`` degrees), as a wall's either side of its door
    do? An end with fewer than three hits near it, or hits in no line, says nothing."""
    axis = _direction(points)
    if axis is None:
        return True
    along = (points - points.mean(axis=0)) @ axis
    for end in (points[np.argmin(along)], points[np.argmax(along)]):
        near = hits.data[hits.query_ball_point(end, reach)]
        wall = _direction(near) if len(near) >= 3 else None
        if wall is not None and abs(float(wall @ axis)) < math.cos(math.radians(CORNER)):
            return False
    return True


def _direction(points: np.ndarray) -> np.ndarray | None:
    """(2,) the unit principal direction of ``points`` (k, 2); None when they spread as much
    across it as along it (no line)."""
    if len(points) < 2:
        return None
    values, vectors = np.linalg.eigh(np.cov(np.asarray(points, float).T))
    if values[1] <= 0 or values[0] > 0.25 * values[1]:
        return None
    return vectors[:, 1]
