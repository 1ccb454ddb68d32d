"""Figures of worlds and runs (matplotlib, written to files).

One look for every figure: axes read ``x [m]``, occupancy is grey as map viewers draw it (free
white, occupied black, unseen mid-grey, ``OCCUPANCY``), and the legend sits outside the map so
that it hides nothing.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.cm import ScalarMappable  # noqa: E402
from matplotlib.colors import ListedColormap, Normalize  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from sim.tour import TourLog  # noqa: E402
from sim.world import World  # noqa: E402
from slam.poses import positions  # noqa: E402

#: Axis labels of every map figure.
X_LABEL, Y_LABEL = "x [m]", "y [m]"
#: Colour map of occupancy probability: 0 (free) white, 1 (occupied) black, 0.5 (unseen) grey.
OCCUPANCY = "gray_r"
#: Colours of what is drawn on a map: they stand out on white, grey and black.
TRUE_PATH, ESTIMATE, LOOP, START, END, GOAL, ROBOT = (
    "tab:blue", "tab:red", "tab:orange", "tab:green", "tab:purple", "magenta", "tab:red")
#: The grid baseline's frontier cells (the clusters are drawn over them, a colour each).
FRONTIER_CELLS = ListedColormap(["gold"])
#: Colour map of the C-frontier value F (perceptually uniform).
FRONTIER_VALUE = "viridis"


def plot_world(ax, world: World) -> None:
    """The world's walls, dark grey on white, over its extent in meters."""
    ax.imshow(world.occupied, origin="lower", extent=world.extent, cmap="gray_r",
              vmin=0, vmax=1.6, interpolation="nearest")
    ax.set(aspect="equal", xlabel=X_LABEL, ylabel=Y_LABEL)


def figure_size(width_m: float, height_m: float, width_in: float = 8.0, side_in: float = 0.8,
                extra_in: float = 1.4) -> tuple[float, float]:
    """(width, height) inches for a map ``width_m`` x ``height_m`` drawn in a figure ``width_in``
    wide, ``side_in`` of which go to axis labels and colour bar, and ``extra_in`` high for title
    and legend; a tall map is drawn narrower instead."""
    aspect = height_m / width_m
    if aspect > 1.2:
        width_in = max(5.0, width_in / aspect * 1.2)
    return width_in, (width_in - side_in) * aspect + extra_in


def wrapped_title(ax, text: str, fontsize: float = 10) -> None:
    """``text`` as the title of ``ax``, wrapped into lines no wider than the drawn axes (a long
    title over a wide, short map would run into the colour bar or off the figure)."""
    if not text:
        return
    fig = ax.figure
    chars = len(text)
    while True:
        title = ax.set_title(textwrap.fill(text, chars), fontsize=fontsize)
        fig.canvas.draw()  # lays the figure out: the axes' final width
        if chars <= 20 or title.get_window_extent().width <= ax.get_window_extent().width:
            return
        chars = int(chars * 0.85)


def legend_below(fig, handles=None, ncol: int = 3) -> None:
    """The figure's legend under its axes, outside the map (a constrained layout makes room)."""
    kw = {} if handles is None else {"handles": handles}
    fig.legend(loc="outside lower center", ncol=ncol, fontsize=8, frameon=False, **kw)


def world_figure(path: str | Path, world: World, start=None, radius: float = 0.25) -> None:
    """The world; with ``start`` (x, y[, θ], meters) the free space a robot of ``radius`` m can
    reach from it shaded and the start marked (``gpexplore world --out``)."""
    width, height = world.size
    fig, ax = plt.subplots(figsize=figure_size(width, height), layout="constrained")
    plot_world(ax, world)
    title = world.name
    if start is not None:
        reach = world.reachable(start[:2], radius)
        rx, ry = world.resolution
        area = reach.sum() * rx * ry
        ax.imshow(np.ma.masked_where(~reach, reach), origin="lower", extent=world.extent, cmap="Greens",
                  vmin=0, vmax=2.5, alpha=0.6, interpolation="nearest")
        ax.plot(start[0], start[1], "o", mfc=START, mec="black", ms=8)
        if len(start) > 2:  # the heading, as a short arrow
            tip = np.add(start[:2], 0.05 * width * np.array([np.cos(start[2]), np.sin(start[2])]))
            ax.annotate("", xy=tip, xytext=start[:2], arrowprops={"arrowstyle": "->", "color": "black"})
        legend_below(fig, [Patch(color=plt.get_cmap("Greens")(1 / 2.5), alpha=0.6,
                                label=f"reachable free space, robot radius {radius:g} m: {area:.1f} m²"),
                          Line2D([], [], ls="", marker="o", mfc=START, mec="black", ms=8,
                                 label=f"start ({start[0]:g}, {start[1]:g})")], ncol=2)
        title += f": {area:.1f} m² reachable from the start"
    wrapped_title(ax, title)
    save_figure(fig, path, dpi=120)


def tour_figure(path: str | Path, world: World, log: TourLog, every: int = 10) -> None:
    """World, true path, odometry path and the scans (every ``every``-th, at the true pose)."""
    fig, ax = plt.subplots(figsize=figure_size(*world.size), layout="constrained")
    plot_world(ax, world)
    hits = [log.truth[k].transformFrom(log.scans[k].points().T).T
            for k in range(0, len(log.scans), every) if log.scans[k].hit.any()]
    if hits:
        hits = np.vstack(hits)
        ax.plot(hits[:, 0], hits[:, 1], ",", color="tab:orange", alpha=0.6)
        ax.plot([], [], ".", color="tab:orange", label="scan hits")
    truth = positions(log.truth)
    ax.plot(truth[:, 0], truth[:, 1], "-", color=TRUE_PATH, lw=1.5, label="true path")
    # odometry lives in its own frame: show it from the true start so the drift is visible
    start = log.truth[0]
    odom = positions([start.compose(log.odometry[0].between(p)) for p in log.odometry])
    ax.plot(odom[:, 0], odom[:, 1], "--", color=ESTIMATE, lw=1.0, label="odometry")
    _start_and_end(ax, truth)
    legend_below(fig)
    wrapped_title(ax, f"{world.name}: {len(log.scans)} scans")
    save_figure(fig, path, dpi=120)


def save_figure(fig, path: str | Path, dpi: int = 110) -> None:
    """Write ``fig`` to ``path`` (creating its folder) and close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)


def _start_and_end(ax, xy: np.ndarray, end_label: str = "end") -> None:
    """Markers where the path ``xy`` (n, 2) starts and ends."""
    ax.plot(*xy[0], "o", mfc=START, mec="black", ms=8, label="start")
    ax.plot(*xy[-1], "s", mfc=END, mec="black", ms=6, label=end_label)


def occupancy_image(ax, prob: np.ndarray, extent, **kw):
    """``prob`` (h, w) drawn as occupancy over ``extent`` (xmin, xmax, ymin, ymax), meters."""
    return ax.imshow(prob, origin="lower", extent=extent, cmap=OCCUPANCY, vmin=0, vmax=1,
                     interpolation="nearest", **kw)


def map_figure(path: str | Path, prob: np.ndarray, extent, estimate, truth, loops_xy=(),
               title: str = "") -> None:
    """The final map (grey occupancy) with the estimated and true paths, their start and end,
    and the loop closures (paper Fig. 5)."""
    x0, x1, y0, y1 = extent
    size = figure_size(x1 - x0, y1 - y0, side_in=1.8)
    fig, ax = plt.subplots(figsize=size, layout="constrained")
    im = occupancy_image(ax, prob, extent)
    truth, estimate = positions(truth), positions(estimate)
    # the estimate wide and the truth thin on top of it: both show where they agree
    ax.plot(estimate[:, 0], estimate[:, 1], "-", color=ESTIMATE, lw=2.2, label="SLAM estimate")
    ax.plot(truth[:, 0], truth[:, 1], "-", color=TRUE_PATH, lw=0.9, label="true path")
    for k, (a, b) in enumerate(loops_xy):
        ax.plot([a[0], b[0]], [a[1], b[1]], "-", color=LOOP, lw=1.2,
                label=f"loop closures ({len(loops_xy)})" if k == 0 else None)
    ax.plot(*estimate[-1], "s", mfc=ESTIMATE, mec="black", ms=9, label="end (estimate)")
    _start_and_end(ax, truth, end_label="end (true)")
    ax.set(xlabel=X_LABEL, ylabel=Y_LABEL, aspect="equal")
    fig.colorbar(im, ax=ax, shrink=0.7, label="occupancy probability (unseen 0.5)")
    legend_below(fig)
    wrapped_title(ax, title)
    save_figure(fig, path)


def _snapshot_extent(snap) -> tuple[float, float, float, float]:
    h, w = snap.plan.frontier.shape
    x0, y0 = np.asarray(snap.origin) - snap.resolution / 2
    return x0, x0 + w * snap.resolution, y0, y0 + h * snap.resolution


def _snapshot_map(snap) -> np.ndarray | None:
    """The map at the snapshot (h, w), when the snapshot carries it."""
    return getattr(snap, "prob", None)


def frontier_view(snapshots, margin: float = 1.0) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) meters that every panel of ``frontier_figure`` shows: what the
    snapshots' maps observed (or, without maps, their frontiers), the robots and the goals,
    ``margin`` m around it, within the maps' frames."""
    xy = []
    for snap in snapshots:
        prob = _snapshot_map(snap)
        seen = np.abs(prob - 0.5) > 0.01 if prob is not None else snap.plan.frontier != 0
        iy, ix = np.nonzero(seen)
        xy.append(np.asarray(snap.origin) + snap.resolution * np.column_stack([ix, iy]))
        xy.append([[snap.pose.x(), snap.pose.y()]] + ([] if snap.plan.goal is None else [snap.plan.goal]))
    xy = np.vstack(xy)
    frames = np.array([_snapshot_extent(s) for s in snapshots])
    (x0, y0), (x1, y1) = xy.min(axis=0) - margin, xy.max(axis=0) + margin
    return (max(x0, frames[:, 0].min()), min(x1, frames[:, 1].max()),
            max(y0, frames[:, 2].min()), min(y1, frames[:, 3].max()))


def _draw_frontier(ax, f: np.ndarray, extent, binary: bool, norm, over_map: bool) -> None:
    """The grid's frontier cells in one colour; or F in colour: over a map, opaque from F = 1
    (frontier) and fading to transparent at F = 0 (free space's texture) so the map shows
    through; alone, all of it (walls are where it is negative)."""
    if binary:
        ax.imshow(np.ma.masked_where(f <= 0, f), origin="lower", extent=extent, cmap=FRONTIER_CELLS,
                  vmin=0, vmax=1, interpolation="nearest")
        return
    rgba = plt.get_cmap(FRONTIER_VALUE)(norm(f))
    if over_map:
        rgba[..., 3] = np.clip(f, 0.0, 1.0)
    ax.imshow(rgba, origin="lower", extent=extent, interpolation="nearest")


def frontier_figure(path: str | Path, snapshots) -> None:
    """Frontier maps with their k-means clusters, the chosen goal and its path, and the robot
    (paper Fig. 3); for the grid baseline, its frontier cells and regions. Every panel shows the
    same extent (``frontier_view``).

    A snapshot has ``step``, ``pose`` (gtsam.Pose2), ``plan`` (its ``frontier`` (h, w), the C-
    frontier map F, or 1 on grid frontier cells; ``clusters``, ``goal``, ``path``), ``origin``
    and ``resolution``; with ``prob`` (h, w), the map then, the map is drawn under the frontier.
    """
    n = len(snapshots)
    if n == 0:
        return
    xmin, xmax, ymin, ymax = frontier_view(snapshots)
    binary = all(np.isin(s.plan.frontier, (0.0, 1.0)).all() for s in snapshots)  # the grid's
    over_map = all(_snapshot_map(s) is not None for s in snapshots)
    norm = Normalize(0.0 if over_map else -1.0, max(1.0, max(float(s.plan.frontier.max()) for s in snapshots)))
    cols = n if n <= 3 else 2 if n == 4 else 3
    rows = -(-n // cols)
    panel = 4.5
    fig, axes = plt.subplots(rows, cols, squeeze=False, sharex=True, sharey=True, layout="constrained",
                             figsize=(panel * cols + 1.2, rows * panel * (ymax - ymin) / (xmax - xmin) + 1.2))
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    for ax, snap in zip(axes.ravel(), snapshots):
        extent, prob = _snapshot_extent(snap), _snapshot_map(snap)
        if over_map:
            ax.set_facecolor("0.5")  # beyond the map then: unseen
            occupancy_image(ax, prob, extent)
        _draw_frontier(ax, snap.plan.frontier, extent, binary, norm, over_map)
        for k, cluster in enumerate(snap.plan.clusters):
            ax.plot(cluster.points[:, 0], cluster.points[:, 1], ".", ms=3, color=f"C{k % 10}")
        if len(snap.plan.path):
            ax.plot(snap.plan.path[:, 0], snap.plan.path[:, 1], "--", color=GOAL, lw=1.2)
        if snap.plan.goal is not None:
            ax.plot(snap.plan.goal[0], snap.plan.goal[1], "o", mfc="none", mec=GOAL, ms=12, mew=2)
        ax.plot(snap.pose.x(), snap.pose.y(), "^", mfc=ROBOT, mec="black", ms=9)
        k = len(snap.plan.clusters)
        ax.set(title=f"step {snap.step}: {k} cluster{'s' * (k != 1)}", aspect="equal",
               xlim=(xmin, xmax), ylim=(ymin, ymax))
    for ax in axes[-1]:
        ax.set_xlabel(X_LABEL)
    for ax in axes[:, 0]:
        ax.set_ylabel(Y_LABEL)
    handles = [Line2D([], [], ls="", marker="^", mfc=ROBOT, mec="black", ms=9, label="robot (estimate)"),
               Line2D([], [], ls="", marker="o", mfc="none", mec=GOAL, ms=12, mew=2, label="chosen goal"),
               Line2D([], [], ls="--", color=GOAL, label="path to the goal")]
    if binary:
        handles += [Patch(color=FRONTIER_CELLS(1.0), label="frontier cells"),
                    Line2D([], [], ls="", marker="o", color="C0", label="frontier regions (a colour each)")]
    else:
        handles += [Line2D([], [], ls="", marker="o", color="C0", label="k-means clusters of F > τ (a colour each)")]
        fig.colorbar(ScalarMappable(norm, FRONTIER_VALUE), ax=axes, shrink=0.7,
                     label="C-frontier value F (eq. 10)" + (", transparent at F ≤ 0" if over_map else ""))
    if over_map:
        handles.append(Patch(facecolor="0.5", edgecolor="black", label="map: free white, occupied black, unseen grey"))
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    save_figure(fig, path)


def entropy_figure(path: str | Path, curves: dict) -> None:
    """Map entropy (nats, 0.2 m cells) over steps, one line per run (paper Fig. 1)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    for label, curve in curves.items():
        curve = np.asarray(curve)
        ax.plot(curve[:, 0], curve[:, 3], label=label)
    ax.set(xlabel="step", ylabel="map entropy [nats]", title="map entropy")
    ax.grid(alpha=0.3)
    ax.legend()
    save_figure(fig, path)
