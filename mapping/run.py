"""Build a COM from a sequence of keyframes (sensor pose, scan) and measure it."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Iterable

import gtsam
import numpy as np

from mapping.com import ContinuousOccupancyMap
from mapping.config import COMConfig
from mapping.holdout import split
from mapping.metrics import auc_readings, map_entropy
from mapping.training import beam_samples
from slam.scan import LaserScan


@dataclass
class MapRun:
    """A COM built from keyframes, with what it took and how good it is."""

    com: ContinuousOccupancyMap
    poses_xy: np.ndarray                       # (n, 2) sensor positions
    hits_xy: np.ndarray                        # (k, 2) all hits (for figures)
    update_s: list[float] = field(default_factory=list)
    metrics: dict = field(default_factory=dict)


def map_keyframes(keyframes: Iterable[tuple[gtsam.Pose2, LaserScan]], config: COMConfig | None = None,
                  holdout: float = 0.0, protocol: str = "points", seed: int = 0) -> MapRun:
    """Fuse every keyframe (sensor pose in the world frame, scan) into a new COM.

    With ``holdout`` > 0, that fraction of each scan's labelled points (``protocol="points"``)
    or beams (``"beams"``) is kept out of training and the AUC is measured on them; otherwise
    the AUC is measured on all labelled points (resubstitution, optimistic). ``metrics["auc"]``
    reads Λ continuously (bilinear), ``metrics["auc_cell"]`` at the cell holding each point.
    """
    com = ContinuousOccupancyMap(config)
    rng = np.random.default_rng(seed)
    poses, hits, test_xy, test_occ, update_s = [], [], [], [], []
    tic = time.perf_counter()
    for pose, scan in keyframes:
        t = time.perf_counter()
        samples = beam_samples(pose, scan, com.config.training)
        part = split(samples, len(scan), holdout, protocol, rng)
        com.update_samples(part.train)
        update_s.append(time.perf_counter() - t)
        poses.append(samples.origin)
        hits.append(samples.hits)
        test_xy.append(part.test_xy if holdout > 0 else np.vstack([samples.hits, samples.free]))
        test_occ.append(part.test_occ if holdout > 0 else
                        np.r_[np.ones(len(samples.hits), bool), np.zeros(len(samples.free), bool)])
    wall = time.perf_counter() - tic
    if not poses:
        raise ValueError("map_keyframes: no keyframes")
    xy, occ = np.vstack(test_xy), np.concatenate(test_occ)
    prob = com.prob()
    ms = 1e3 * np.asarray(update_s)
    metrics = {
        "keyframes": len(poses),
        "wall_time_s": wall,
        "update_ms_median": float(np.median(ms)),
        "update_ms_p95": float(np.percentile(ms, 95)),
        "holdout": {"fraction": holdout, "protocol": protocol if holdout > 0 else "none (resubstitution)",
                    "points": int(len(occ))},
        **auc_readings(occ, com.frame, prob, xy),
        # over the bounding box of the observed cells (the arrays carry growth padding)
        "entropy_nats_0.2m": map_entropy(prob[com.observed_bounds()], com.resolution, 0.2),
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
    return MapRun(com, np.asarray(poses), np.vstack(hits), update_s, metrics)
