"""The continuous occupancy map (COM): Algorithm 1 of the paper, lines 1-17, and its reset.

``update(pose, scan)`` reads like the algorithm: training points → (first frame) fit θo, θf →
local query set → obstacle and free GPs → squash (eq. 7) → BCM fusion into Λo, Λf (eqs. 8-9)
→ drift (eqs. 12-13). ``regenerate(keyframes)`` resets the map and relearns it from all
keyframes at their (corrected) poses, keeping the hyperparameters.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Iterable

import gtsam
import numba
import numpy as np

from mapping.config import COMConfig, KernelConfig
from mapping.drift import DriftMonitor, js_divergence
from mapping.fusion import BCMAccumulator, bcm_fuse
from mapping.gp import GaussianProcess, fit_hyperparameters
from mapping.grid import GridFrame, box, cell_key
from mapping.kernels import Kernel
from mapping.localgp import nearest_within, predict_blocks
from mapping.occupancy import MapSnapshot
from mapping.refreshed import Refreshed
from mapping.regeneration import moved, reframed, replayed_frame, tile_mask, touches
from mapping.squash import squash
from mapping.training import BeamSamples, beam_samples, voxel_thin
from slam.scan import LaserScan

#: A frame needs this many hits and free points before the hyperparameters are fitted on it;
#: until then the GPs use the configured initial values.
MIN_FIT_POINTS = 10
#: Smallest GP variance fused (a zero variance would give an infinite BCM precision).
VAR_FLOOR = 1e-6


@dataclass
class _Fused:
    """A keyframe as fused: the sensor pose it was fused at (None when given as points),
    its thinned points in the world frame, the earlier keyframes whose points joined its
    training pool, and the blocks (``cell_key``s) and global cell bounds (lo, hi) of its query
    set (none when it has no points)."""

    pose: gtsam.Pose2 | None
    origin: np.ndarray
    hits: np.ndarray
    free: np.ndarray
    pool: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, int))
    blocks: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, np.int64))
    bounds: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def empty(self) -> bool:
        return len(self.hits) + len(self.free) == 0

    @property
    def reach(self) -> float:
        """Meters from the sensor to its farthest point."""
        pts = np.concatenate([self.hits, self.free])
        return float(np.hypot(*(pts - self.origin).T).max()) if len(pts) else 0.0


@dataclass
class _GPState:
    """One of the two GPs: its kernel θ (fitted on the first frame), noise variance and σ²min."""

    kernel: Kernel
    noise_var: float
    sign: float               # +1: obstacle map from μo; −1: free map from −μf (eq. 7)
    fitted: bool = False
    sigma2_min: float = np.nan


def _initial_kernel(c: KernelConfig, product: bool) -> Kernel:
    return Kernel(c.signal_var, c.matern_length, c.nu, c.se_length if product else None)


class ContinuousOccupancyMap:
    """Global obstacle map Λo, free map Λf and fused COM Λ, learned from keyframes.

    Args:
        config: :class:`COMConfig`; defaults work for a 2-D lidar indoors.

    Attributes (after updates):
        obstacle_, free_: the GPs' fitted kernels (``.kernel``), noise and σ²min.
        keyframes: number of keyframes fused since the last reset.
        drift: the :class:`DriftMonitor` of the cumulated JS divergence.
    """

    def __init__(self, config: COMConfig | None = None):
        self.config = config or COMConfig()
        c = self.config
        self.obstacle_ = _GPState(_initial_kernel(c.obstacle, False), c.obstacle.noise_var, +1.0)
        self.free_ = _GPState(_initial_kernel(c.free, True), c.free.noise_var, -1.0)
        d = c.drift
        self.drift = DriftMonitor(d.threshold, d.factor, d.window, d.floor, d.warmup)
        self._rng = np.random.default_rng(c.seed)
        # Λ and Λo as the planner reads them, computed again only where keyframes were fused
        self._prob = Refreshed(lambda box: self._fused(self._occ.precision[box], self._occ.weighted[box],
                                                       self._free.precision[box], self._free.weighted[box]))
        self._prob_occ = Refreshed(lambda box: self._occ.mean(box))
        self.reset()

    # ---------------------------------------------------------------- Algorithm 1
    def update(self, pose: gtsam.Pose2, scan: LaserScan) -> float:
        """Fuse one keyframe: ``pose`` is the sensor pose in the world frame (meters, radians).

        Returns:
            this update's Jensen-Shannon divergence between the global COM and the local map,
            averaged over the cells known in both and occupied in one (0 when none); also
            added to ``drift``.
        """
        if not isinstance(pose, gtsam.Pose2):
            raise TypeError(f"COM.update: pose must be a gtsam.Pose2, got {type(pose).__name__}")
        if not (np.isfinite([pose.x(), pose.y(), pose.theta()]).all()):
            raise ValueError(f"COM.update: pose {pose} is not finite")
        return self.update_samples(beam_samples(pose, scan, self.config.training), pose)

    def update_samples(self, samples: BeamSamples, pose: gtsam.Pose2 | None = None) -> float:
        """Fuse one keyframe given as labelled points (hits, free) in the world frame, taken at
        sensor ``pose`` when known (a regeneration then relearns it only if it moved)."""
        kf = self._keyframe(samples, pose)
        kf.pool = self._pool(kf.origin, self._origins[:self.keyframes])     # line 10
        if not kf.empty:
            cells, blocks, start = self._query_set(kf)                        # line 9
            self._grow(cells)               # may reject a wild pose: nothing is stored then
            kf.blocks, kf.bounds = cell_key(blocks), box(cells)
        self._keep(kf)
        if kf.empty:
            return 0.0
        flat = self.frame.flat(cells)
        before = self.prob_at(flat)
        local = self._add(kf, cells, blocks, start)
        p_local, _ = bcm_fuse([local[0][0], local[1][0]], [local[0][1], local[1][1]])
        return self._drift(before, p_local)

    @property
    def needs_regeneration(self) -> bool:
        """True when the cumulated drift passed its threshold (Section VII): call
        ``regenerate`` with the keyframes at their corrected poses."""
        return self.drift.exceeded

    def regenerate(self, keyframes: Iterable[tuple[gtsam.Pose2, LaserScan]]) -> None:
        """Relearn the COM from all ``keyframes`` (sensor pose, scan), the ones fused so far
        first and in their order, at their corrected poses (Section VII; Algorithm 1 with reset
        = true). θ stays fixed.

        Only what the keyframes that moved (``drift.unmoved`` below) reach is relearnt: a
        keyframe's local GPs read its own points and its training pool's, and each block of
        its query set reads only the points nearest to it. So the blocks the dirty keyframes
        (moved, or whose training pool moved or changed) cover, at their old and new poses, are
        cleared and relearnt from every keyframe whose query set covers them, in order; the
        other blocks' sums stand. The map is the one relearning from scratch gives, bit for
        bit, with each unmoved keyframe at the pose it was fused at. The relearnt keyframes add
        no divergence to ``drift``: its baseline stays that of the online updates.
        """
        keyframes = list(keyframes)
        old = self._fused_keyframes
        if len(keyframes) < len(old):
            raise ValueError(f"COM.regenerate: {len(keyframes)} keyframes, but {len(old)} "
                             f"were fused")
        tolerance = self.config.drift.unmoved
        fused, dirty = [], np.zeros(len(keyframes), bool)
        for k, (pose, scan) in enumerate(keyframes):
            kept = old[k] if k < len(old) else None
            if kept is not None and not moved(kept.pose, pose, tolerance and kept.reach, tolerance):
                fused.append(dataclasses.replace(kept))
                continue
            fused.append(self._keyframe(beam_samples(pose, scan, self.config.training), pose))
            dirty[k] = True
        relocated = dirty.copy()
        origins = np.array([kf.origin for kf in fused]).reshape(-1, 2)
        for k, kf in enumerate(fused):
            kf.pool = self._pool(kf.origin, origins[:k])
            if k < len(old) and not dirty[k]:
                dirty[k] = relocated[kf.pool].any() or not np.array_equal(kf.pool, old[k].pool)
        queries = {}
        for k in np.flatnonzero(dirty):
            if relocated[k] and not fused[k].empty:
                queries[k] = self._query_set(fused[k])
                cells, blocks, _ = queries[k]
                fused[k].blocks, fused[k].bounds = cell_key(blocks), box(cells)
        cleared = np.unique(np.concatenate(
            [np.zeros(0, np.int64)] + [fused[k].blocks for k in np.flatnonzero(dirty)]
            + [old[k].blocks for k in np.flatnonzero(dirty[:len(old)])]))
        bounds = [kf.bounds for kf in fused if kf.bounds is not None]
        if bounds:
            self._check_size(np.min([lo for lo, _ in bounds], 0), np.max([hi for _, hi in bounds], 0))
        frame = replayed_frame(self.frame.resolution, bounds)
        blocks_cleared = tile_mask(frame, cleared, self.config.query.block)
        for acc in (self._occ, self._free):
            acc.precision = np.where(blocks_cleared, 0.0, reframed(acc.precision, self.frame, frame))
            acc.weighted = np.where(blocks_cleared, 0.0, reframed(acc.weighted, self.frame, frame))
        self._forget_products()
        self.frame, self._fused_keyframes, self._origins = frame, [], np.zeros((0, 2))
        self.keyframes = 0
        for kf in fused:
            self._keep(kf)
        for k, kf in enumerate(fused):
            if kf.empty or not touches(kf.blocks, cleared).any():
                continue
            cells, blocks, start = queries.get(k) or self._query_set(kf)
            inside = touches(cell_key(blocks), cleared)
            start, cells = _blocks_of(start, inside), cells[np.repeat(inside, np.diff(start))]
            self._add(kf, cells, blocks[inside], start)
        self.drift.reset()

    def reset(self) -> None:
        """Λ = Λo = Λf = ∅ (Algorithm 1, line 7); hyperparameters are kept."""
        self.frame = GridFrame(self.config.query.resolution)
        self._occ = BCMAccumulator((0, 0))
        self._free = BCMAccumulator((0, 0))
        self._fused_keyframes: list[_Fused] = []
        self._origins = np.zeros((0, 2))     # theirs, in a buffer that doubles when full
        self.keyframes = 0
        self._forget_products()

    def _keep(self, kf: _Fused) -> None:
        """Append a fused keyframe, and its origin to ``_origins``."""
        if self.keyframes == len(self._origins):
            self._origins = np.concatenate([self._origins, np.empty((max(64, self.keyframes), 2))])
        self._origins[self.keyframes] = kf.origin
        self._fused_keyframes.append(kf)
        self.keyframes += 1

    # ---------------------------------------------------------------- map products
    @property
    def origin(self) -> np.ndarray:
        """(2,) world coordinates (m) of the centre of cell (0, 0) of the map arrays."""
        return self.frame.origin

    @property
    def resolution(self) -> float:
        return self.frame.resolution

    def prob_occ(self) -> np.ndarray:
        """(h, w) Λo: occupancy probability from the obstacle GP (eq. 8), 0.5 where unseen."""
        return self._prob_occ.read(self.frame.shape)

    def prob_free(self) -> np.ndarray:
        """(h, w) Λf: occupancy probability from the free GP (eq. 8), 0.5 where unseen."""
        return self._free.mean()

    def var_occ(self) -> np.ndarray:
        """(h, w) variance of Λo (eq. 9), the prior variance where unseen."""
        return self._occ.variance(self.obstacle_.kernel.prior_var)

    def var_free(self) -> np.ndarray:
        """(h, w) variance of Λf (eq. 9), the prior variance where unseen."""
        return self._free.variance(self.free_.kernel.prior_var)

    def prob(self) -> np.ndarray:
        """(h, w) Λ: the COM, Λo and Λf fused by the BCM; 0.5 where unseen."""
        return self._prob.read(self.frame.shape)

    def _forget_products(self) -> None:
        """Λ and Λo are to be computed again over the whole map (it was reset, relearnt or grew)."""
        self._prob.forget()
        self._prob_occ.forget()

    def snapshot(self) -> MapSnapshot:
        """Λ and Λo for the explorer (eq. 10 reads both)."""
        return MapSnapshot(self.prob(), self.prob_occ(), self.frame.origin, self.frame.resolution)

    def var(self) -> np.ndarray:
        """(h, w) variance of Λ; the larger prior variance where unseen."""
        prior = max(self.obstacle_.kernel.prior_var, self.free_.kernel.prior_var)
        precision = self._occ.precision + self._free.precision
        with np.errstate(divide="ignore"):
            v = np.where(precision > 0, 1.0 / precision, np.inf)
        return np.where(np.isfinite(v), v, prior)

    def observed_bounds(self) -> tuple[slice, slice]:
        """(rows, cols) slices of the smallest box holding every observed cell."""
        obs = self.observed()
        if not obs.any():
            return slice(0, 0), slice(0, 0)
        rows, cols = np.flatnonzero(obs.any(1)), np.flatnonzero(obs.any(0))
        return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)

    def observed(self) -> np.ndarray:
        """(h, w) bool: cells some local map has been fused into."""
        return (self._occ.precision > 0) | (self._free.precision > 0)

    def prob_at(self, flat: np.ndarray) -> np.ndarray:
        """(k,) Λ at flat cell indices of the map arrays."""
        o, f = self._occ, self._free
        return self._fused(o.precision.flat[flat], o.weighted.flat[flat],
                           f.precision.flat[flat], f.weighted.flat[flat])

    def sample(self, grid: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Values of a map array (h, w) at world points ``xy`` (..., 2); 0.5 off the map."""
        return self.frame.sample(grid, xy)

    @staticmethod
    def _fused(po, wo, pf, wf):
        """Λ of the BCM from each GP's precision and precision-weighted mean sums; not its
        variance (``var``): Λ is read at every replan, and computing both doubled its cost."""
        C = po + pf
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(C > 0, (wo + wf) / C, 0.5)

    # ---------------------------------------------------------------- steps
    def _fit(self, hits: np.ndarray, free: np.ndarray) -> None:
        """Fit θo and θf by maximum marginal likelihood on this frame, then keep them fixed.

        Each GP is fitted on the frame's labelled points: its own class +1, the other −1 (with
        +1-only targets the likelihood keeps growing with the length scale: no maximum), with
        the signal variance fixed at the targets' scale. σ²min of each GP is the smallest
        posterior variance over its own training points, as the GP is then used (+1 only).
        """
        c = self.config
        half = c.fit_max_points // 2
        h = hits if len(hits) <= half else hits[np.sort(self._rng.choice(len(hits), half, replace=False))]
        f = free if len(free) <= half else free[np.sort(self._rng.choice(len(free), half, replace=False))]
        X = np.vstack([h, f])
        label = np.r_[np.ones(len(h)), -np.ones(len(f))]
        for gp, kc, y, own in ((self.obstacle_, c.obstacle, label, h),
                               (self.free_, c.free, -label, f)):
            if c.fit_hyperparameters:
                gp.kernel, gp.noise_var = fit_hyperparameters(
                    X, y, gp.kernel, gp.noise_var, kc.length_bounds, kc.noise_floor, c.seed,
                    se_bounds=kc.se_bounds)
            gp.sigma2_min = _sigma2_min(gp.kernel, gp.noise_var, own)
            gp.fitted = True

    def _keyframe(self, samples: BeamSamples, pose: gtsam.Pose2 | None) -> _Fused:
        """The keyframe's points, thinned; θ fitted on the first frame that has enough
        of both kinds (line 5)."""
        t = self.config.training
        hits = samples.hits[voxel_thin(samples.hits, t.voxel)]
        free = samples.free[voxel_thin(samples.free, t.free_voxel)]
        if not self.obstacle_.fitted and min(len(hits), len(free)) >= MIN_FIT_POINTS:
            self._fit(hits, free)                                             # line 5
        return _Fused(pose, np.asarray(samples.origin, float),
                      hits, free)

    def _pool(self, origin: np.ndarray, previous: np.ndarray) -> np.ndarray:
        """Indices of the ``history`` earlier keyframes, at ``previous`` (k, 2) origins, nearest
        to the sensor at ``origin`` (within the query window), whose points join its training
        pool."""
        q = self.config.query
        if q.history == 0 or not len(previous):
            return np.zeros(0, int)
        d = np.hypot(*(previous - origin).T)
        near = np.flatnonzero(d < q.window / 2)
        return near[np.argsort(d[near], kind="stable")[:q.history]]

    def _add(self, kf: _Fused, cells, blocks, start) -> list[tuple[np.ndarray, np.ndarray]]:
        """Predict both GPs of keyframe ``kf`` at ``cells`` (its query set, or part of it,
        grouped by ``blocks``), squash and fuse them into Λo and Λf (lines 11-16). Returns
        the local (probability, variance) of each GP."""
        flat = self.frame.flat(cells)
        local = []
        for gp, own, acc in ((self.obstacle_, "hits", self._occ), (self.free_, "free", self._free)):
            pts = np.concatenate([getattr(kf, own)] + [getattr(self._fused_keyframes[i], own) for i in kf.pool])
            if len(pts) == 0:
                local.append((np.full(len(flat), 0.5), np.full(len(flat), np.inf)))
                continue
            if not gp.sigma2_min > 0:      # not fitted yet (no frame with both kinds of points)
                gp.sigma2_min = _sigma2_min(gp.kernel, gp.noise_var, pts)
            mean, var = self._predict(gp, pts, blocks, cells, start)          # line 11
            var = np.maximum(var, VAR_FLOOR)
            p = squash(mean, var, gp.sigma2_min, self.config.squash.gamma, gp.sign)  # 12-14
            acc.add(flat, p, var)                                             # lines 15-16
            local.append((p, var))
        for product in (self._prob, self._prob_occ):
            product.touch_flat(flat, self.frame.shape[1])
        return local

    def _query_set(self, kf: _Fused):
        """Cells within ``near`` of this keyframe's training points and inside the window
        (line 9), grouped by block of block × block cells.

        Returns:
            cells (k, 2) global cells sorted by block; blocks (B, 2) block indices;
            start (B + 1,) offsets: block b owns ``cells[start[b]:start[b+1]]``.
        """
        q = self.config.query
        res = q.resolution
        origin, pts = kf.origin, np.concatenate([kf.hits, kf.free])
        r = int(np.ceil(q.near / res))
        oy, ox = np.mgrid[-r:r + 1, -r:r + 1]
        disk = (ox ** 2 + oy ** 2) * res * res <= q.near ** 2 + 1e-12
        offsets = np.column_stack([ox[disk], oy[disk]])
        lo = np.floor((origin - q.window / 2) / res).astype(np.int64)
        hi = np.floor((origin + q.window / 2) / res).astype(np.int64)
        return _blocked_cells(self.frame.cells(pts).reshape(-1, 2), offsets, lo, hi, q.block)

    def _predict(self, gp: _GPState, pts: np.ndarray, blocks: np.ndarray, cells: np.ndarray,
                 start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Local GPs (line 11), one per block, each trained on the ``max_train`` points nearest
        to the block centre within ``margin`` of the block. Returns (k,) mean, var."""
        q = self.config.query
        b, res = q.block, q.resolution
        centres = (blocks + 0.5) * b * res
        reach = np.sqrt(2) * b * res / 2 + q.margin
        k = min(q.max_train, len(pts))
        idx = nearest_within(np.ascontiguousarray(pts, np.float64), centres, k, reach, b * res)
        return predict_blocks(gp.kernel, gp.noise_var, pts, idx, self.frame.centres(cells), start)

    def _grow(self, cells: np.ndarray) -> None:
        bounds = box(cells)
        lo, hi = bounds
        if not self.frame.empty:
            lo = np.minimum(lo, [self.frame.ix0, self.frame.iy0])
            hi = np.maximum(hi, [self.frame.ix0 + self.frame.shape[1] - 1,
                                 self.frame.iy0 + self.frame.shape[0] - 1])
        self._check_size(lo, hi)
        pad = self.frame.ensure(*bounds)
        if pad is not None:
            self._occ.pad(*pad)
            self._free.pad(*pad)
            self._forget_products()

    def _check_size(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Refuse a map spanning global cells ``lo`` .. ``hi`` larger than ``max_cells``."""
        span = (np.asarray(hi) - np.asarray(lo) + 1).astype(float)
        if span[0] * span[1] > self.config.query.max_cells:
            r = self.resolution
            raise ValueError(f"COM: the map would grow to {span[0] * r:.0f} m x {span[1] * r:.0f} m "
                             f"({span[0] * span[1]:.3g} cells > max_cells "
                             f"{self.config.query.max_cells}); is the pose right?")

    def _drift(self, before: np.ndarray, local: np.ndarray) -> float:
        """Mean JS divergence (eq. 12) between the global Λ before this update and the local
        map, over the cells known in both and occupied in at least one (free space that
        agrees would dilute the disagreement of shifted walls); cumulated in ``drift``."""
        known = self.config.drift.known
        both = (np.abs(before - 0.5) > known) & (np.abs(local - 0.5) > known)
        both &= (before > 0.5) | (local > 0.5)
        if not both.any():
            return 0.0
        js = float(js_divergence(np.stack([before[both], local[both]])).mean())
        self.drift.add(js)
        return js


@numba.njit(cache=True)
def _blocked_cells(base, offsets, lo, hi, block):
    """``_query_set``'s (cells, blocks, start): the cells at ``offsets`` (m, 2) from a cell of
    ``base`` (n, 2), within ``lo`` .. ``hi`` (2,) (inclusive), each once, grouped by block of
    ``block`` x ``block`` cells: the blocks in ``cell_key`` order, the cells in that order
    within each. Marked on a bitmap of their box and read back block by block, not sorted
    twice (the query sets were a sixth of a regeneration)."""
    x0, y0, x1, y1 = hi[0], hi[1], lo[0], lo[1]
    for k in range(base.shape[0]):
        x0, y0 = min(x0, base[k, 0]), min(y0, base[k, 1])
        x1, y1 = max(x1, base[k, 0]), max(y1, base[k, 1])
    x0, y0 = max(x0 + offsets[:, 0].min(), lo[0]), max(y0 + offsets[:, 1].min(), lo[1])
    x1, y1 = min(x1 + offsets[:, 0].max(), hi[0]), min(y1 + offsets[:, 1].max(), hi[1])
    if base.shape[0] == 0 or x0 > x1 or y0 > y1:
        return np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64), np.zeros(1, np.int64)
    w = x1 - x0 + 1
    marked = np.zeros((y1 - y0 + 1) * w, np.bool_)
    count = 0
    for k in range(base.shape[0]):
        for j in range(offsets.shape[0]):
            x, y = base[k, 0] + offsets[j, 0], base[k, 1] + offsets[j, 1]
            if x0 <= x <= x1 and y0 <= y <= y1 and not marked[(y - y0) * w + (x - x0)]:
                marked[(y - y0) * w + (x - x0)] = True
                count += 1
    cells = np.empty((count, 2), np.int64)
    blocks = np.empty((count, 2), np.int64)
    start = np.empty(count + 1, np.int64)
    n = b = 0
    for by in range(y0 // block, y1 // block + 1):
        for bx in range(x0 // block, x1 // block + 1):
            first = n
            for y in range(max(by * block, y0), min(by * block + block - 1, y1) + 1):
                for x in range(max(bx * block, x0), min(bx * block + block - 1, x1) + 1):
                    if marked[(y - y0) * w + (x - x0)]:
                        cells[n, 0], cells[n, 1] = x, y
                        n += 1
            if n > first:
                blocks[b, 0], blocks[b, 1] = bx, by
                start[b] = first
                b += 1
    start[b] = n
    return cells, blocks[:b].copy(), start[:b + 1].copy()


def _blocks_of(start: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """The (B' + 1,) offsets of the blocks flagged in ``keep`` (B,), their cells taken in
    order, from the offsets ``start`` (B + 1,) of all B blocks."""
    return np.r_[0, np.cumsum(np.diff(start)[keep])]


def _sigma2_min(kernel: Kernel, noise_var: float, pts: np.ndarray) -> float:
    """σ²min: the smallest exact-GP posterior variance over ``pts`` (at most 400 of them)."""
    pts = pts[:: max(1, len(pts) // 400)]
    exact = GaussianProcess(kernel, noise_var).fit(pts, np.ones(len(pts)))
    return float(max(exact.predict(pts)[1].min(), VAR_FLOOR))
