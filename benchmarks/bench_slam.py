"""Pose SLAM on the MIT CSAIL log: Kümmerle relation error and speed, against baselines of the
same run (raw odometry, and the scan-matching front end without loop closures).

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_slam.py [--repeat 1]

Published figures on this log (mean ± std): Cartographer 0.0319 ± 0.0363 m, 0.369 ± 0.365 deg
at 12x real time on a 6-core Xeon (Hess et al. 2016); graph mapping 0.004 ± 0.009 m
(Kümmerle et al. 2009).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.data import benchmark_data_dir  # noqa: E402
from slam.carmen import CarmenLog  # noqa: E402
from slam.config import SlamConfig  # noqa: E402
from slam.evaluation import read_relations, relation_error  # noqa: E402
from sim.logs import replay_log  # noqa: E402


def line(name: str, summary: dict) -> str:
    parts = []
    for key in ("all", "short_lt_5s", "long_ge_5s"):
        e = summary[key]
        parts.append(f"{key} {e['trans_mean_m']:.4f} ± {e['trans_std_m']:.4f} m, "
                     f"{e['rot_mean_deg']:.3f} ± {e['rot_std_deg']:.3f} deg")
    return f"{name:<22}" + " | ".join(parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1, help="full SLAM runs (timing spread)")
    args = parser.parse_args()
    data = benchmark_data_dir()
    log = CarmenLog(data / "logs" / "mit-csail.clf")
    relations = read_relations(data / "relations" / "mit-csail.relations")
    odometry = [r.odometry for r in log]
    stamps = [r.scan.timestamp for r in log]
    print(f"mit-csail.clf: {len(log)} scans, {log.duration:.1f} s of data, {len(relations.t1)} relations")

    print(line("raw odometry", relation_error(relations, stamps, odometry).summary()))

    no_loops = SlamConfig()
    no_loops.loop_closure.enabled = False
    front = replay_log(log, no_loops)
    print(line("front end, no loops", relation_error(relations, front.stamps, front.trajectory, odometry).summary()))

    walls = []
    for _ in range(args.repeat):
        full = replay_log(log)
        walls.append(full.wall_time)
    print(line("Pose SLAM", relation_error(relations, full.stamps, full.trajectory, odometry).summary()))
    slam = full.slam
    print(f"keyframes {len(slam.graph)}, loop closures {len(slam.loops)}, verified candidates "
          f"{slam.detector.tried}, rejected {dict(slam.detector.rejected)}")
    best = min(walls)
    print(f"wall time: front end only {front.wall_time:.1f} s ({log.duration / front.wall_time:.1f}x real time); "
          f"Pose SLAM {best:.1f} s best of {len(walls)} ({log.duration / best:.1f}x real time); "
          f"loop closing costs {best / front.wall_time:.2f}x the front end")


if __name__ == "__main__":
    main()
