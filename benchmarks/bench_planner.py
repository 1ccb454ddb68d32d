"""Planning cost against map size: one replan on the whole known map of each building.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_planner.py [--worlds stage_cave office_f office_g]
        [--hits-per-cell 16] [--repeats 3]

A replan (``Explorer.plan``) reads the whole map: the costmap's clearance to the hits, the
Dijkstra field from the robot, the frontier map and the door check. Its cost grows with the map,
and in the suite it ran every few scans, so it is what made a big building's cost per scan grow
(office_h's GP run spent half its time there). Here each world's true map, read at 0.1 m cells,
stands for a map the robot has finished: free where the robot's largest region and its walls
lie, unknown elsewhere, ``--hits-per-cell`` laser endpoints (1 cm noise) in each wall cell that
faces free space (office_d's run ended with 15 per such cell), from its seed-0 start.

Prints, per world: cells, hits, the median replan time and its reachable-field part, and their
ratios against the first world (the Stage cave by default), each replan with one more scan's
hits (``SCAN_HITS``) than the last, as in a run, where the clearance field of the hits seen
before is reused; and the median replan that keeps its goal (most replans of a run), on the
map seen within ``SEEN`` m of the start, where the first replan chose the goal (nan when the
goal was not kept); then the clearance to all the hits from scratch (``costmap.distance_to_points``
on hits it has not seen) against a k-d tree over the same hits queried at every free cell (what
it replaced), on the largest map. Prints, never asserts.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import gtsam  # noqa: E402
import numpy as np  # noqa: E402
from scipy import ndimage  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from exploration.costmap import distance_to_points  # noqa: E402
from exploration.explorer import Explorer, ExplorerConfig  # noqa: E402
from mapping.occupancy import MapSnapshot  # noqa: E402
from sim.campaign import suite_world_spec  # noqa: E402
from sim.data import shared_data_dir  # noqa: E402
from sim.suite import largest_region, sample_start, world_list  # noqa: E402

RESOLUTION = 0.1
#: hits one scan adds to the map between two replans (a 0.5° laser, thinned to a half cell)
SCAN_HITS = 200
#: m round the start that the map for the kept-goal replans has seen
SEEN = 8.0


def finished_map(name: str, data: Path, hits_per_cell: int, rng: np.random.Generator):
    """(snapshot, start pose) of world ``name`` as a finished run's map would read it."""
    radius = ExplorerConfig().robot_radius
    (spec, size), = world_list(data, data / "maps" / "suite", [name])
    world = suite_world_spec(spec, radius, size=size).load()
    start = sample_start(world, radius, 0)
    # the region's cells and the walls beside it, at 0.1 m cells
    seen = ndimage.binary_dilation(largest_region(world, radius),
                                   iterations=int(np.ceil(radius / min(world.resolution))) + 2)
    h, w = (np.ceil(np.asarray(world.size)[::-1] / RESOLUTION)).astype(int)
    yy, xx = np.mgrid[0:h, 0:w]
    centres = world.origin + RESOLUTION * (np.stack([xx, yy], axis=-1) + 0.5)
    cells = np.clip(((centres - world.origin) / world.resolution).astype(int), 0,
                    np.array(world.shape[::-1]) - 1)
    known = seen[cells[..., 1], cells[..., 0]]
    wall = ndimage.maximum_filter(world.occupied.astype(np.uint8),
                                  size=max(1, round(RESOLUTION / min(world.resolution))))
    wall = wall[cells[..., 1], cells[..., 0]].astype(bool)
    prob = np.where(known, np.where(wall, 0.9, 0.1), 0.5)
    facing = known & wall & ndimage.binary_dilation(known & ~wall)
    iy, ix = np.nonzero(facing)
    corners = np.repeat(np.column_stack([ix, iy]), hits_per_cell, axis=0)
    hits = (world.origin + RESOLUTION * (corners + rng.random(corners.shape))
            + rng.normal(0.0, 0.01, corners.shape))
    origin = np.asarray(world.origin, float) + 0.5 * RESOLUTION
    occ = np.where(known, np.where(wall, 0.9, 0.3), 0.5)
    return MapSnapshot(prob, occ, origin, RESOLUTION, hits=hits), start


def half_seen(snapshot: MapSnapshot, start: gtsam.Pose2, seen: float = SEEN) -> MapSnapshot:
    """``snapshot`` seen within ``seen`` m of the start alone (unknown beyond, without the hits
    there): a map with frontiers, whose goal later replans keep."""
    h, w = snapshot.prob.shape
    yy, xx = np.mgrid[0:h, 0:w]
    centres = snapshot.origin + RESOLUTION * np.stack([xx, yy], axis=-1)
    far = np.hypot(centres[..., 0] - start.x(), centres[..., 1] - start.y()) > seen
    hits = snapshot.hits[np.hypot(*(snapshot.hits - [start.x(), start.y()]).T) <= seen]
    return dataclasses.replace(snapshot, prob=np.where(far, 0.5, snapshot.prob),
                               prob_occ=np.where(far, 0.5, snapshot.prob_occ), hits=hits)


def growing(snapshot: MapSnapshot, replans: int):
    """``snapshot`` for each of ``replans`` replans, the last with all its hits, each before it
    with ``SCAN_HITS`` fewer: read-only views of one buffer, as ``LogOddsGrid.hits`` hands
    them out."""
    hits = snapshot.hits.copy()
    hits.flags.writeable = False
    for k in range(replans - 1, -1, -1):
        yield dataclasses.replace(snapshot, hits=hits[:len(hits) - k * SCAN_HITS])


def median_ms(f, repeats: int) -> float:
    f()                                                   # compiles, warms caches
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return 1000.0 * float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", nargs="+", default=["stage_cave", "office_f", "office_g"])
    parser.add_argument("--hits-per-cell", type=int, default=16)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    data = shared_data_dir()
    if data is None:
        sys.exit("shared data not found (set GPEXPLORE_DATA)")
    rng = np.random.default_rng(0)
    rows = []
    for name in args.worlds:
        snapshot, start = finished_map(name, Path(data), args.hits_per_cell, rng)
        grown = growing(snapshot, 2 * (args.repeats + 1))
        explorer = Explorer(ExplorerConfig())
        reach = median_ms(lambda: explorer._reachable(next(grown), start), args.repeats)
        replan = median_ms(lambda: Explorer(ExplorerConfig()).plan(next(grown), start), args.repeats)
        part = growing(half_seen(snapshot, start), args.repeats + 2)
        keeping = Explorer(ExplorerConfig())
        chosen = keeping.plan(next(part), start).goal is not None
        kept = median_ms(lambda: keeping.plan(next(part), start), args.repeats)
        rows.append((name, snapshot, reach, replan, kept if chosen and keeping.goals_chosen == 1 else np.nan))
    base = rows[0]
    print(f"{'world':>16} {'cells':>9} {'hits':>9} {'replan ms':>10} {'x':>6} {'field ms':>9} {'x':>6} "
          f"{'kept ms':>8} {'x':>6}")
    for name, snapshot, reach, replan, kept in rows:
        print(f"{name:>16} {snapshot.prob.size:>9} {len(snapshot.hits):>9} {replan:>10.1f} "
              f"{replan / base[3]:>6.2f} {reach:>9.1f} {reach / base[2]:>6.2f} {kept:>8.1f} {kept / base[4]:>6.2f}")
    name, snapshot, *_ = max(rows, key=lambda r: r[1].prob.size)
    free = snapshot.prob < 0.35
    iy, ix = np.nonzero(free)
    centres = snapshot.origin + RESOLUTION * np.column_stack([ix, iy])
    moved = iter([snapshot.hits + 1e-6 * k for k in range(args.repeats + 1)])   # a rebuild each time
    ours = median_ms(lambda: distance_to_points(next(moved), snapshot.origin, RESOLUTION,
                                                free.shape, 0.27), args.repeats)
    tree = median_ms(lambda: cKDTree(snapshot.hits).query(centres, distance_upper_bound=0.6),
                     args.repeats)
    print(f"clearance to the hits on {name} ({len(centres)} free cells): scattered {ours:.0f} ms, "
          f"k-d tree {tree:.0f} ms ({tree / ours:.1f}x)")


if __name__ == "__main__":
    main()
