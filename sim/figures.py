"""Figures of worlds and runs (matplotlib, written to files)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from sim.tour import TourLog  # noqa: E402
from sim.world import World  # noqa: E402


def _xy(poses) -> np.ndarray:
    return np.array([[p.x(), p.y()] for p in poses])


def plot_world(ax, world: World) -> None:
    ax.imshow(world.occupied, origin="lower", extent=world.extent, cmap="gray_r",
              vmin=0, vmax=1.6, interpolation="nearest")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def tour_figure(path: str | Path, world: World, log: TourLog, every: int = 10) -> None:
    """World, true path, odometry path and the scans (every ``every``-th, at the true pose)."""
    fig, ax = plt.subplots(figsize=(8, 8 * world.size[1] / world.size[0] + 0.5))
    plot_world(ax, world)
    hits = [log.truth[k].transformFrom(log.scans[k].points().T).T
            for k in range(0, len(log.scans), every) if log.scans[k].hit.any()]
    if hits:
        hits = np.vstack(hits)
        ax.plot(hits[:, 0], hits[:, 1], ",", color="tab:orange", alpha=0.6, label="scan hits")
    truth, odom = _xy(log.truth), _xy(log.odometry)
    ax.plot(truth[:, 0], truth[:, 1], "-", color="tab:blue", lw=1.5, label="true path")
    # odometry lives in its own frame: show it from the true start so the drift is visible
    start = log.truth[0]
    odom = _xy([start.compose(log.odometry[0].between(p)) for p in log.odometry])
    ax.plot(odom[:, 0], odom[:, 1], "--", color="tab:red", lw=1.0, label="odometry")
    ax.plot(*truth[0], "o", color="tab:green", label="start")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{world.name}: {len(log.scans)} scans")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
