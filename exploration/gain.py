"""What a goal would show: the unknown area a 360-degree look from it would see, ray-cast on the
map the planner reads. The stop test drops frontier clusters that would show less than the
sensitivity asked for, so that a run ends when nothing worth a trip is left instead of driving
to remnants (a few unknown cells in a corner, a speck behind furniture)."""

from __future__ import annotations

import math

import numba
import numpy as np

from mapping.metrics import KNOWN


def visible_unknown_area(prob: np.ndarray, origin, resolution: float, at, sensor_range: float,
                         occupied_above: float, rays: int = 360) -> float:
    """Area (m²) of the unknown cells (``|prob - 0.5| <= KNOWN``, and every cell off the map)
    that ``rays`` rays from ``at`` (2,) (m) cross before an occupied cell (``prob`` above
    ``occupied_above``) or ``sensor_range`` meters, each ray sampled every half cell.
    ``prob`` (h, w) has cell (0, 0)'s centre at ``origin`` (2,), meters."""
    half = int(math.ceil(sensor_range / resolution)) + 1          # cells: the window's half side
    start = (np.asarray(at, float) - np.asarray(origin, float)) / resolution
    seen = np.zeros((2 * half + 1, 2 * half + 1), dtype=np.bool_)
    _cast(np.ascontiguousarray(prob, dtype=np.float64), start[0], start[1],
          sensor_range / resolution, occupied_above, KNOWN, rays, half, seen)
    return float(seen.sum() * resolution**2)


@numba.njit(cache=True)
def _occupied(prob, ix, iy, occupied_above):
    h, w = prob.shape
    return 0 <= ix < w and 0 <= iy < h and prob[iy, ix] > occupied_above


@numba.njit(cache=True)
def _cast(prob, x, y, reach, occupied_above, known, rays, half, seen):
    """Mark in ``seen`` (a window of ``half`` cells about the start's cell) the unknown cells
    the rays from (``x``, ``y``) (cells) cross, each until its first occupied cell, a step
    between two occupied cells that touch at a corner (a diagonal wall has no gap), or
    ``reach`` cells."""
    h, w = prob.shape
    cx, cy = int(round(x)), int(round(y))
    steps = int(reach * 2.0 + 1.0)
    for k in range(rays):
        theta = 2.0 * math.pi * k / rays
        dx, dy = math.cos(theta), math.sin(theta)
        px, py = cx, cy
        for j in range(steps):
            t = (j + 0.5) * 0.5
            ix, iy = int(round(x + t * dx)), int(round(y + t * dy))
            value = prob[iy, ix] if 0 <= ix < w and 0 <= iy < h else 0.5
            if value > occupied_above or (ix != px and iy != py and _occupied(prob, ix, py, occupied_above)
                                          and _occupied(prob, px, iy, occupied_above)):
                break
            px, py = ix, iy
            if abs(value - 0.5) <= known:
                seen[iy - cy + half, ix - cx + half] = True
