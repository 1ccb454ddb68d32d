"""Pose SLAM on every log in the shared data: one row per log, the worst case beside the mean.

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_slam_suite.py
        [--logs NAME ...] [--perturb 5] [--seed 0] [--config FILE]

Prints, never asserts, per log: scans, keyframes and loop closures; the real-time factor of
Pose SLAM and its wall time against the scan-matching front end alone (loop closing off) in the
same run; for GMapping-corrected logs, the agreement with GMapping's poses after SE(2) alignment,
matched by scan order (RMSE, p95, max, heading RMSE: GMapping's maps are good, but not ground
truth), and the scale and RMSE of the best similarity alignment (a difference of scale alone is
a longer or shorter trajectory throughout, such as the distance along a featureless corridor,
which is the wheels'); the map's self-consistency, which needs no reference
(``slam.consistency``: how far each scan point lies from the surfaces the scans 5 m of travel
away saw there; median and p90, and beside them GMapping's poses' on a corrected log, and our
poses' scaled to GMapping's scale, so that a disagreement with GMapping can be told from a worse
map, and the scans say whose scale they support); for MIT CSAIL, the Kümmerle relation error
(mean, short/long, p95, max). With ``--perturb N``, N more replays with the ranges perturbed by
seeded 1 mm Gaussian noise: the largest trajectory RMSE between a perturbed replay and the clean
one, and the spread (max − min) of their agreement with GMapping. A crash is a row too, with its
error. ``--config`` replays with the ``[stack.slam]`` section of a configuration file, as
``gpexplore replay --config`` does (TOML or YAML: ``gpexplore config dump`` writes one, a run's
config.toml is one), instead of the defaults; a bad file stops the benchmark before any replay,
naming the file and the key.

Targets (issue 12): 0 crashes; agreement RMSE ≤ 0.10 m and max ≤ 0.5 m on each corrected log;
CSAIL ≤ 0.025 m / 0.33° mean, worst relation ≤ 0.3 m; perturbed replays within 0.05 m; on
CSAIL with false loops injected after verification (50 % as many as the true ones), the relation
error within 10 % of the clean run's.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
import traceback
from pathlib import Path

import gtsam
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.config_file import ConfigError, read_config  # noqa: E402
from sim.data import benchmark_data_dir  # noqa: E402
from sim.logs import replay_log  # noqa: E402
from slam.agreement import agreement  # noqa: E402
from slam.carmen import CarmenLog  # noqa: E402
from slam.config import SlamConfig  # noqa: E402
from slam.evaluation import read_relations, relation_error  # noqa: E402
from slam.false_loops import inject_false_loops  # noqa: E402
from slam.pose_slam import PoseSlam  # noqa: E402
from slam.replay import log_consistency, replay_metrics  # noqa: E402


#: Chance that a candidate verification turned down returns a false loop instead: on MIT CSAIL
#: about 50 % as many false loops as true ones.
FALSE_LOOP_RATE = 0.12


def _cm(metres: float | None) -> str:
    return "—" if metres is None else f"{100 * metres:.2f} cm"


def perturbed(log: CarmenLog, sigma: float, seed: int) -> CarmenLog:
    """A copy of ``log`` whose finite ranges carry extra N(0, sigma²) noise (m), seeded."""
    rng = np.random.default_rng(seed)
    copy = CarmenLog.__new__(CarmenLog)
    copy.__dict__.update(log.__dict__)
    records = []
    for r in log:
        ranges = r.scan.ranges.copy()
        hit = np.isfinite(ranges) & (ranges < r.scan.max_range)
        ranges[hit] += rng.normal(0.0, sigma, hit.sum())
        records.append(dataclasses.replace(r, scan=dataclasses.replace(r.scan, ranges=ranges)))
    copy.records = records
    return copy


def row(path: Path, relations_dir: Path, perturb: int, seed: int, config: SlamConfig) -> str:
    log = CarmenLog(path)
    no_loops = config.model_copy(deep=True)
    no_loops.loop_closure.enabled = False
    front = replay_log(log, no_loops)
    full = replay_log(log, config)
    m = replay_metrics(log, full)
    rtf = m["real_time_factor"]
    out = [f"{path.name}: {len(log)} scans, {m['keyframes']} keyframes, {m['loop_closures']} loops "
           f"({m['loops']['proposed']} proposed, {m['loops']['verified']} verified), "
           f"{'%.1fx real time' % rtf if rtf else 'no stamps'}, {full.wall_time:.1f} s wall = "
           f"{full.wall_time / front.wall_time:.2f}x the front end; largest correction "
           f"{m['largest_correction_m']:.2f} m; fallbacks {m['fallbacks'] or 'none'}"]
    corrected = "corrected" in path.name
    if corrected:
        a = agreement(full.trajectory, [r.pose for r in log])
        f = agreement(front.trajectory, [r.pose for r in log])
        out.append(f"  vs GMapping: RMSE {a['rmse_m']:.3f} m, p95 {a['p95_m']:.3f}, max {a['max_m']:.3f}, "
                   f"heading RMSE {a['rot_rmse_deg']:.2f} deg; GMapping's scale {a['scale']:.4f}, similarity "
                   f"RMSE {a['similarity_rmse_m']:.3f} m (front end alone: RMSE {f['rmse_m']:.3f} m, "
                   f"max {f['max_m']:.3f})")
    c = m["self_consistency"]
    line = (f"  self-consistency: {100 * c['revisited']:.0f} % of points seen again, "
            f"{_cm(c['median_m'])} median, {_cm(c['p90_m'])} p90")
    if corrected:
        g = log_consistency(log, [r.pose for r in log], full.slam)
        at_scale = log_consistency(log, [gtsam.Pose2(a["scale"] * p.x(), a["scale"] * p.y(), p.theta())
                                         for p in full.trajectory], full.slam)
        line += (f" (GMapping's poses: {_cm(g['median_m'])}, {_cm(g['p90_m'])}; ours at GMapping's scale: "
                 f"{_cm(at_scale['median_m'])}, {_cm(at_scale['p90_m'])})")
    out.append(line)
    relations = relations_dir / (path.name.split(".")[0] + ".relations")
    if relations.exists():
        odometry = [r.odometry for r in log]
        e = relation_error(read_relations(relations), full.stamps, full.trajectory,
                           odometry if None not in odometry else None).summary()
        parts = [f"{k} {e[k]['trans_mean_m']:.4f} m {e[k]['rot_mean_deg']:.3f} deg"
                 for k in ("all", "short_lt_5s", "long_ge_5s")]
        out.append(f"  relations: {' | '.join(parts)}; p95 {e['all']['trans_p95_m']:.3f} m, "
                   f"max {e['all']['trans_max_m']:.3f} m")
        slam = PoseSlam(config)
        injected = inject_false_loops(slam, rate=FALSE_LOOP_RATE, seed=seed)
        dirty = replay_log(log, slam=slam)
        d = relation_error(read_relations(relations), dirty.stamps, dirty.trajectory,
                           odometry if None not in odometry else None).summary()["all"]
        kept = sum(any(loop is false for loop in slam.loops) for false in injected)
        out.append(f"  {len(injected)} false loops injected ({len(injected) / max(len(full.slam.loops), 1):.0%} "
                   f"of the true ones), {kept} kept: relation error {d['trans_mean_m']:.4f} m "
                   f"{d['rot_mean_deg']:.3f} deg ({d['trans_mean_m'] / e['all']['trans_mean_m']:.2f}x the clean run)")
    if perturb:
        between, against = [], []
        for k in range(perturb):
            other = replay_log(perturbed(log, 0.001, seed + k), config)
            between.append(agreement(other.trajectory, full.trajectory)["rmse_m"])
            if corrected:
                against.append(agreement(other.trajectory, [r.pose for r in log])["rmse_m"])
        spread = f", agreement with GMapping {min(against):.3f}-{max(against):.3f} m " \
                 f"(spread {max(against) - min(against):.3f})" if against else ""
        out.append(f"  {perturb} replays with 1 mm range noise: RMSE to the clean replay max "
                   f"{max(between):.3f} m{spread}")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", nargs="*", help="logs whose file names start with these (default: every log)")
    parser.add_argument("--perturb", type=int, default=5, help="replays with 1 mm range noise per log")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first perturbed replay")
    parser.add_argument("--config", type=Path, help="Pose SLAM configuration file (default: the defaults)")
    args = parser.parse_args()
    try:
        config = read_config(args.config).stack.slam if args.config else SlamConfig()
    except ConfigError as err:
        parser.error(str(err))
    data = benchmark_data_dir()
    paths = sorted(p for p in (data / "logs").iterdir() if p.name.endswith((".clf", ".log", ".gz")))
    unknown = [name for name in args.logs or [] if not any(p.name.startswith(name) for p in paths)]
    if unknown:
        parser.error(f"no log in {data / 'logs'} starts with {', '.join(unknown)} "
                     f"(have: {', '.join(p.name for p in paths)})")
    if args.logs:
        paths = [p for p in paths if any(p.name.startswith(name) for name in args.logs)]
    crashes = 0
    for path in paths:
        tic = time.perf_counter()
        try:
            print(row(path, data / "relations", args.perturb, args.seed, config), flush=True)
        except Exception:                                   # a crash is a result here
            crashes += 1
            print(f"{path.name}: CRASH\n{traceback.format_exc()}", flush=True)
        print(f"  ({time.perf_counter() - tic:.0f} s)", flush=True)
    print(f"{len(paths)} logs, {crashes} crashes")


if __name__ == "__main__":
    main()
