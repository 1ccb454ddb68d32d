"""Pose SLAM on the simulator's scripted tours: one row per world and seed, the worst case beside
the mean.

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_slam_sim.py
        [--worlds office room] [--seeds 10]

Each seed drives the built-in world's tour (``sim.tour.demo_tour``: the lidar's and the wheels'
noise drawn from the seed) and replays it through Pose SLAM with the default configuration. It
prints, never asserts, per run: scans, keyframes, loop closures, the real-time factor, and the
trajectory's error against the truth after SE(2) alignment (``slam.agreement``: RMSE, max, heading
RMSE) beside the raw odometry's. ``office`` is the 40 m x 30 m office (rooms off a corridor);
``room`` the 10 m x 8 m room with a box in its middle, which looks the same turned by half a
turn (a loop to the place opposite is a false one). A crash is a row too, with its error.

Targets (issue 12), 10 seeds each: the office ATE ≤ 0.10 m; the room ATE ≤ 0.10 m and below the
odometry's.
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.tour import demo_tour  # noqa: E402
from sim.worlds import BUILTIN_WORLDS  # noqa: E402
from slam.agreement import agreement  # noqa: E402
from slam.pose_slam import PoseSlam  # noqa: E402

#: ATE (m) each world's runs should stay within, and whether they should beat the odometry
TARGETS = {"office": (0.10, False), "room": (0.10, True)}


def run(world: str, seed: int) -> dict:
    """One tour through Pose SLAM: the row's figures."""
    log, tour = demo_tour(BUILTIN_WORLDS[world](), seed)
    slam = PoseSlam()
    tic = time.perf_counter()
    for odometry, scan in zip(log.odometry, log.scans):
        slam.step(odometry, scan)
    wall = time.perf_counter() - tic
    return {"scans": len(log.scans), "travel_m": tour["travel_distance_m"], "keyframes": len(slam.graph),
            "loops": len(slam.loops), "realtime": tour["sim_time_s"] / wall,
            "slam": agreement(slam.trajectory(), log.truth), "odometry": agreement(log.odometry, log.truth)}


def row(world: str, seed: int, r: dict) -> str:
    s, o = r["slam"], r["odometry"]
    return (f"{world:<7}{seed:>5}{r['scans']:>7}{r['travel_m']:>8.1f}{r['keyframes']:>6}{r['loops']:>6}"
            f"{r['realtime']:>7.1f}x  ATE {s['rmse_m']:.3f} max {s['max_m']:.3f} m, {s['rot_rmse_deg']:.2f}°"
            f"  odometry {o['rmse_m']:.3f} max {o['max_m']:.3f} m")


def summary(world: str, runs: dict[int, dict], crashed: list[int]) -> str:
    limit, below_odometry = TARGETS.get(world, (np.inf, False))
    ate = {seed: r["slam"]["rmse_m"] for seed, r in runs.items()}
    if not ate:
        return f"{world}: every run crashed ({len(crashed)})"
    worst = max(ate, key=ate.get)
    missed = sorted(seed for seed, r in runs.items() if ate[seed] > limit
                    or (below_odometry and ate[seed] >= r["odometry"]["rmse_m"]))
    odometry = np.mean([r["odometry"]["rmse_m"] for r in runs.values()])
    target = f"≤ {limit:.2f} m" + (" and below odometry" if below_odometry else "")
    return (f"{world}: ATE mean {np.mean(list(ate.values())):.3f} m, worst {ate[worst]:.3f} m (seed {worst}); "
            f"odometry mean {odometry:.3f} m; loops {np.mean([r['loops'] for r in runs.values()]):.1f} a run; "
            f"target {target}: {len(runs) - len(missed)}/{len(runs) + len(crashed)} runs"
            + (f", missed by seeds {missed}" if missed else "") + (f", crashed seeds {crashed}" if crashed else ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", default=list(TARGETS), choices=list(BUILTIN_WORLDS))
    parser.add_argument("--seeds", type=int, default=10, help="runs per world, seeds 0..k-1")
    args = parser.parse_args()
    print(f"{'world':<7}{'seed':>5}{'scans':>7}{'travel':>8}{'keys':>6}{'loops':>6}{'speed':>8}")
    lines = []
    for world in args.worlds:
        runs, crashed = {}, []
        for seed in range(args.seeds):
            try:
                runs[seed] = run(world, seed)
                print(row(world, seed, runs[seed]), flush=True)
            except Exception as error:   # a crash is a result: report it, go on
                crashed.append(seed)
                print(f"{world:<7}{seed:>5}  CRASHED: {type(error).__name__}: {error}", flush=True)
                traceback.print_exc()
        lines.append(summary(world, runs, crashed))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
