"""A COM that measures itself: it keeps each mapped scan's labelled test points (held out from
training, or all of them) and its update times, for the AUC and the timings of log mapping."""

from __future__ import annotations

import time
from collections.abc import Iterable

import gtsam
import numpy as np

from mapping.com import ContinuousOccupancyMap
from mapping.config import COMConfig
from mapping.holdout import split
from mapping.metrics import auc_readings, map_entropy
from mapping.occupancy import MapSnapshot
from mapping.training import beam_samples
from slam.scan import LaserScan


class MeasuredMap:
    """An occupancy map (``mapping.occupancy.OccupancyMap``) wrapping a COM.

    With ``holdout`` > 0, that fraction of each scan's labelled points (``protocol="points"``)
    or beams (``"beams"``) is kept out of training and the AUC is measured on them; otherwise
    on all labelled points (resubstitution, optimistic). The split is drawn from ``seed`` and
    drawn again identically when the map is regenerated, so the test points follow the scans
    to their corrected poses.
    """

    def __init__(self, config: COMConfig | None = None, holdout: float = 0.0,
                 protocol: str = "points", seed: int = 0):
        if not 0 <= holdout < 1:
            raise ValueError(f"hold-out fraction must be in [0, 1), got {holdout}")
        self.com = ContinuousOccupancyMap(config)
        self.holdout, self.protocol, self.seed = holdout, protocol, seed
        self._forget()

    def _forget(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        self.origins: list[np.ndarray] = []
        self.hits: list[np.ndarray] = []
        self._test_xy: list[np.ndarray] = []
        self._test_occ: list[np.ndarray] = []
        self.update_s: list[float] = []

    @property
    def frame(self):
        return self.com.frame

    def update(self, pose: gtsam.Pose2, scan: LaserScan) -> None:
        """Fuse the training part of one scan taken at sensor ``pose``; keep its test points."""
        tic = time.perf_counter()
        samples = beam_samples(pose, scan, self.com.config.training)
        part = split(samples, len(scan), self.holdout, self.protocol, self._rng)
        self.com.update_samples(part.train)
        self.update_s.append(time.perf_counter() - tic)
        self.origins.append(samples.origin)
        self.hits.append(samples.hits)
        if self.holdout > 0:
            self._test_xy.append(part.test_xy)
            self._test_occ.append(part.test_occ)
        else:
            self._test_xy.append(np.vstack([samples.hits, samples.free]))
            self._test_occ.append(np.r_[np.ones(len(samples.hits), bool), np.zeros(len(samples.free), bool)])

    def prob(self) -> np.ndarray:
        return self.com.prob()

    def snapshot(self) -> MapSnapshot:
        return self.com.snapshot()

    @property
    def needs_regeneration(self) -> bool:
        return self.com.needs_regeneration

    def regenerate(self, keyframes: Iterable[tuple[gtsam.Pose2, LaserScan]]) -> None:
        """Relearn the COM from ``keyframes`` (pose, scan), with the same held-out points."""
        self.com.reset()
        self._forget()
        for pose, scan in keyframes:
            self.update(pose, scan)
        self.com.drift.reset()

    def metrics(self) -> dict:
        """Update times, the AUC on the test points (two readings), entropy, size, and the fitted
        hyperparameters."""
        com = self.com
        if not self.update_s:
            raise ValueError("MeasuredMap: nothing was mapped")
        xy, occ = np.vstack(self._test_xy), np.concatenate(self._test_occ)
        prob = com.prob()
        ms = 1e3 * np.asarray(self.update_s)
        rows, cols = com.observed_bounds()
        x0, _, y0, _ = com.frame.extent
        r = com.resolution
        observed = (x0 + cols.start * r, x0 + cols.stop * r, y0 + rows.start * r, y0 + rows.stop * r)
        return {
            "keyframes": len(self.update_s),
            "update_ms_median": float(np.median(ms)),
            "update_ms_p95": float(np.percentile(ms, 95)),
            "holdout": {"fraction": self.holdout,
                        "protocol": self.protocol if self.holdout > 0 else "none (resubstitution)",
                        "points": int(len(occ))},
            **auc_readings(occ, com.frame, prob, xy),
            "entropy_nats_0.2m": map_entropy(com.frame, prob, observed),
            "map_cells": list(prob.shape),
            "resolution_m": com.resolution,
            "origin_m": [float(v) for v in com.origin],
            "observed_area_m2": float(com.observed().sum() * com.resolution ** 2),
            "hyperparameters": {
                name: {"signal_var": gp.kernel.signal_var, "matern_length": gp.kernel.matern_length,
                       "nu": gp.kernel.nu, "se_length": gp.kernel.se_length,
                       "noise_var": gp.noise_var, "sigma2_min": gp.sigma2_min}
                for name, gp in (("obstacle", com.obstacle_), ("free", com.free_))},
            "drift_cumulated_js": com.drift.cumulated,
        }
