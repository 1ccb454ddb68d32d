"""A campaign's runs on the local engine's process pool against the same runs one after another.

    python benchmarks/bench_campaign.py [--world cave] [--method gp] [--runs 4] [--workers 2]
        [--max-steps 400] [--poses slam]

Prints, never asserts: the wall time of the runs done serially in this process, then on a pool
of --workers processes (spawning and importing included), their ratio (target with 4 runs on 2
free cores: about 0.5) and whether both gave the same metrics, and the machine's load average:
on a machine busy with other work the ratio is worse than the cores alone would give.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.campaign import WorldSpec, execute, plan, results, run_campaign  # noqa: E402
from sim.engines import LocalEngine, single_threaded_workers  # noqa: E402
from sim.episode import EpisodeConfig  # noqa: E402
from sim.worlds import BUILTIN_WORLDS  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", default="cave", choices=list(BUILTIN_WORLDS))
    parser.add_argument("--method", default="gp", choices=["gp", "grid"])
    parser.add_argument("--runs", type=int, default=4, help="seeds 0..N-1")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--max-steps", type=int, default=400)
    parser.add_argument("--poses", default="slam", choices=["slam", "truth"])
    args = parser.parse_args()
    single_threaded_workers()  # the serial runs get the same one thread as each worker
    config = EpisodeConfig().overridden(args.method, args.poses, args.max_steps)
    start = BUILTIN_WORLDS[args.world]().start
    world = WorldSpec(args.world, (start.x(), start.y(), start.theta()))
    seeds = list(range(args.runs))
    out = Path(tempfile.mkdtemp(prefix="bench_campaign_"))
    serial, pooled = plan(out / "serial", [world], {args.method: config}, seeds), \
        plan(out / "pool", [world], {args.method: config}, seeds)

    load = os.getloadavg()[0]
    tic = time.perf_counter()
    for run in serial:
        execute(run)
    serial_wall = time.perf_counter() - tic
    tic = time.perf_counter()
    with LocalEngine(args.workers) as engine:
        summary = run_campaign(pooled, engine)
    pool_wall = time.perf_counter() - tic

    def runs(campaign):
        return [{k: v for k, v in m.items() if k not in ("wall_time_s", "onboard_time_s")}
                for m in results(campaign)[world.name][args.method]]

    print(f"{args.runs} {args.method} runs on {args.world} ({args.max_steps} steps, poses {args.poses}), "
          f"runs in {out}")
    print(f"serial, in this process:      {serial_wall:7.1f} s")
    print(f"local engine, {args.workers} workers:     {pool_wall:7.1f} s  ({summary['failed']} failed)")
    print(f"ratio pool / serial:          {pool_wall / serial_wall:7.2f}  (target about {1 / args.workers:.2f})")
    same = json.dumps(runs(serial), sort_keys=True) == json.dumps(runs(pooled), sort_keys=True)
    print(f"same metrics both ways:       {'yes' if same else 'NO'}")
    print(f"machine load (1 min average) at the start {load:.1f}, at the end {os.getloadavg()[0]:.1f}, "
          f"on {os.cpu_count()} cores: other work shares them")


if __name__ == "__main__":
    main()
