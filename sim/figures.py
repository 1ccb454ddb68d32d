"""Figures of worlds and runs (matplotlib, written to files)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from sim.tour import TourLog  # noqa: E402
from sim.world import World  # noqa: E402
from slam.poses import positions  # noqa: E402


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
    truth, odom = positions(log.truth), positions(log.odometry)
    ax.plot(truth[:, 0], truth[:, 1], "-", color="tab:blue", lw=1.5, label="true path")
    # odometry lives in its own frame: show it from the true start so the drift is visible
    start = log.truth[0]
    odom = positions([start.compose(log.odometry[0].between(p)) for p in log.odometry])
    ax.plot(odom[:, 0], odom[:, 1], "--", color="tab:red", lw=1.0, label="odometry")
    ax.plot(*truth[0], "o", color="tab:green", label="start")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{world.name}: {len(log.scans)} scans")
    save_figure(fig, path, dpi=120)


def save_figure(fig, path: str | Path, dpi: int = 110) -> None:
    """Write ``fig`` to ``path`` (creating its folder) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)


def map_figure(path: str | Path, prob: np.ndarray, extent, estimate, truth, loops_xy=(),
               title: str = "") -> None:
    """The final map with the estimated and true paths and the loop closures (paper Fig. 5)."""
    fig, ax = plt.subplots(figsize=(8, 8))
    im = ax.imshow(prob, origin="lower", extent=extent, cmap="jet", vmin=0, vmax=1)
    truth, estimate = positions(truth), positions(estimate)
    ax.plot(truth[:, 0], truth[:, 1], "-", color="white", lw=1.0, label="true path")
    ax.plot(estimate[:, 0], estimate[:, 1], "-", color="tab:red", lw=1.2, label="SLAM estimate")
    for k, (a, b) in enumerate(loops_xy):
        ax.plot([a[0], b[0]], [a[1], b[1]], "-", color="lime", lw=1.0,
                label="loop closure" if k == 0 else None)
    ax.plot(*truth[0], "o", color="white")
    ax.set(title=title, xlabel="x (m)", ylabel="y (m)", aspect="equal")
    ax.legend(loc="upper right", fontsize=8)
    fig.colorbar(im, ax=ax, shrink=0.7, label="occupancy probability")
    save_figure(fig, path)


def frontier_figure(path: str | Path, snapshots) -> None:
    """Frontier maps with their k-means clusters and the chosen goal (paper Fig. 3); for the
    grid baseline, its frontier cells."""
    n = len(snapshots)
    if n == 0:
        return
    fig, axes = plt.subplots(1, n, figsize=(4.5 * n, 4.8), squeeze=False)
    for ax, snap in zip(axes[0], snapshots):
        f = snap.plan.frontier
        h, w = f.shape
        x0, y0 = snap.origin - snap.resolution / 2
        extent = (x0, x0 + w * snap.resolution, y0, y0 + h * snap.resolution)
        ax.imshow(f, origin="lower", extent=extent, cmap="viridis", vmin=-1, vmax=max(1.0, f.max()))
        for k, cluster in enumerate(snap.plan.clusters):
            ax.plot(cluster.points[:, 0], cluster.points[:, 1], ".", ms=2, color=f"C{k % 10}")
        ax.plot(snap.plan.goal[0], snap.plan.goal[1], "o", mfc="none", mec="magenta", ms=12, mew=2)
        ax.plot(snap.pose.x(), snap.pose.y(), "^", color="red", ms=8)
        ax.set(title=f"step {snap.step}", aspect="equal", xlabel="x (m)")
    axes[0, 0].set_ylabel("y (m)")
    save_figure(fig, path)


def entropy_figure(path: str | Path, curves: dict) -> None:
    """Map entropy (nats, 0.2 m cells) over steps, one line per run (paper Fig. 1)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    for label, curve in curves.items():
        curve = np.asarray(curve)
        ax.plot(curve[:, 0], curve[:, 3], label=label)
    ax.set(xlabel="step", ylabel="map entropy (nats)", title="map entropy")
    ax.grid(alpha=0.3)
    ax.legend()
    save_figure(fig, path)
