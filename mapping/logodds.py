"""The standard baseline: a log-odds occupancy grid with an inverse sensor model."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import gtsam
import numba
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from mapping.grid import GridFrame, cell_key, key_cells, unique_keys
from mapping.occupancy import MapSnapshot
from mapping.refreshed import Refreshed
from mapping.regeneration import moved, reframed, replayed_frame, tile_mask, tiles_of, touches
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
    unmoved: float = Field(0.01, ge=0, description="meters: a regeneration keeps a keyframe where "
                           "it was traced when none of its rays' ends moved this far (0: only a "
                           "keyframe whose pose is unchanged), and rebuilds only what the others reach; "
                           "0.01 m, a laser's range noise, as the COM's drift.unmoved")


#: A regeneration rebuilds the grid in tiles of this many cells a side.
TILE = 16


@dataclass
class _Traced:
    """An update as traced: the sensor pose of its whole scan (None: rays given, or
    beams left out), the length of its longest ray, the global cell bounds (lo, hi) and
    tiles (``cell_key``s) its rays reach (none when it has no rays), and its marked hits."""

    pose: gtsam.Pose2 | None
    reach: float
    bounds: tuple[np.ndarray, np.ndarray] | None = None
    tiles: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    hits: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


#: A tile and the eight beside it, as offsets.
_AROUND = np.array([(dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1)])


@numba.njit(cache=True, inline="always")
def _cell(x, resolution):
    """``GridFrame.cells`` of one coordinate."""
    return np.int64(np.floor(x / resolution))


@numba.njit(cache=True, inline="always")
def _key(cx, cy):
    """``mapping.grid.cell_key`` of one cell."""
    return (cy << 32) + (cx + (1 << 31))


@numba.njit(cache=True)
def _ray_cells(origin, ends, is_hit, step, resolution, tile):
    """The cells of rays from ``origin`` (2,) to ``ends`` (k, 2), as sorted ``cell_key``s:
    those they free (each ray sampled at ``i / n`` of its length for i < n = ceil(length /
    step), so at least at its origin; not the hit cells), those their ends flagged by
    ``is_hit`` (k,) occupy, and the ``tile`` x ``tile`` tiles holding either; and the least
    and greatest cells (2,) of both. Marked on a bitmap of the rays' box and read back row by
    row, in key order: sorting a scan's 30 000 samples in numpy was most of a regeneration's
    tracing."""
    lo = np.array([_cell(origin[0], resolution), _cell(origin[1], resolution)])
    hi = lo.copy()
    for r in range(ends.shape[0]):      # every sample lies in the box of its ray's ends
        for a in range(2):
            c = _cell(ends[r, a], resolution)
            lo[a], hi[a] = min(lo[a], c), max(hi[a], c)
    w, h = hi[0] - lo[0] + 1, hi[1] - lo[1] + 1
    marked = np.zeros(h * w, np.uint8)          # 1 freed, 2 hit
    for r in range(ends.shape[0]):
        dx, dy = ends[r, 0] - origin[0], ends[r, 1] - origin[1]
        n = max(int(np.ceil(np.hypot(dx, dy) / step)), 1)
        for i in range(n):
            t = i / n
            cx, cy = _cell(origin[0] + t * dx, resolution), _cell(origin[1] + t * dy, resolution)
            f = (cy - lo[1]) * w + (cx - lo[0])
            marked[f] = max(marked[f], 1)
    for r in range(ends.shape[0]):
        if is_hit[r]:
            cx, cy = _cell(ends[r, 0], resolution), _cell(ends[r, 1], resolution)
            marked[(cy - lo[1]) * w + (cx - lo[0])] = 2
    t0x, t0y = lo[0] // tile, lo[1] // tile
    tw = hi[0] // tile - t0x + 1
    tiles = np.zeros(((hi[1] // tile - t0y + 1) * tw), np.bool_)
    nh = 0
    for f in range(marked.size):
        nh += marked[f] == 2
    free, hit = np.empty(np.count_nonzero(marked) - nh, np.int64), np.empty(nh, np.int64)
    seen_lo, seen_hi = hi.copy(), lo.copy()
    nf = nh = 0
    for f in range(marked.size):
        if marked[f] == 0:
            continue
        cx, cy = f % w + lo[0], f // w + lo[1]
        key = _key(cx, cy)
        if marked[f] == 1:
            free[nf] = key
            nf += 1
        else:
            hit[nh] = key
            nh += 1
        tiles[(cy // tile - t0y) * tw + (cx // tile - t0x)] = True
        seen_lo[0], seen_lo[1] = min(seen_lo[0], cx), min(seen_lo[1], cy)
        seen_hi[0], seen_hi[1] = max(seen_hi[0], cx), max(seen_hi[1], cy)
    at = np.flatnonzero(tiles)
    return free, hit, _key(at % tw + t0x, at // tw + t0y), seen_lo, seen_hi


class LogOddsGrid:
    """Occupancy grid: each scan adds ``l_free`` once to every cell its beams cross and
    ``l_occ`` once to every cell holding a hit (hit cells are not also freed by that scan)."""

    def __init__(self, config: LogOddsConfig | None = None):
        self.config = config or LogOddsConfig()
        # the probabilities as the planner reads them, computed again only where rays were traced
        self._prob = Refreshed(lambda box: 1.0 / (1.0 + np.exp(-self.logodds[box])))
        self.reset()

    def reset(self) -> None:
        """Forget every update: all cells unknown."""
        self.frame = GridFrame(self.config.resolution)
        self.logodds = np.zeros((0, 0))
        # each update's marked hits, one per half cell, appended to a buffer that doubles when
        # full: ``hits`` hands out views of it, never copies (it is read at every replan)
        self._hits, self._count = np.zeros((0, 2)), 0
        self._traced: list[_Traced] = []
        self._prob.forget()

    def update(self, pose: gtsam.Pose2, scan: LaserScan, beams: np.ndarray | None = None,
               mark_hits: np.ndarray | None = None) -> None:
        """Integrate ``scan`` at sensor ``pose``; optionally only the beams flagged in ``beams``
        (n,) and marking as occupied only the hits flagged in ``mark_hits`` (n,)."""
        whole = beams is None and mark_hits is None
        self.update_rays(*self._rays(pose, scan, beams, mark_hits), pose if whole else None)

    def _rays(self, pose: gtsam.Pose2, scan: LaserScan, beams: np.ndarray | None = None,
              mark_hits: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``update_rays``' (origin, ends, is_hit) of ``scan`` at ``pose``."""
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
        return origin, ends, (hit & mark)[use]

    def update_rays(self, origin: np.ndarray, ends: np.ndarray, is_hit: np.ndarray,
                    pose: gtsam.Pose2 | None = None) -> None:
        """Trace rays from ``origin`` (2,) to ``ends`` (k, 2); ``is_hit`` (k,) marks the ends
        that are obstacles. ``pose``: the sensor pose the rays are a whole scan from, when they
        are (a regeneration then retraces them only if it moved)."""
        traced, free, hit = self._trace(origin, ends, is_hit, pose)
        self._traced.append(traced)
        if traced.bounds is None:
            return
        pad = self.frame.ensure(*traced.bounds)
        if pad is not None:
            (b0, b1), (a0, a1) = pad
            self.logodds = np.pad(self.logodds, ((b0, a0), (b1, a1)))
            self._prob.forget()
        self._append_hits(traced.hits)
        self._add(free, hit)

    def _trace(self, origin: np.ndarray, ends: np.ndarray, is_hit: np.ndarray,
               pose: gtsam.Pose2 | None) -> tuple[_Traced, np.ndarray, np.ndarray]:
        """The cells the rays free and occupy (``cell_key``s, sorted; a hit's cell is not also
        freed), and the update's record. Each ray is sampled every half cell (``_ray_cells``)."""
        c = self.config
        reach = float(np.hypot(*(ends - origin).T).max()) if len(ends) else 0.0
        traced = _Traced(pose, reach)
        if len(ends) == 0:
            return traced, np.zeros(0, np.int64), np.zeros(0, np.int64)
        step = 0.5 * c.resolution
        is_hit = np.asarray(is_hit, bool)
        free, hit, traced.tiles, lo, hi = _ray_cells(
            np.asarray(origin, np.float64), np.ascontiguousarray(ends, np.float64), is_hit, step,
            self.frame.resolution, TILE)
        traced.bounds = lo, hi
        marked = ends[is_hit]
        traced.hits = marked[voxel_thin(marked, step)]
        return traced, free, hit

    def _add(self, free: np.ndarray, hit: np.ndarray) -> None:
        """Add ``l_free`` to the cells of ``free`` keys and ``l_occ`` to those of ``hit``,
        clamped (the other cells are within the clamp already)."""
        c = self.config
        L = self.logodds.reshape(-1)
        free, hit = self.frame.flat(key_cells(free)), self.frame.flat(key_cells(hit))
        L[free] = np.clip(L[free] + c.l_free, c.l_min, c.l_max)
        L[hit] = np.clip(L[hit] + c.l_occ, c.l_min, c.l_max)
        self._prob.touch_flat(free, self.logodds.shape[1])
        self._prob.touch_flat(hit, self.logodds.shape[1])

    @property
    def needs_regeneration(self) -> bool:
        """Always: a grid has no drift measure, so any SLAM correction makes it stale."""
        return True

    def regenerate(self, keyframes: Iterable[tuple[gtsam.Pose2, LaserScan]]) -> None:
        """Rebuild the grid from ``keyframes`` (sensor pose, scan), the ones traced so far
        first and in their order, at their corrected poses.

        Only the tiles of ``TILE`` x ``TILE`` cells that the moved keyframes' rays crossed,
        before or after (``unmoved`` below), are rebuilt, from every keyframe whose rays cross
        them, in order: the grid is the one rebuilt from scratch, bit for bit, with each
        unmoved keyframe at the pose it was traced at."""
        keyframes = list(keyframes)
        old = self._traced
        if len(keyframes) < len(old):
            raise ValueError(f"LogOddsGrid.regenerate: {len(keyframes)} keyframes, but "
                             f"{len(old)} were traced")
        tolerance = self.config.unmoved
        traced, cells = [], {}
        for k, (pose, scan) in enumerate(keyframes):
            kept = old[k] if k < len(old) else None
            if kept is not None and not moved(kept.pose, pose, tolerance and kept.reach, tolerance):
                traced.append(kept)
                continue
            record, free, hit = self._trace(*self._rays(pose, scan), pose)
            traced.append(record)
            cells[k] = free, hit
        cleared = np.unique(np.concatenate([np.zeros(0, np.int64)] + [traced[k].tiles for k in cells]
                                           + [old[k].tiles for k in cells if k < len(old)]))
        frame = replayed_frame(self.frame.resolution, (t.bounds for t in traced))
        self.logodds = np.where(tile_mask(frame, cleared, TILE), 0.0,
                                reframed(self.logodds, self.frame, frame))
        self._prob.forget()
        self.frame, self._traced = frame, traced
        beside = unique_keys((key_cells(cleared)[:, None, :] + _AROUND).reshape(-1, 2))
        for k, record in enumerate(traced):
            if record.bounds is None or not touches(record.tiles, cleared).any():
                continue
            if k in cells:
                free, hit = cells[k]
            else:
                origin, ends, is_hit = self._rays(record.pose, keyframes[k][1])
                crossing = self._crossing(origin, ends, beside)
                free, hit = self._trace(origin, ends[crossing], is_hit[crossing], None)[1:]
            self._add(free[touches(tiles_of(free, TILE), cleared)], hit[touches(tiles_of(hit, TILE), cleared)])
        self._hits, self._count = np.zeros((0, 2)), 0
        self._append_hits(np.concatenate([np.zeros((0, 2))] + [t.hits for t in traced]))

    def _crossing(self, origin: np.ndarray, ends: np.ndarray, beside: np.ndarray) -> np.ndarray:
        """(k,) bool: the rays from ``origin`` (2,) to ``ends`` (k, 2) that may cross one of
        some ``TILE`` tiles, given as ``beside``, the sorted ``cell_key``s of those tiles and
        the tiles beside them: the rays with a point in one of ``beside``, among points a
        tile's side apart at most along the ray, and its end (every point of the ray lies
        within half a side of one of those, so in its tile or one beside it). The others add
        nothing to those tiles."""
        side = TILE * self.config.resolution
        count = np.maximum(np.ceil(np.hypot(*(ends - origin).T) / side).astype(int), 1) + 1
        ray = np.repeat(np.arange(len(ends)), count)
        t = (np.arange(ray.size) - np.repeat(np.cumsum(count) - count, count)) / np.repeat(count - 1, count)
        at = np.floor_divide(self.frame.cells(origin + t[:, None] * (ends - origin)[ray]), TILE)
        return np.bincount(ray[touches(cell_key(at), beside)], minlength=len(ends)) > 0

    @property
    def origin(self) -> np.ndarray:
        """(2,) world coordinates of the centre of cell (0, 0), meters."""
        return self.frame.origin

    @property
    def resolution(self) -> float:
        return self.frame.resolution

    def prob(self) -> np.ndarray:
        """(h, w) occupancy probability, 0.5 where unseen."""
        return self._prob.read(self.logodds.shape)

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
