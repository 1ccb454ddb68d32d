"""The floor-plan suite: both explorers on every building, seeded random starts, Pose SLAM in the loop.

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_suite.py [--seeds 3]
        [--worlds lab_a office_g cave ...] [--workers 1] [--out DIR] [--max-steps N] [--suite DIR]

Runs C-frontier (gp) and the grid baseline on the 16 maps of ``maps/suite/`` (``manifest.csv``)
and on the extra worlds: the built-in ``cave`` and ``office``, the Stage cave at 20 m x 20 m
(``stage_cave``) and ``simple_rooms`` at 40 m x 30 m; over seeds 0..k-1, each seed's run starting
at its random pose in the largest free region (0.5 m from walls, the same for both methods), with
a step budget that grows with the free area (``sim.suite.step_budget``); ``--max-steps`` caps it
for a smoke test. Runs land in --out (``<world>/<method>/seed_<k>/``) and are not redone when the
benchmark is run again; a run that crashes keeps its traceback in its folder's error.json and
counts as failed. --workers runs at a time (default 1: cost per scan is a figure here).

Writes ``suite.md`` and ``suite.csv`` (one row per world and method: runs that succeeded,
crashes, coverage mean and worst, travel, tail = travel after 99 % coverage as a share of travel,
late = travel after the last 1 m² seen as a share of travel (the part of the tail the stop could
have saved), missed area, how runs ended, collisions, ATE, cost per scan) and Table I per world
(``table.md``), prints the table, then one summary line. Prints, never asserts. Targets (issue
13): every run ends by itself with >= 99 % coverage, 0 crashes, 0 collisions, gp/grid travel
<= 1, tail <= 10 %, GP cost per scan on office_g <= 1.5x the cave's, the whole suite, both
methods, 3 seeds, within 60 min on 2 cores.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.campaign import (check_resumable, plan, run_campaign, run_line, suite_world_spec,  # noqa: E402
                          write_tables)
from sim.data import benchmark_data_dir  # noqa: E402
from sim.engines import LocalEngine  # noqa: E402
from sim.episode import EpisodeConfig  # noqa: E402
from sim.suite import (EXTRA_WORLDS, outcome, rows_csv, rows_markdown, suite_rows,  # noqa: E402
                       suite_summary, summary_line, world_list)
from slam.atomic import write_text_atomic  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="seeds 0..N-1 (default 3)")
    parser.add_argument("--worlds", nargs="+", default=None,
                        help=f"suite map names (lab_a ...) and extras ({', '.join(EXTRA_WORLDS)}); default all")
    parser.add_argument("--workers", type=int, default=1, help="runs at a time (default 1)")
    parser.add_argument("--out", type=Path, default=None, help="keep the runs here (resumable)")
    parser.add_argument("--max-steps", type=int, default=None, help="cap every world's step budget (smoke tests)")
    parser.add_argument("--suite", type=Path, default=None, help="suite folder or manifest.csv "
                        "(default: the shared data's maps/suite)")
    args = parser.parse_args(argv)
    data = benchmark_data_dir()     # warns unless BLAS is single-threaded
    base = EpisodeConfig()          # Pose SLAM in the loop (stack.poses = "slam")
    configs = {m: base.overridden(method=m) for m in ("gp", "grid")}
    try:
        chosen = world_list(data, args.suite or data / "maps" / "suite", args.worlds)
    except (FileNotFoundError, ValueError) as err:
        raise SystemExit(str(err)) from None
    worlds = [suite_world_spec(spec, base.robot.radius, size=size, max_steps=args.max_steps)
              for spec, size in chosen]
    out = (args.out or Path(tempfile.mkdtemp(prefix="bench_suite_"))).absolute()
    runs = plan(out, worlds, configs, list(range(args.seeds)))
    try:
        check_resumable(runs)       # a folder of another configuration, budget or start is not mixed in
    except ValueError as err:
        raise SystemExit(str(err)) from None
    print(f"{len(worlds)} worlds x 2 methods x {args.seeds} seeds = {len(runs)} runs, {args.workers} at a time, "
          f"in {out}; step budgets: " + ", ".join(f"{w.name} {w.max_steps}" for w in worlds), flush=True)

    tic = time.perf_counter()
    with LocalEngine(args.workers) as engine:
        run_campaign(runs, engine, lambda run, m, error: print(run_line(run, m, error), flush=True))
    wall = time.perf_counter() - tic

    outcomes = [outcome(r) for r in runs]
    rows = suite_rows(outcomes)
    table = rows_markdown(rows)
    write_text_atomic(out / "suite.md", table)
    write_text_atomic(out / "suite.csv", rows_csv(rows))
    write_tables(out, runs)
    print(f"\n{table}")
    print(summary_line(suite_summary(outcomes, wall)))


if __name__ == "__main__":
    main()
