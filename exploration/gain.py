"""What a goal would show: the unknown area a 360-degree look from it would see, ray-cast on the
map the planner reads. The stop test drops frontier clusters that would show less than the
sensitivity asked for, so that a run ends when nothing worth a trip is left instead of driving
to remnants (a few unknown cells in a corner, a speck behind furniture)."""

from __future__ import annotations

import numpy as np

from mapping.metrics import KNOWN


def visible_unknown_area(prob: np.ndarray, origin, resolution: float, at, sensor_range: float,
                         occupied_above: float, rays: int = 360) -> float:
    """Area (m²) of the unknown cells (``|prob - 0.5| <= KNOWN``, and every cell off the map)
    that ``rays`` rays from ``at`` (2,) (m) cross before an occupied cell (``prob`` above
    ``occupied_above``) or ``sensor_range`` meters. ``prob`` (h, w) has cell (0, 0)'s centre
    at ``origin`` (2,), meters."""
    theta = np.linspace(0.0, 2 * np.pi, rays, endpoint=False)
    steps = np.arange(0.5, sensor_range / resolution * 2 + 1) * resolution / 2      # half cells
    xy = np.asarray(at, float) + steps[None, :, None] * np.stack([np.cos(theta), np.sin(theta)], -1)[:, None, :]
    cells = np.round((xy - np.asarray(origin, float)) / resolution).astype(np.int64)   # (rays, n, 2)
    h, w = prob.shape
    inside = (cells[..., 0] >= 0) & (cells[..., 0] < w) & (cells[..., 1] >= 0) & (cells[..., 1] < h)
    value = np.full(inside.shape, 0.5)
    value[inside] = prob[cells[..., 1][inside], cells[..., 0][inside]]
    blocked = np.cumsum(value > occupied_above, axis=1) > 0          # at and past the first wall
    seen = ~blocked & (np.abs(value - 0.5) <= KNOWN)
    unknown = np.unique(cells[seen][:, 0] * (2**31) + cells[seen][:, 1])
    return float(len(unknown) * resolution**2)
