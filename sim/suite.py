"""The floor-plan suite as a benchmark runs it: its worlds, a seeded random start in each, a
step budget that grows with the free area to explore, and how a suite campaign's runs score.

bc-exploration's recipe: many runs per map, each from a random start in the largest free region
the robot reaches, counted a success when the run ends by itself with the reachable space seen.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections import Counter
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
STEPS_PER_M2 = 60.0
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
    scans at 2.2 s of robot time per metre, so 6000 is a 3x margin, and small maps keep it as
    a floor (a fixed cost: the first spin, turns at dead ends). The travel that sees a
    building grows with its area, but faster than the cave's where rooms are many, small and
    cluttered: lab_e's C-frontier run (372 m², seed 0) drove 489 m to its own stop, 1.3 m
    a m² against the cave's 0.3, at 2.7 s a metre (doors of 0.55 m, furniture), 13 100 scans,
    35 a m². 60 scans a m² give the most demanding building measured a 1.7x margin; the
    budget is a net for runs that never end, not a measure of speed. The 2500 m² of the
    102 x 116 m office_g get 150 000 scans (4.2 h of robot time); the 190 m² cave_compact
    keeps 6000.
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


def world_list(data: Path, suite: Path, names: list[str] | None) -> list[tuple[str, tuple | None]]:
    """(spec, size) of the chosen worlds: suite maps by name (``lab_a``), extras by their key."""
    extras = {k: (v[0] if v[1] is None else str(data / v[0]), v[1]) for k, v in EXTRA_WORLDS.items()}
    if names is None:
        return [(str(p), None) for p in suite_maps(suite)] + list(extras.values())
    chosen_maps = suite_maps(suite, [n for n in names if n not in extras])
    return [(str(p), None) for p in chosen_maps] + [extras[n] for n in names if n in extras]


# --- scoring a suite campaign -----------------------------------------------------------------

#: A run succeeds when it ends by itself (no crash, no step-budget stop, no ``stop_failed``)
#: with at least this core coverage.
SUCCESS_COVERAGE = 0.99

#: Meters: the narrowest door a 0.25 m robot is asked to pass. A failed stop whose missed regions
#: all lie behind narrower doors (``missed_regions``' ``door_m``) is counted apart in the summary:
#: still a failure, but of a door with centimetres to spare, not of the exploration.
REQUIRED_DOOR_M = 0.8


def outcome(run) -> dict:
    """A campaign ``Run``'s end as the suite scores it: world, method, seed, ``metrics`` (None
    unless finished) and ``crashed`` (it left error.json)."""
    from sim.campaign import failed, finished

    folder = Path(run.folder)
    metrics = json.loads((folder / "metrics.json").read_text()) if finished(run) else None
    return {"world": run.world.name, "method": run.method, "seed": run.seed, "metrics": metrics,
            "crashed": failed(run)}


def tail_share(m: dict) -> float | None:
    """Share of a run's travel driven after it first reached 99 % coverage; None if it never did."""
    return _share_after(m["travel_at_coverage_m"].get("0.99"), m["travel_distance_m"])


def late_share(m: dict) -> float | None:
    """Share of a run's travel driven after its last gain (``travel_at_last_gain_m``: it saw less
    than a missed region's 1 m² more after it), the part of the tail the stop could have saved;
    None for runs written before it was recorded."""
    return _share_after(m.get("travel_at_last_gain_m"), m["travel_distance_m"])


def _share_after(at: float | None, travel: float) -> float | None:
    if at is None:
        return None
    return (travel - at) / travel if travel > 0 else 0.0


def failed_stop(m: dict) -> bool:
    """metrics.json's ``stop_failed``, computed for runs written before it existed."""
    from sim.episode import stop_failed

    if "stop_failed" in m:
        return m["stop_failed"]
    return stop_failed(m["termination_reason"], m.get("missed_area_m2", 0.0))


def behind_narrow_doors(m: dict) -> bool:
    """A failed stop whose every missed region lies behind a door narrower than
    ``REQUIRED_DOOR_M`` (False for runs written before ``missed_regions`` existed)."""
    regions = m.get("missed_regions")
    return failed_stop(m) and bool(regions) and all(r["door_m"] < REQUIRED_DOOR_M for r in regions)


def succeeded(m: dict | None) -> bool:
    """A finished run that ended by itself with the reachable space seen (``SUCCESS_COVERAGE``)."""
    return m is not None and not failed_stop(m) and m["coverage"] >= SUCCESS_COVERAGE


def cost_per_scan_ms(m: dict) -> float:
    """The stack's time per scan of a run (the robot's cost: the evaluator's coverage samples,
    which grow with the map, are the benchmark's), ms; a run written before that was recorded
    gives its wall time per scan."""
    return 1000.0 * m.get("onboard_time_s", m["wall_time_s"]) / max(m["steps"], 1)


def _mean(values) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def suite_rows(outcomes: list[dict]) -> list[dict]:
    """One row per world and method, in the order of ``outcomes``: runs planned, finished, crashed
    and succeeded; coverage mean and worst; travel, tail and late shares, missed area (mean and
    worst), ATE and cost per scan, means over the finished runs; collisions summed; how runs ended."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for o in outcomes:
        groups.setdefault((o["world"], o["method"]), []).append(o)
    rows = []
    for (world, method), group in groups.items():
        done = [o["metrics"] for o in group if o["metrics"] is not None]
        reasons = Counter(m["termination_reason"] for m in done)
        rows.append({
            "world": world, "method": method, "runs": len(group), "finished": len(done),
            "crashed": sum(o["crashed"] for o in group), "succeeded": sum(map(succeeded, done)),
            "coverage": _mean(m["coverage"] for m in done),
            "coverage_worst": min((m["coverage"] for m in done), default=None),
            "travel_m": _mean(m["travel_distance_m"] for m in done),
            "tail_share": _mean(map(tail_share, done)),
            "late_share": _mean(map(late_share, done)),
            "missed_area_m2": _mean(m.get("missed_area_m2") for m in done),
            "missed_area_worst_m2": max((m.get("missed_area_m2", 0.0) for m in done), default=None),
            "ended": dict(sorted(reasons.items())),
            "collisions": sum(m["collisions"] for m in done),
            "ate_m": _mean(m["ate_rmse_m"] for m in done),
            "ate_final_m": _mean(m.get("ate_final_rmse_m") for m in done),
            "ate_aligned_m": _mean(m.get("ate_final_aligned_rmse_m") for m in done),
            "ms_per_scan": _mean(map(cost_per_scan_ms, done)),
        })
    return rows


#: The world whose cost per scan the largest map's is held against (the Stage cave at 20 m x 20 m,
#: else the built-in cave).
COST_REFERENCES = ("cave.png", "cave")


def suite_summary(outcomes: list[dict], wall_s: float) -> dict:
    """The suite's figures over every planned run: the share that succeeded (``succeeded``),
    crashes, collisions, step-budget stops and failed stops; the C-frontier/grid travel as the
    mean of ratios paired by world and seed (both finished); the mean tail and late shares; the
    GP cost per scan on the largest world (by reachable area) against the cave's; ``wall_s`` (the
    benchmark's wall time) and the finished runs' wall time summed."""
    done = [o["metrics"] for o in outcomes if o["metrics"] is not None]
    travel = {(o["world"], o["seed"], o["method"]): o["metrics"]["travel_distance_m"]
              for o in outcomes if o["metrics"] is not None}
    ratios = [travel[w, s, "gp"] / travel[w, s, "grid"] for (w, s, method) in travel
              if method == "gp" and (w, s, "grid") in travel and travel[w, s, "grid"] > 0]
    gp_cost: dict[str, list[float]] = {}
    area: dict[str, float] = {}
    for o in outcomes:
        if o["metrics"] is not None and o["method"] == "gp":
            gp_cost.setdefault(o["world"], []).append(cost_per_scan_ms(o["metrics"]))
            area[o["world"]] = o["metrics"].get("reachable_area_m2", 0.0)
    largest = max(area, key=area.get) if area else None
    reference = next((w for w in COST_REFERENCES if w in gp_cost), None)
    return {
        "runs": len(outcomes), "finished": len(done),
        "succeeded": sum(map(succeeded, done)),
        "crashed": sum(o["crashed"] for o in outcomes),
        "collisions": sum(m["collisions"] for m in done),
        "step_budget_stops": sum(m["termination_reason"] == "step_budget" for m in done),
        "failed_stops": sum(failed_stop(m) and m["termination_reason"] != "step_budget" for m in done),
        "failed_behind_narrow_doors": sum(map(behind_narrow_doors, done)),
        "travel_ratio": _mean(ratios), "pairs": len(ratios),
        "tail_share": _mean(map(tail_share, done)),
        "late_share": _mean(map(late_share, done)),
        "largest": largest, "largest_ms_per_scan": _mean(gp_cost.get(largest, [])) if largest else None,
        "reference": reference, "reference_ms_per_scan": _mean(gp_cost[reference]) if reference else None,
        "wall_s": wall_s, "runs_wall_s": sum(m["wall_time_s"] for m in done),
    }


def _num(value, fmt: str, scale: float = 1.0) -> str:
    return "—" if value is None else format(scale * value, fmt)


def summary_line(s: dict) -> str:
    """``suite_summary`` in one line."""
    cost = "cost per scan: no GP run"
    if s["largest"] is not None:
        cost = f"GP cost per scan {s['largest']} {s['largest_ms_per_scan']:.1f} ms"
        if s["reference"] is not None and s["reference"] != s["largest"]:
            cost += (f" = {s['largest_ms_per_scan'] / s['reference_ms_per_scan']:.2f}x {s['reference']}'s "
                     f"{s['reference_ms_per_scan']:.1f} ms")
    share = s["succeeded"] / s["runs"] if s["runs"] else 0.0
    return (f"suite: {s['succeeded']}/{s['runs']} runs ({100 * share:.0f} %) ended by themselves with "
            f">= {100 * SUCCESS_COVERAGE:.0f} % coverage; {s['crashed']} crashed, {s['collisions']} collisions, "
            f"{s['step_budget_stops']} step-budget stops, {s['failed_stops']} failed stops (missed >= 1 m²; "
            f"{s['failed_behind_narrow_doors']} only behind doors < {REQUIRED_DOOR_M} m); "
            f"gp/grid travel {_num(s['travel_ratio'], '.2f')} (mean of {s['pairs']} paired ratios); "
            f"tail {_num(s['tail_share'], '.1f', 100)} % of travel ({_num(s['late_share'], '.1f', 100)} % after "
            f"the last 1 m² seen); {cost}; wall {s['wall_s'] / 60:.1f} min "
            f"(runs' own {s['runs_wall_s'] / 60:.1f} min)")


#: The suite table's columns: (header, row key, format, scale).
COLUMNS = [("world", "world", "s", 1), ("method", "method", "s", 1), ("ok/runs", None, "", 1),
           ("crashed", "crashed", "d", 1), ("coverage %", "coverage", ".1f", 100),
           ("worst %", "coverage_worst", ".1f", 100), ("travel m", "travel_m", ".1f", 1),
           ("tail %", "tail_share", ".1f", 100), ("late %", "late_share", ".1f", 100),
           ("missed m²", "missed_area_m2", ".1f", 1),
           ("worst missed m²", "missed_area_worst_m2", ".1f", 1), ("ended", "ended", "", 1),
           ("collisions", "collisions", "d", 1), ("ATE m", "ate_m", ".3f", 1),
           ("final ATE m", "ate_final_m", ".3f", 1), ("aligned m", "ate_aligned_m", ".3f", 1),
           ("ms/scan", "ms_per_scan", ".1f", 1)]


def _cell(row: dict, key, fmt: str, scale: float) -> str:
    if key is None:
        done = f" ({row['finished']} done)" if row["finished"] < row["runs"] else ""
        return f"{row['succeeded']}/{row['runs']}{done}"
    if key == "ended":
        return ", ".join(f"{reason} {n}" for reason, n in row["ended"].items()) or "—"
    value = row[key]
    if isinstance(value, str):
        return value
    return _num(value, fmt, scale)


def rows_markdown(rows: list[dict]) -> str:
    """``suite_rows`` as a Markdown table."""
    lines = ["| " + " | ".join(c[0] for c in COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(_cell(row, key, fmt, scale) for _, key, fmt, scale in COLUMNS) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def rows_csv(rows: list[dict]) -> str:
    """``suite_rows`` as CSV, one column per row key (``ended`` as reason:count pairs)."""
    text = io.StringIO()
    keys = list(rows[0]) if rows else []
    sheet = csv.writer(text, lineterminator="\n")
    sheet.writerow(keys)
    for row in rows:
        sheet.writerow(["" if row[k] is None else (" ".join(f"{r}:{n}" for r, n in row[k].items())
                                                   if k == "ended" else row[k]) for k in keys])
    return text.getvalue()
