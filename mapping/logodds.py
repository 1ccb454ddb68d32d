"""The standard baseline: a log-odds occupancy grid with an inverse sensor model."""

from __future__ import annotations

from collections.abc import Iterable

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from mapping.grid import GridFrame
from mapping.occupancy import MapSnapshot
from mapping.training import voxel_thin
from slam.scan import LaserScan


class LogOddsConfig(BaseModel):
    """Inverse sensor model of the log-odds grid (values in log-odds units)."""

    model_config = ConfigDict(extra="forbid")

    resolution: float = Field(0.1, gt=0, description="cell size, m")
    l_occ: float = Field(2.0, gt=0, description="added to the cell holding a hit")
    l_free: float = Field(-0.2, lt=0, description="added to each cell a beam crosses before its hit")
    l_min: float = Field(-10.0, lt=0, description="clamp, low")
    l_max: float = Field(10.0, gt=0, description="clamp, high")
    max_range: float = Field(10.0, gt=0, description="m; hits beyond count as no return, "
                             "traced as free up to this range")


class LogOddsGrid:
    """Occupancy grid: each scan adds ``l_free`` once to every cell its beams cross and
    ``l_occ`` once to every cell holding a hit (hit cells are not also freed by that scan)."""

    def __init__(self, config: LogOddsConfig | None = None):
        self.config = config or LogOddsConfig()
        self.reset()

    def reset(self) -> None:
        """Forget every update: all cells unknown."""
        self.frame = GridFrame(self.config.resolution)
        self.logodds = np.zeros((0, 0))
        # each update's marked hits, one per half cell, appended to a buffer that doubles when
        # full: ``hits`` hands out views of it, never copies (it is read at every replan)
        self._hits, self._count = np.zeros((0, 2)), 0

    def update(self, pose: gtsam.Pose2, scan: LaserScan, beams: np.ndarray | None = None,
               mark_hits: np.ndarray | None = None) -> None:
        """Integrate ``scan`` at sensor ``pose``; optionally only the beams flagged in ``beams``
        (n,) and marking as occupied only the hits flagged in ``mark_hits`` (n,)."""
        c = self.config
        n = len(scan)
        use = np.ones(n, bool) if beams is None else np.asarray(beams, bool)
        mark = np.ones(n, bool) if mark_hits is None else np.asarray(mark_hits, bool)
        hit = scan.hit & (scan.ranges < c.max_range)
        no_return = scan.no_return | (scan.hit & ~hit)
        use &= hit | no_return
        r = np.where(hit, scan.ranges, min(c.max_range, scan.max_range))[use]
        theta = pose.theta() + scan.angles[use]
        origin = np.array([pose.x(), pose.y()])
        ends = origin + r[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])
        self.update_rays(origin, ends, (hit & mark)[use])

    def update_rays(self, origin: np.ndarray, ends: np.ndarray, is_hit: np.ndarray) -> None:
        """Trace rays from ``origin`` (2,) to ``ends`` (k, 2); ``is_hit`` (k,) marks the ends
        that are obstacles. Vectorised: each ray is sampled every half cell."""
        c = self.config
        if len(ends) == 0:
            return
        step = 0.5 * c.resolution
        d = ends - origin
        length = np.hypot(d[:, 0], d[:, 1])
        count = np.maximum(np.ceil(length / step).astype(int), 1)
        ray = np.repeat(np.arange(len(ends)), count)
        first = np.repeat(np.cumsum(count) - count, count)
        t = (np.arange(ray.size) - first) / np.repeat(count, count)        # [0, 1)
        samples = origin + t[:, None] * d[ray]
        free_cells = self.frame.cells(samples)
        hit_cells = self.frame.cells(ends[is_hit])
        all_cells = np.vstack([free_cells, hit_cells, self.frame.cells(origin[None])])
        pad = self.frame.ensure(all_cells.min(0), all_cells.max(0))
        if pad is not None:
            (b0, b1), (a0, a1) = pad
            self.logodds = np.pad(self.logodds, ((b0, a0), (b1, a1)))
        marked = ends[is_hit]
        self._append_hits(marked[voxel_thin(marked, step)])
        hit_flat = np.unique(self.frame.flat(hit_cells))
        free_flat = np.setdiff1d(np.unique(self.frame.flat(free_cells)), hit_flat, assume_unique=True)
        L = self.logodds.reshape(-1)
        L[free_flat] += c.l_free
        L[hit_flat] += c.l_occ
        np.clip(L, c.l_min, c.l_max, out=L)

    @property
    def needs_regeneration(self) -> bool:
        """Always: a grid has no drift measure, so any SLAM correction makes it stale."""
        return True

    def regenerate(self, keyframes: Iterable[tuple[gtsam.Pose2, LaserScan]]) -> None:
        """Rebuild the grid from ``keyframes`` (sensor pose, scan) at their corrected poses."""
        self.reset()
        for pose, scan in keyframes:
            self.update(pose, scan)

    @property
    def origin(self) -> np.ndarray:
        """(2,) world coordinates of the centre of cell (0, 0), meters."""
        return self.frame.origin

    @property
    def resolution(self) -> float:
        return self.frame.resolution

    def prob(self) -> np.ndarray:
        """(h, w) occupancy probability, 0.5 where unseen."""
        return 1.0 / (1.0 + np.exp(-self.logodds))

    def snapshot(self) -> MapSnapshot:
        """The grid for the explorer (no obstacle map of its own), with the hits it marked."""
        return MapSnapshot(self.prob(), None, self.frame.origin, self.frame.resolution, self.hits())

    def _append_hits(self, new: np.ndarray) -> None:
        """Append (k, 2) hits to the buffer, moving it to one twice as big when it is full."""
        end = self._count + len(new)
        if end > len(self._hits):
            grown = np.empty((max(end, 2 * len(self._hits), 1024), 2))
            grown[:self._count] = self._hits[:self._count]
            self._hits = grown
        self._hits[self._count:end] = new
        self._count = end

    def hits(self) -> np.ndarray:
        """(k, 2) the marked hits of every update since the last reset (one per half cell of
        each update), meters: a read-only view, whose points never change (later updates
        write past it; a reset starts a new buffer), so that a cache of them
        (``exploration.costmap.extends``) sees at once that the next view begins with it."""
        view = self._hits[:self._count]
        view.flags.writeable = False
        return view

    def sample(self, grid: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Values of ``grid`` (h, w) at world points ``xy`` (..., 2); 0.5 off the grid."""
        return self.frame.sample(grid, xy)
