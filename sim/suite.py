"""The floor-plan suite as a benchmark runs it: its worlds, a seeded random start in each, and a
step budget that grows with the free area to explore.

bc-exploration's recipe: many runs per map, each from a random start in the largest free region
the robot reaches, counted a success when the run ends by itself with the reachable space seen.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import gtsam
import numpy as np
from scipy import ndimage

from sim.world import World

#: A sampled start keeps the robot's centre at least this far (m) from every wall.
WALL_CLEARANCE = 0.5
#: Today's budget (scans), sized for the cave: the floor of every world's budget.
MIN_STEPS = 6000
#: Scans per m² of the robot's free area (see ``step_budget``).
STEPS_PER_M2 = 22.5
#: The worlds beside the suite's maps, as (spec, size in m or None): the built-in worlds, the
#: Stage cave at the paper's 20 m x 20 m (benchmarks/bench_explore.py's ``stage``) and Stage's
#: simple_rooms at 40 m x 30 m (``maps/map_scales.csv``), relative to the shared data folder.
EXTRA_WORLDS = {"cave": ("cave", None), "office": ("office", None),
                "stage_cave": ("maps/cave.png", (20.0, 20.0)),
                "simple_rooms": ("maps/simple_rooms.png", (40.0, 30.0))}


def largest_region(world: World, radius: float) -> np.ndarray:
    """(h, w) bool: the largest region a disc robot of ``radius`` m can move in, the cells whose
    clearance is at least ``radius``, 4-connected as in ``World.reachable``.

    Raises:
        ValueError: the robot fits nowhere in ``world``.
    """
    labels, n = ndimage.label(world.clearance() >= radius)
    if n == 0:
        raise ValueError(f"{world.name}: a robot of radius {radius} m fits nowhere")
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    return labels == int(np.argmax(sizes))


def sample_start(world: World, radius: float, seed: int,
                 clearance: float = WALL_CLEARANCE) -> gtsam.Pose2:
    """A random start for run ``seed``: the centre of a cell of ``largest_region`` whose disc of
    ``clearance`` m touches no wall (checked exactly, ``World.collides``), uniform over those
    cells, and a uniform heading in [-π, π). The same seed gives the same pose; the draw does not
    share a stream with the run's own noise (``run_episode`` spawns those from the seed).

    Raises:
        ValueError: no cell of the largest region is ``clearance`` m from the walls.
    """
    region = largest_region(world, radius)
    # clearance() is measured to the nearest wall cell's edge along the axes; a diagonal wall
    # corner can be up to 0.3 cell closer, hence the exact check on the drawn cells
    iy, ix = np.nonzero(region & (world.clearance() >= clearance))
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5747]))
    for k in rng.permutation(len(ix)):
        xy = world.center_of(np.array([ix[k], iy[k]]))
        if not world.collides(xy, clearance):
            return gtsam.Pose2(float(xy[0]), float(xy[1]), float(rng.uniform(-np.pi, np.pi)))
    raise ValueError(f"{world.name}: no place in the largest free region is {clearance} m from the walls "
                     f"(robot radius {radius} m)")


def free_area_m2(world: World, radius: float) -> float:
    """Area (m²) of ``largest_region``: where the robot's centre can be, the space it explores."""
    return float(largest_region(world, radius).sum() * world.resolution[0] * world.resolution[1])


def step_budget(area_m2: float) -> int:
    """The scans a run on ``area_m2`` of free area (``free_area_m2``) may take before it is
    stopped (``step_budget``): ``max(MIN_STEPS, ceil(STEPS_PER_M2 · area))``.

    Derivation: today's 6000 scans (600 s at 10 Hz) were sized for the Stage cave at 20 m x 20 m,
    whose robot free area is 267 m²; there runs stop after 65-93 ± 23 m (DESIGN.md), 1400-2000
    scans at 2.2 s of robot time per metre, so 6000 is a 3x margin. The travel that sees a
    building grows with its area (every room is visited, corridors are driven at a swath of at
    most the laser's 16 m), so the budget keeps the cave's scans per m², 6000 / 267 ≈ 22.5, and
    never drops below 6000 (small maps have a fixed cost: the first spin, turns at dead ends).
    The 2500 m² of the 102 x 116 m office_g get 56 250 scans (94 min of robot time); the
    190 m² cave_compact keeps 6000.
    """
    if not area_m2 >= 0:
        raise ValueError(f"step_budget: free area must be a non-negative number of m², got {area_m2}")
    return max(MIN_STEPS, math.ceil(STEPS_PER_M2 * area_m2))


def suite_maps(where: str | Path, names: list[str] | None = None) -> list[Path]:
    """The map YAMLs of the suite in ``where`` (its folder or its ``manifest.csv``), in the
    manifest's order; only those called ``names`` (``lab_a`` or ``lab_a.yaml``) when given.

    Raises:
        FileNotFoundError: no manifest, or a map it lists is missing.
        ValueError: a name in ``names`` is not in the manifest (the known names listed).
    """
    where = Path(where)
    manifest = where if where.suffix.lower() == ".csv" else where / "manifest.csv"
    if not manifest.is_file():
        raise FileNotFoundError(f"{manifest}: no suite manifest (a folder with manifest.csv, or the csv itself)")
    with open(manifest, newline="") as f:
        rows = {row["name"]: manifest.parent / row["file"] for row in csv.DictReader(f)}
    if names is not None:
        wanted = [Path(n).stem if n.endswith((".yaml", ".yml")) else n for n in names]
        unknown = [n for n in wanted if n not in rows]
        if unknown:
            raise ValueError(f"{manifest}: no map called {', '.join(unknown)} (have: {', '.join(rows)})")
        rows = {n: rows[n] for n in wanted}
    missing = [str(p) for p in rows.values() if not p.is_file()]
    if missing:
        raise FileNotFoundError(f"{manifest}: listed maps are missing: {', '.join(missing)}")
    return list(rows.values())
