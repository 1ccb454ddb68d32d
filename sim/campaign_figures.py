"""Figures comparing the methods of a campaign on one world, over their seeded runs.

A curve is one run's samples (``sim.results.read_curve``: step, time_s, travel_m, coverage,
entropy_nats). Runs end at different steps; after its end a run keeps its final value, which
is what its map is, so the mean and band over runs are taken on a common axis with each run
held at its last sample.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sim.figures import plt, save_figure


def travel_figure(path: str | Path, runs: dict[str, list[dict]], world: str) -> None:
    """Travel distance (m) per method: a box over the runs and every run as a dot."""
    methods = [m for m in runs if runs[m]]
    travel = [[r["travel_distance_m"] for r in runs[m]] for m in methods]
    fig, ax = plt.subplots(figsize=(1.8 * len(methods) + 2, 4))
    ax.boxplot(travel, showfliers=False)
    ax.set_xticks(range(1, len(methods) + 1), methods)
    rng = np.random.default_rng(0)  # jitter only spreads the dots sideways
    for k, values in enumerate(travel, start=1):
        ax.plot(k + rng.uniform(-0.12, 0.12, len(values)), values, "o", ms=5, alpha=0.7, color=f"C{k - 1}")
    ax.set(ylabel="travel distance [m]", title=f"{world}: travel distance per run")
    ax.grid(alpha=0.3, axis="y")
    save_figure(fig, path)


def band(curves: list[dict[str, np.ndarray]], x: str, y: str, n: int = 200):
    """Common axis, mean and standard deviation of ``y`` over runs against ``x``, from 0 to the
    largest ``x`` reached; each run is held at its last value after its end."""
    axis = np.linspace(0.0, max(float(c[x][-1]) for c in curves), n)
    values = np.array([np.interp(axis, c[x], c[y]) for c in curves])
    return axis, values.mean(axis=0), values.std(axis=0)


def _plot_bands(ax, curves: dict[str, list], x: str, y: str, scale: float = 1.0) -> None:
    for k, (method, runs) in enumerate((m, r) for m, r in curves.items() if r):
        axis, mean, sd = band(runs, x, y)
        ax.plot(axis, scale * mean, color=f"C{k}", label=f"{method} (n={len(runs)})")
        ax.fill_between(axis, scale * (mean - sd), scale * (mean + sd), color=f"C{k}", alpha=0.2, lw=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)


def coverage_figure(path: str | Path, curves: dict[str, list], world: str) -> None:
    """Coverage of the reachable free space over travel distance and over robot time, per
    method: the mean over runs with a ±1 standard deviation band."""
    fig, (by_travel, by_time) = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    _plot_bands(by_travel, curves, "travel_m", "coverage", 100.0)
    _plot_bands(by_time, curves, "time_s", "coverage", 100.0)
    by_travel.set(xlabel="travel distance [m]", ylabel="coverage [%]", title=f"{world}: coverage over travel")
    by_time.set(xlabel="robot time [s]", title=f"{world}: coverage over time")
    save_figure(fig, path)


def entropy_band_figure(path: str | Path, curves: dict[str, list], world: str) -> None:
    """Map entropy (nats, 0.2 m cells) over steps per method: the mean over runs with a
    ±1 standard deviation band (paper Fig. 1 over seeds)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    _plot_bands(ax, curves, "step", "entropy_nats")
    ax.set(xlabel="step", ylabel="map entropy [nats]", title=f"{world}: map entropy, mean ± s.d. over runs")
    save_figure(fig, path)
