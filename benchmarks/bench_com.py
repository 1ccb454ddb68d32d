"""The continuous occupancy map: accuracy against a tuned log-odds grid, and speed.

    python benchmarks/bench_com.py [--quick]

Prints, never asserts:
1. Intel (corrected log, its poses): ROC AUC of the COM and of a log-odds grid tuned on the
   same protocol, side by side, for 20 % held-out labelled points of each scan and for 20 %
   held-out whole beams. Each map read two ways at every test point: continuously (bilinear
   between cell centres; the headline, ``auc`` in metrics.json) and at the cell holding it
   (``auc_cell``); COM and grid are read the same way in each line, the grid tuned for it.
2. Whole-log mapping time (single thread), per-keyframe update median / p95.
3. The same local-GP work done by scikit-learn's GaussianProcessRegressor (fixed kernel, no
   optimiser), on the inputs captured from the COM run: time ratio and largest difference.
4. Per-keyframe cost on a map 4x the area (the built-in cave tiled 2 x 2) against the cave.
5. Regeneration of the whole COM of a 20 m x 20 m simulated run (the cave demo tour).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from typing import NamedTuple  # noqa: E402

import gtsam  # noqa: E402
import numpy as np  # noqa: E402

import mapping.com as com_module  # noqa: E402
from mapping.com import ContinuousOccupancyMap  # noqa: E402
from mapping.config import COMConfig  # noqa: E402
from mapping.holdout import split  # noqa: E402
from mapping.logodds import LogOddsConfig, LogOddsGrid  # noqa: E402
from mapping.metrics import auc_readings  # noqa: E402
from mapping.training import beam_samples  # noqa: E402
from sim.data import shared_data_dir  # noqa: E402
from slam.carmen import CarmenLog  # noqa: E402

GRID_CANDIDATES = [(l_occ, l_free) for l_occ in (0.85, 2.0, 3.0) for l_free in (-0.1, -0.2, -0.4)]
#: the two readings of a map at a test point (see mapping.metrics.auc_readings)
READINGS = {"auc": "read continuously (bilinear)", "auc_cell": "read at the cell holding each point"}


class GridRun(NamedTuple):
    auc: dict          # auc_readings of the grid
    l_occ: float
    l_free: float
    wall_s: float


def intel_accuracy(log: CarmenLog, protocol: str, seed: int = 0) -> dict:
    cfg = COMConfig()
    rng = np.random.default_rng(seed)
    parts = [split(beam_samples(r.pose, r.scan, cfg.training), len(r.scan), 0.2, protocol, rng)
             for r in log]
    xy = np.vstack([p.test_xy for p in parts])
    occ = np.concatenate([p.test_occ for p in parts])
    com = ContinuousOccupancyMap(cfg)
    times = []
    tic = time.perf_counter()
    for p in parts:
        t = time.perf_counter()
        com.update_samples(p.train)
        times.append(time.perf_counter() - t)
    wall = time.perf_counter() - tic
    out = {"com": auc_readings(occ, com.frame, com.prob(), xy), "com_wall_s": wall,
           "times": np.asarray(times), "test_points": len(occ)}
    grids = []
    for l_occ, l_free in GRID_CANDIDATES:
        grid = LogOddsGrid(LogOddsConfig(l_occ=l_occ, l_free=l_free))
        t = time.perf_counter()
        for r, p in zip(log, parts):
            if protocol == "points":   # all beams traced; held-out hits not marked
                grid.update(r.pose, r.scan, None, ~p.held_beams)
            else:                      # held-out beams not used at all
                grid.update(r.pose, r.scan, ~p.held_beams)
        grids.append(GridRun(auc_readings(occ, grid.frame, grid.prob(), xy), l_occ, l_free,
                             time.perf_counter() - t))
    # the grid is tuned for each reading separately: each line compares with the best grid in it
    out["grid"] = {reading: max(grids, key=lambda g: g.auc[reading]) for reading in READINGS}
    return out


def sklearn_ratio(log: CarmenLog, keyframes: int = 30) -> None:
    """Capture the local-GP inputs of ``keyframes`` COM updates, redo them with sklearn."""
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern

    from mapping.localgp import predict_blocks

    captured = []

    def spy(kernel, noise, pts, idx, qxy, start):
        captured.append((kernel, noise, pts, idx, qxy, start))
        return predict_blocks(kernel, noise, pts, idx, qxy, start)

    real = com_module.predict_blocks
    com_module.predict_blocks = spy
    try:
        com = ContinuousOccupancyMap()
        for r in log[200:200 + keyframes]:
            com.update(r.pose, r.scan)
    finally:
        com_module.predict_blocks = real
    t = time.perf_counter()
    ours = [predict_blocks(*c) for c in captured]
    t_ours = time.perf_counter() - t
    worst = 0.0
    t = time.perf_counter()
    blocks = 0
    for (kernel, noise, pts, idx, qxy, start), (m_ours, v_ours) in zip(captured, ours):
        sk = ConstantKernel(kernel.signal_var, "fixed") * Matern(kernel.matern_length, "fixed", nu=kernel.nu)
        if kernel.se_length is not None:
            sk = sk * RBF(kernel.se_length, "fixed")
        for b in range(len(idx)):
            sel = idx[b][idx[b] < len(pts)]
            Q = qxy[start[b]:start[b + 1]]
            if len(sel) == 0 or len(Q) == 0:
                continue
            blocks += 1
            gpr = GaussianProcessRegressor(sk, alpha=noise, optimizer=None, normalize_y=False)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                gpr.fit(pts[sel], np.ones(len(sel)))
                m, s = gpr.predict(Q, return_std=True)
            worst = max(worst, np.abs(m - m_ours[start[b]:start[b + 1]]).max(),
                        np.abs(s ** 2 - v_ours[start[b]:start[b + 1]]).max())
    t_sk = time.perf_counter() - t
    print(f"  local GPs of {keyframes} keyframes ({blocks} block GPs, both maps): ours {1e3 * t_ours:.0f} ms, "
          f"sklearn GaussianProcessRegressor {1e3 * t_sk:.0f} ms -> {t_sk / t_ours:.0f}x; "
          f"largest |difference| in mean or variance {worst:.1e}")


def random_free_poses(world, n: int, rng) -> list[gtsam.Pose2]:
    free = np.argwhere(world.clearance() > 0.4)
    pick = free[rng.choice(len(free), n, replace=False)]
    xy = world.center_of(pick[:, ::-1])
    return [gtsam.Pose2(x, y, a) for (x, y), a in zip(xy, rng.uniform(-np.pi, np.pi, n))]


def map_size_flatness() -> None:
    from sim.lidar import Lidar
    from sim.world import World
    from sim.worlds import cave

    small = cave().world
    big = World(np.tile(small.occupied, (2, 2)), small.resolution, small.origin, "cave 2x2")
    medians = {}
    for world, n in ((small, 100), (big, 400)):
        rng = np.random.default_rng(7)
        lidar = Lidar(seed=7)
        poses = random_free_poses(world, n, rng)
        scans = [lidar.scan(world, p) for p in poses]
        com = ContinuousOccupancyMap()
        times = []
        for p, s in zip(poses, scans):
            t = time.perf_counter()
            com.update(p, s)
            times.append(time.perf_counter() - t)
        medians[world.name] = 1e3 * np.median(times[5:])
        w, h = world.size
        print(f"  {world.name}: {w:.0f} m x {h:.0f} m, {n} keyframes, map {com.prob().shape}: "
              f"update median {medians[world.name]:.2f} ms, p95 {1e3 * np.percentile(times, 95):.2f} ms")
    a, b = medians.values()
    print(f"  median cost ratio, 4x area / 1x: {b / a:.2f} (target <= 1.5)")


def regeneration_time() -> None:
    from sim.lidar import Lidar
    from sim.odometry import Odometry
    from sim.robot import Robot
    from sim.tour import drive_tour
    from sim.worlds import cave

    builtin = cave()
    log = drive_tour(Robot(builtin.world, builtin.start), Lidar(seed=3), Odometry(seed=3), builtin.tour)
    keyframes, last = [], None
    for pose, scan in zip(log.truth, log.scans):   # a keyframe every 0.5 m or 30 degrees
        if last is None or np.hypot(*last.between(pose).translation()) > 0.5 or \
                abs(last.between(pose).theta()) > np.pi / 6:
            keyframes.append((pose, scan))
            last = pose
    com = ContinuousOccupancyMap()
    t = time.perf_counter()
    for p, s in keyframes:
        com.update(p, s)
    first = time.perf_counter() - t
    best = np.inf
    for _ in range(3):
        t = time.perf_counter()
        com.regenerate(keyframes)
        best = min(best, time.perf_counter() - t)
    print(f"  cave demo tour: {len(log.scans)} scans, {len(keyframes)} keyframes; first build "
          f"{first:.2f} s (includes the hyperparameter fit), regeneration {best:.2f} s (best of 3; "
          f"target <= 2 s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="skip the simulated-world parts")
    args = parser.parse_args()
    ContinuousOccupancyMap().update(gtsam.Pose2(), _warmup_scan())   # numba compile / cache load
    data = shared_data_dir()
    if data is None:
        print("shared data not found: skipping the Intel parts")
    else:
        log = CarmenLog(data / "logs" / "intel-corrected.log.gz")
        print(f"Intel corrected log, {len(log)} scans, FLASER poses, COM defaults "
              f"(0.1 m cells, 10 m range); grid tuned over {len(GRID_CANDIDATES)} (l_occ, l_free):")
        for protocol in ("points", "beams"):
            r = intel_accuracy(log, protocol)
            t = 1e3 * r["times"]
            print(f" hold-out 20 % {protocol} ({r['test_points']} test points):")
            for reading, how in READINGS.items():
                com, grid = r["com"][reading], r["grid"][reading]
                print(f"   AUC {how}: COM {com:.4f} | log-odds grid {grid.auc[reading]:.4f} (l_occ "
                      f"{grid.l_occ}, l_free {grid.l_free}) -> COM - grid {com - grid.auc[reading]:+.4f}")
            print(f"   COM whole log {r['com_wall_s']:.2f} s single-threaded (update median {np.median(t):.2f} ms, "
                  f"p95 {np.percentile(t, 95):.2f} ms, first {t[0]:.0f} ms with the fit); grid "
                  f"{r['grid']['auc'].wall_s:.2f} s")
        print("sklearn baseline:")
        sklearn_ratio(log)
    if not args.quick:
        print("cost per keyframe against map size (random free poses, 361-beam 8 m lidar):")
        map_size_flatness()
        print("regeneration:")
        regeneration_time()


def _warmup_scan():
    from slam.scan import LaserScan

    angles = np.deg2rad(np.arange(-90, 91, 1.0))
    return LaserScan(np.full(181, 3.0), angles, 8.0)


if __name__ == "__main__":
    main()
