"""The occupancy map's interface: what the stack and the explorer need of a map, whichever it is.

Two maps implement it: the continuous occupancy map (``com.ContinuousOccupancyMap``, the
paper's) and the log-odds grid (``logodds.LogOddsGrid``, the baseline). The stack updates a map
with keyframes, asks it after a SLAM correction whether it drifted, and regenerates it from the
keyframes at their corrected poses; the explorer reads a ``MapSnapshot``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

import gtsam
import numpy as np

from mapping.grid import GridFrame
from slam.scan import LaserScan


@dataclass(frozen=True)
class MapSnapshot:
    """The map as the explorer reads it, at one instant.

    ``prob`` (h, w) is the occupancy probability (Λ, or the grid's), 0.5 where unseen;
    ``prob_occ`` (h, w) is the obstacle map Λo of a COM (None for a grid, which has none);
    ``origin`` (2,) the centre of cell (0, 0) and ``resolution`` the cell size, meters;
    ``hits`` (k, 2) the measured laser endpoints the map was built from, meters (None when
    unknown: the planner then keeps its clearance from occupied cells).

    ``traversable`` (h, w), when given, is where the planner reads free and unknown space
    instead of ``prob``: the stack fills it, on the same cells, from its log-odds costmap grid
    when the map is a COM, whose smoothing closes doors a robot fits through; ``hits`` are then
    that grid's.

    ``trail`` (k, 2), when given, is where the robot's centre has been, in order (its mapped
    poses as corrected now), meters: the way it came is a way back, whatever the map's noise
    makes of a narrow door it passed.
    """

    prob: np.ndarray
    prob_occ: np.ndarray | None
    origin: np.ndarray
    resolution: float
    hits: np.ndarray | None = None
    traversable: np.ndarray | None = None
    trail: np.ndarray | None = None


class OccupancyMap(Protocol):
    """A map the stack can keep: updated by keyframes, regenerated after SLAM corrections."""

    frame: GridFrame

    def update(self, pose: gtsam.Pose2, scan: LaserScan) -> object:
        """Fuse one scan taken at sensor ``pose`` (world frame, meters and radians)."""

    def prob(self) -> np.ndarray:
        """(h, w) occupancy probability on ``frame``, 0.5 where unseen."""

    def snapshot(self) -> MapSnapshot:
        """The map for the explorer."""

    @property
    def needs_regeneration(self) -> bool:
        """After a SLAM correction: has the map drifted enough to be relearned?"""

    def regenerate(self, keyframes: Iterable[tuple[gtsam.Pose2, LaserScan]]) -> None:
        """Forget every update and relearn from ``keyframes`` (pose, scan) at their poses."""
