"""The continuous occupancy map (COM): Algorithm 1 of the paper, lines 1-17, and its reset.

``update(pose, scan)`` reads like the algorithm: training points → (first frame) fit θo, θf →
local query set → obstacle and free GPs → squash (eq. 7) → BCM fusion into Λo, Λf (eqs. 8-9)
→ drift (eqs. 12-13). ``regenerate(keyframes)`` resets the map and relearns it from all
keyframes at their (corrected) poses, keeping the hyperparameters.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import gtsam
import numpy as np
from scipy.spatial import cKDTree

from mapping.config import COMConfig, KernelConfig
from mapping.drift import DriftMonitor, js_divergence
from mapping.fusion import BCMAccumulator, bcm_fuse
from mapping.gp import GaussianProcess, fit_hyperparameters
from mapping.grid import GridFrame
from mapping.kernels import Kernel
from mapping.localgp import predict_blocks
from mapping.occupancy import MapSnapshot
from mapping.squash import squash
from mapping.training import BeamSamples, beam_samples, voxel_thin
from slam.scan import LaserScan

#: A frame needs this many hits and free points before the hyperparameters are fitted on it;
#: until then the GPs use the configured initial values.
MIN_FIT_POINTS = 10
#: Smallest GP variance fused (a zero variance would give an infinite BCM precision).
VAR_FLOOR = 1e-6


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
        return self.update_samples(beam_samples(pose, scan, self.config.training))

    def update_samples(self, samples: BeamSamples) -> float:
        """Fuse one keyframe given as labelled points (hits, free) in the world frame."""
        t = self.config.training
        hits = samples.hits[voxel_thin(samples.hits, t.voxel)]
        free = samples.free[voxel_thin(samples.free, t.free_voxel)]
        origin = np.asarray(samples.origin, float)
        if not self.obstacle_.fitted and min(len(hits), len(free)) >= MIN_FIT_POINTS:
            self._fit(hits, free)                                             # line 5
        pool_hits, pool_free = self._training_pool(origin, hits, free)       # line 10
        if len(hits) + len(free) > 0:
            cells, blocks, start = self._query_set(origin, hits, free)       # line 9
            self._grow(cells)               # may reject a wild pose: nothing is stored then
        self._keyframe_origins.append(origin)
        self._keyframe_hits.append(hits)
        self._keyframe_free.append(free)
        self.keyframes += 1
        if len(hits) + len(free) == 0:
            return 0.0
        flat = self.frame.flat(cells)
        before = self.prob_at(flat)
        local = []
        for gp, pts, acc in ((self.obstacle_, pool_hits, self._occ),
                             (self.free_, pool_free, self._free)):
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
        p_local, _ = bcm_fuse([local[0][0], local[1][0]], [local[0][1], local[1][1]])
        return self._drift(before, p_local)

    @property
    def needs_regeneration(self) -> bool:
        """True when the cumulated drift passed its threshold (Section VII): call
        ``regenerate`` with the keyframes at their corrected poses."""
        return self.drift.exceeded

    def regenerate(self, keyframes: Iterable[tuple[gtsam.Pose2, LaserScan]]) -> None:
        """Reset the COM and relearn it from all ``keyframes`` (sensor pose, scan) at their
        corrected poses (Section VII; Algorithm 1 with reset = true). θ stays fixed."""
        self.reset()
        for pose, scan in keyframes:
            self.update(pose, scan)
        self.drift.reset()

    def reset(self) -> None:
        """Λ = Λo = Λf = ∅ (Algorithm 1, line 7); hyperparameters are kept."""
        self.frame = GridFrame(self.config.query.resolution)
        self._occ = BCMAccumulator((0, 0))
        self._free = BCMAccumulator((0, 0))
        self._keyframe_origins: list[np.ndarray] = []
        self._keyframe_hits: list[np.ndarray] = []
        self._keyframe_free: list[np.ndarray] = []
        self.keyframes = 0

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
        return self._occ.mean()

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
        return self._fused(self._occ.precision, self._occ.weighted,
                           self._free.precision, self._free.weighted)[0]

    def snapshot(self) -> MapSnapshot:
        """Λ and Λo for the explorer (eq. 10 reads both)."""
        return MapSnapshot(self.prob(), self.prob_occ(), self.frame.origin, self.frame.resolution)

    def var(self) -> np.ndarray:
        """(h, w) variance of Λ; the larger prior variance where unseen."""
        prior = max(self.obstacle_.kernel.prior_var, self.free_.kernel.prior_var)
        v = self._fused(self._occ.precision, self._occ.weighted,
                        self._free.precision, self._free.weighted)[1]
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
                           f.precision.flat[flat], f.weighted.flat[flat])[0]

    def sample(self, grid: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Values of a map array (h, w) at world points ``xy`` (..., 2); 0.5 off the map."""
        return self.frame.sample(grid, xy)

    @staticmethod
    def _fused(po, wo, pf, wf):
        C = po + pf
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(C > 0, (wo + wf) / C, 0.5), np.where(C > 0, 1.0 / C, np.inf)

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

    def _training_pool(self, origin, hits, free):
        """This keyframe's points plus those of the ``history`` previous keyframes nearest to
        the sensor (within the query window)."""
        q = self.config.query
        if q.history == 0 or not self._keyframe_origins:
            return hits, free
        origins = np.asarray(self._keyframe_origins)
        d = np.hypot(*(origins - origin).T)
        near = np.flatnonzero(d < q.window / 2)
        near = near[np.argsort(d[near], kind="stable")[:q.history]]
        return (np.concatenate([hits] + [self._keyframe_hits[i] for i in near]),
                np.concatenate([free] + [self._keyframe_free[i] for i in near]))

    def _query_set(self, origin, hits, free):
        """Cells within ``near`` of this keyframe's training points and inside the window
        (line 9), grouped by block of block × block cells.

        Returns:
            cells (k, 2) global cells sorted by block; blocks (B, 2) block indices;
            start (B + 1,) offsets: block b owns ``cells[start[b]:start[b+1]]``.
        """
        q = self.config.query
        res = q.resolution
        pts = np.concatenate([hits, free])
        r = int(np.ceil(q.near / res))
        oy, ox = np.mgrid[-r:r + 1, -r:r + 1]
        disk = (ox ** 2 + oy ** 2) * res * res <= q.near ** 2 + 1e-12
        offsets = np.column_stack([ox[disk], oy[disk]])
        base = _unique_cells(self.frame.cells(pts))
        cells = (base[:, None, :] + offsets[None]).reshape(-1, 2)
        lo = np.floor((origin - q.window / 2) / res)
        hi = np.floor((origin + q.window / 2) / res)
        cells = _unique_cells(cells[np.all((cells >= lo) & (cells <= hi), axis=1)])
        block_of = np.floor_divide(cells, q.block)
        key = _cell_key(block_of)
        order = np.argsort(key, kind="stable")
        cells, key, block_of = cells[order], key[order], block_of[order]
        first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
        start = np.r_[first, len(cells)]
        return cells, block_of[first], start

    def _predict(self, gp: _GPState, pts: np.ndarray, blocks: np.ndarray, cells: np.ndarray,
                 start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Local GPs (line 11), one per block, each trained on the ``max_train`` points nearest
        to the block centre within ``margin`` of the block (KD-tree). Returns (k,) mean, var."""
        q = self.config.query
        b, res = q.block, q.resolution
        centres = (blocks + 0.5) * b * res
        reach = np.sqrt(2) * b * res / 2 + q.margin
        k = min(q.max_train, len(pts))
        _, idx = cKDTree(pts).query(centres, k=k, distance_upper_bound=reach)
        idx = idx.reshape(len(blocks), k)
        return predict_blocks(gp.kernel, gp.noise_var, pts, idx, self.frame.centres(cells), start)

    def _grow(self, cells: np.ndarray) -> None:
        lo, hi = cells.min(0), cells.max(0)
        if not self.frame.empty:
            lo = np.minimum(lo, [self.frame.ix0, self.frame.iy0])
            hi = np.maximum(hi, [self.frame.ix0 + self.frame.shape[1] - 1,
                                 self.frame.iy0 + self.frame.shape[0] - 1])
        span = (hi - lo + 1).astype(float)
        if span[0] * span[1] > self.config.query.max_cells:
            r = self.resolution
            raise ValueError(f"COM: the map would grow to {span[0] * r:.0f} m x {span[1] * r:.0f} m "
                             f"({span[0] * span[1]:.3g} cells > max_cells "
                             f"{self.config.query.max_cells}); is the pose right?")
        pad = self.frame.ensure(cells.min(0), cells.max(0))
        if pad is not None:
            self._occ.pad(*pad)
            self._free.pad(*pad)

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


def _cell_key(cells: np.ndarray) -> np.ndarray:
    """(k, 2) integer cells -> (k,) int64 keys that order them row by row."""
    return (cells[:, 1].astype(np.int64) << 32) + (cells[:, 0].astype(np.int64) + (1 << 31))


def _unique_cells(cells: np.ndarray) -> np.ndarray:
    """Unique rows of (k, 2) integer cells (fast: one 1-D unique on int64 keys)."""
    _, first = np.unique(_cell_key(cells), return_index=True)
    return cells[first]


def _sigma2_min(kernel: Kernel, noise_var: float, pts: np.ndarray) -> float:
    """σ²min: the smallest exact-GP posterior variance over ``pts`` (at most 400 of them)."""
    pts = pts[:: max(1, len(pts) // 400)]
    exact = GaussianProcess(kernel, noise_var).fit(pts, np.ones(len(pts)))
    return float(max(exact.predict(pts)[1].min(), VAR_FLOOR))
