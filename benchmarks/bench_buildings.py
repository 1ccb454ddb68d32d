"""Held-out buildings: generated floor plans, both explorers on each, the floor-plan suite's campaign.

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_buildings.py --count N --seed S
        --seeds K --out DIR [--workers 1] [--max-steps M]

Writes the buildings of seeds S..S+N-1 (``sim.buildings.building``, named ``building_<seed>``)
as ROS map YAMLs and PNGs with their ``manifest.csv`` in DIR/maps, prints what they hold, then
runs benchmarks/bench_suite.py on exactly those maps (``--suite DIR/maps --worlds ...``):
C-frontier (gp) and the grid baseline with Pose SLAM, seeds 0..K-1 from seeded random starts in
the largest free region, each map's step budget from its free area (``--max-steps`` caps it),
runs in DIR/<map>/<method>/seed_<k>/ and not redone when the benchmark is run again (the same
seeds write the same maps), and its suite.md, suite.csv, table.md, table and summary line.
Prints, never asserts. A building alone is ``sim.buildings.building(seed)``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_suite  # noqa: E402

from sim.buildings import building_name, write_buildings  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, required=True, help="buildings to generate")
    parser.add_argument("--seed", type=int, default=0, help="the first building's seed (default 0)")
    parser.add_argument("--seeds", type=int, default=3, help="run seeds 0..K-1 per building and method (default 3)")
    parser.add_argument("--out", type=Path, required=True, help="maps in OUT/maps, runs in OUT (resumable)")
    parser.add_argument("--workers", type=int, default=1, help="runs at a time (default 1)")
    parser.add_argument("--max-steps", type=int, default=None, help="cap every map's step budget (smoke tests)")
    args = parser.parse_args()
    if args.count < 1 or args.seed < 0:
        raise SystemExit(f"need --count >= 1 and --seed >= 0, got --count {args.count} --seed {args.seed}")
    seeds = range(args.seed, args.seed + args.count)
    out = args.out.absolute()

    tic = time.perf_counter()
    manifest = write_buildings(out / "maps", seeds)
    print(f"{args.count} buildings in {manifest.parent} ({time.perf_counter() - tic:.1f} s):", flush=True)
    with open(manifest, newline="") as f:
        for row in csv.DictReader(f):
            print(f"  {row['name']}: {row['width_m']} x {row['height_m']} m, {row['free_area_m2']} m² free, "
                  f"{row['rooms']} rooms, {row['corridors']} corridors, {row['doors']} doors "
                  f"(narrowest {row['narrowest_door_m']} m), {row['furniture']} furniture blocks"
                  + (", L-shaped" if row["l_shaped"] == "yes" else ""), flush=True)

    suite = ["--suite", str(manifest.parent), "--worlds", *map(building_name, seeds), "--seeds", str(args.seeds),
             "--workers", str(args.workers), "--out", str(out)]
    if args.max_steps is not None:
        suite += ["--max-steps", str(args.max_steps)]
    bench_suite.main(suite)


if __name__ == "__main__":
    main()
