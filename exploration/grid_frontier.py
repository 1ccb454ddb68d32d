"""The baseline: Yamauchi's frontier-based exploration on an occupancy grid (nearest frontier)."""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from scipy.spatial.distance import pdist

from exploration.costmap import CostmapConfig, classify


def grid_frontiers(prob: np.ndarray, config: CostmapConfig, min_size: int = 10,
                   exclude: np.ndarray | None = None) -> list[np.ndarray]:
    """Frontier regions of a grid: free cells next to unknown ones, 8-connected, at least
    ``min_size`` cells long (``region_size``; the paper's Fig. 6 keeps frontiers larger than 9
    cells of 0.2 m), leaving out the cells of ``exclude`` (h, w) bool when given.

    Returns:
        list of (m, 2) integer cells (ix, iy), one array per region.
    """
    free, occupied = classify(prob, config)
    unknown = ~free & ~occupied
    cross = ndimage.generate_binary_structure(2, 1)
    frontier = free & ndimage.binary_dilation(unknown, structure=cross)
    if exclude is not None:
        frontier &= ~exclude
    labels, n = ndimage.label(frontier, structure=np.ones((3, 3)))
    iy, ix = np.nonzero(labels)
    order = np.argsort(labels[iy, ix], kind="stable")
    cells = np.column_stack([ix[order], iy[order]])
    sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    regions = np.split(cells, np.cumsum(sizes)[:-1])
    return [r for r in regions if region_size(r) >= min_size]


def region_size(region: np.ndarray) -> float:
    """A frontier region's size, cells: its cell count or its length (the longest distance
    between two of its cells, plus one), whichever is greater. A frontier on a diagonal is a
    staircase of one cell a row, √2 cells apart: counted alone, a 1.1 m opening seen at 45°
    is 8 cells, below the 10 of a 1 m one along an axis (lab_a's grid run left an 11 m² room
    behind such a door)."""
    if len(region) < 2 or len(region) >= math.hypot(*np.ptp(region, axis=0)) + 1.0:
        return float(len(region))     # its box's diagonal bounds its length
    return max(float(len(region)), float(pdist(region).max()) + 1.0)

