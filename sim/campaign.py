"""Campaigns: both methods over seeded runs on one world, and the paper's Table I from them.

Each run writes its own folder (``<out>/<method>/seed_<k>/``); a run whose ``metrics.json``
exists is finished and is not run again, so an interrupted campaign resumes where it stopped.
"""

from __future__ import annotations

import json
from pathlib import Path

import gtsam
import numpy as np

from sim.episode import EpisodeConfig, run_episode
from sim.results import write_episode
from sim.world import World

#: Table I rows: (label, metrics key, scale).
ROWS = [
    ("Travel distance (m)", "travel_distance_m", 1.0),
    ("Exploration time (min)", "sim_time_s", 1 / 60),
    ("Map entropy rate (nats/step)", "entropy_rate_nats_per_step", 1.0),
    ("Final map entropy (nats)", "final_map_entropy_nats", 1.0),
    ("Coverage (%)", "coverage", 100.0),
    ("AUC", "auc", 1.0),
    ("Travel at 90 % coverage (m)", ("travel_at_coverage_m", "0.90"), 1.0),
    ("Travel at 95 % coverage (m)", ("travel_at_coverage_m", "0.95"), 1.0),
    ("Travel at 99 % coverage (m)", ("travel_at_coverage_m", "0.99"), 1.0),
    ("ATE RMSE (m)", "ate_rmse_m", 1.0),
    ("Collisions", "collisions", 1.0),
    ("Wall time (s)", "wall_time_s", 1.0),
]


def run_campaign(world: World, start: gtsam.Pose2, configs: dict[str, EpisodeConfig],
                 seeds: list[int], out: str | Path, progress=None) -> dict[str, list[dict]]:
    """Run every (method, seed) not yet finished; returns the metrics of all runs by method."""
    out = Path(out)
    results: dict[str, list[dict]] = {}
    for method, config in configs.items():
        results[method] = []
        for seed in seeds:
            folder = out / method / f"seed_{seed}"
            done = folder / "metrics.json"
            if not done.exists():
                write_episode(folder, run_episode(world, start, config, seed=seed))
            results[method].append(json.loads(done.read_text()))
            if progress is not None:
                progress(method, seed, results[method][-1])
    return results


def _value(metrics: dict, key):
    if isinstance(key, tuple):
        metrics = metrics[key[0]]
        key = key[1]
    v = metrics.get(key)
    return np.nan if v is None else float(v)


def table(results: dict[str, list[dict]]) -> list[dict]:
    """Rows of Table I: per method, mean and standard error of each metric over the runs, and
    how many runs reached it (runs that never reached a coverage level are left out)."""
    rows = []
    for label, key, scale in ROWS:
        row = {"metric": label}
        for method, runs in results.items():
            values = np.array([_value(m, key) for m in runs]) * scale
            values = values[np.isfinite(values)]
            n = len(values)
            row[method] = {
                "mean": float(values.mean()) if n else None,
                "stderr": float(values.std(ddof=1) / np.sqrt(n)) if n > 1 else (0.0 if n else None),
                "n": n,
            }
        rows.append(row)
    return rows


def termination_counts(results: dict[str, list[dict]]) -> dict[str, dict[str, int]]:
    """How each method's runs ended."""
    counts = {}
    for method, runs in results.items():
        reasons = [m["termination_reason"] for m in runs]
        counts[method] = {r: reasons.count(r) for r in sorted(set(reasons))}
    return counts
