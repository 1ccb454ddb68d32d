"""Pose SLAM with other common 2-D lidars and odometry: one row per world, sensor setup and seed.

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_slam_sensors.py
        [--worlds office room] [--seeds 3] [--setups default 360-360b-12m ...]

Every setup drives the built-in world's scripted tour (``sim.tour.drive_tour``, the robot, the
tour and the seeding as in ``sim.tour.demo_tour``) with its own lidar (``sim.lidar.LidarConfig``:
field of view, beams, range, noise, dropouts, rate) and wheel odometry (``sim.odometry``'s noise),
and replays it through Pose SLAM with the DEFAULT configuration, as a user who does not tune
would. ``default`` is the laser all tuning used (180°, 361 beams, 8 m, 10 Hz, σ 1 cm) and is
bench_slam_sim's run to the bit; ``no-wheels`` drives the default sensors but gives Pose SLAM no
odometry (``step(None, scan)``, as a log without odometry is replayed), and ``no-wheels-360-12m``
does so with the 360° 12 m lidar that a robot without wheel odometry more likely carries.

It prints, never asserts, per run: scans, keyframes, loop closures, the real-time factor (tour
time / SLAM wall time), the trajectory's error against the truth after SE(2) alignment
(``slam.agreement``: RMSE, max, heading RMSE) beside the raw odometry's (``-`` where SLAM was not
given it), the front end's correlative searches and its links that fell back on the motion prior;
then, per world and setup, the mean ATE and its ratio to the default's measured in the same run.
A crash is a row too: its exception and the last frames of its traceback.
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.lidar import Lidar, LidarConfig  # noqa: E402
from sim.odometry import Odometry, OdometryNoise  # noqa: E402
from sim.robot import Robot  # noqa: E402
from sim.tour import drive_tour  # noqa: E402
from sim.worlds import BUILTIN_WORLDS  # noqa: E402
from slam.agreement import agreement  # noqa: E402
from slam.pose_slam import PoseSlam  # noqa: E402

#: wheel noise three times the default's σ (the model's α are variances: 9 times)
_NOISE_X3 = OdometryNoise(**{name: 9.0 * value for name, value in OdometryNoise().model_dump().items()})

#: name → (lidar, wheel noise, whether Pose SLAM gets the wheel odometry)
SETUPS: dict[str, tuple[LidarConfig, OdometryNoise, bool]] = {
    "default": (LidarConfig(), OdometryNoise(), True),
    "360-360b-12m": (LidarConfig(fov_deg=360, beams=360, max_range=12.0), OdometryNoise(), True),
    "360-720b-25m": (LidarConfig(fov_deg=360, beams=720, max_range=25.0), OdometryNoise(), True),
    "270-1081b-30m": (LidarConfig(fov_deg=270, beams=1081, max_range=30.0), OdometryNoise(), True),
    "short-4m-181b": (LidarConfig(max_range=4.0, beams=181), OdometryNoise(), True),
    "sigma-3cm": (LidarConfig(range_sigma=0.03), OdometryNoise(), True),
    "dropout-10%-nan": (LidarConfig(dropout=0.1, dropout_value="nan"), OdometryNoise(), True),
    "40hz": (LidarConfig(rate_hz=40.0), OdometryNoise(), True),
    "5hz": (LidarConfig(rate_hz=5.0), OdometryNoise(), True),
    "wheels-x3": (LidarConfig(), _NOISE_X3, True),
    "no-wheels": (LidarConfig(), OdometryNoise(), False),
    "no-wheels-360-12m": (LidarConfig(fov_deg=360, beams=360, max_range=12.0), OdometryNoise(), False),
}


def run(world: str, setup: str, seed: int) -> dict:
    """One tour with ``setup``'s sensors through Pose SLAM: the row's figures."""
    lidar_config, noise, wheels = SETUPS[setup]
    builtin = BUILTIN_WORLDS[world]()
    lidar_seed, odometry_seed = np.random.SeedSequence(seed).spawn(2)    # as demo_tour seeds them
    robot = Robot(builtin.world, builtin.start)
    # drive_tour's cap counts scans: demo_tour's 20000 at 10 Hz are 2000 s, which a 40 Hz lidar's
    # scans would use up before the office tour's end; the same 2000 s at every rate
    max_steps = round(20000 * lidar_config.rate_hz / LidarConfig().rate_hz)
    log = drive_tour(robot, Lidar(lidar_config, seed=lidar_seed), Odometry(noise, seed=odometry_seed), builtin.tour,
                     max_steps=max_steps)
    slam = PoseSlam()
    tic = time.perf_counter()
    for odometry, scan in zip(log.odometry, log.scans):
        slam.step(odometry if wheels else None, scan)
    wall = time.perf_counter() - tic
    return {"scans": len(log.scans), "travel_m": robot.distance, "keyframes": len(slam.graph),
            "loops": len(slam.loops), "realtime": log.stamps[-1] / wall,
            "slam": agreement(slam.trajectory(), log.truth),
            "odometry": agreement(log.odometry, log.truth) if wheels else None,
            "correlative": slam.front_end.counts["correlative_searches"],
            "prior_links": slam.fallbacks["motion_prior_links"], "wall_s": wall}


HEADER = (f"{'world':<7}{'setup':<18}{'seed':>4}{'scans':>7}{'travel':>7}{'keys':>6}{'loops':>6}{'speed':>7}"
          f"  {'ATE rmse':>8} {'max':>6} {'rot°':>6}  {'odo rmse':>8} {'max':>6}  {'fe-corr':>7} {'prior':>5}")


def row(world: str, setup: str, seed: int, r: dict) -> str:
    s, o = r["slam"], r["odometry"]
    odometry = f"{o['rmse_m']:>8.3f} {o['max_m']:>6.3f}" if o else f"{'-':>8} {'-':>6}"
    return (f"{world:<7}{setup:<18}{seed:>4}{r['scans']:>7}{r['travel_m']:>7.1f}{r['keyframes']:>6}{r['loops']:>6}"
            f"{r['realtime']:>6.1f}x  {s['rmse_m']:>8.3f} {s['max_m']:>6.3f} {s['rot_rmse_deg']:>6.2f}"
            f"  {odometry}  {r['correlative']:>7} {r['prior_links']:>5}")


def crash_row(world: str, setup: str, seed: int, error: Exception, frames: int = 4) -> str:
    """The crash's type and message, and the last ``frames`` frames of its traceback."""
    stack = traceback.extract_tb(error.__traceback__)[-frames:]
    where = "\n".join(f"        {Path(f.filename).name}:{f.lineno} in {f.name}: {f.line}" for f in stack)
    return f"{world:<7}{setup:<18}{seed:>4}  CRASHED: {type(error).__name__}: {error}\n{where}"


def summary(world: str, setup: str, runs: list[dict], crashed: int, baseline: float | None) -> str:
    if not runs:
        return f"{world:<7}{setup:<18} every run crashed ({crashed})"
    ate = [r["slam"]["rmse_m"] for r in runs]
    ratio = f"{np.mean(ate) / baseline:5.1f}x default" if baseline else "   - x default"
    odometry = [r["odometry"]["rmse_m"] for r in runs if r["odometry"]]
    return (f"{world:<7}{setup:<18} ATE mean {np.mean(ate):.3f} m, worst {max(ate):.3f} m, {ratio}; "
            f"odometry mean " + (f"{np.mean(odometry):.3f} m" if odometry else "-")
            + f"; loops {np.mean([r['loops'] for r in runs]):.1f}; {len(runs)}/{len(runs) + crashed} ran")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", default=["office", "room"], choices=list(BUILTIN_WORLDS))
    parser.add_argument("--seeds", type=int, default=3, help="runs per world and setup, seeds 0..k-1")
    parser.add_argument("--setups", nargs="+", default=list(SETUPS), choices=list(SETUPS))
    args = parser.parse_args()
    tic = time.perf_counter()
    print(HEADER, flush=True)
    lines = []
    for world in args.worlds:
        baseline = None
        for setup in args.setups:
            runs, crashed = [], 0
            for seed in range(args.seeds):
                try:
                    runs.append(run(world, setup, seed))
                    print(row(world, setup, seed, runs[-1]), flush=True)
                except Exception as error:   # a crash is a result: report it, go on
                    crashed += 1
                    print(crash_row(world, setup, seed, error), flush=True)
            if setup == "default" and runs:
                baseline = float(np.mean([r["slam"]["rmse_m"] for r in runs]))
            lines.append(summary(world, setup, runs, crashed, baseline))
    print("\n".join(lines))
    print(f"total wall time {time.perf_counter() - tic:.0f} s")


if __name__ == "__main__":
    main()
