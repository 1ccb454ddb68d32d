"""Figures explain themselves: every line visible and in the legend, grey occupancy with a colour
bar, titles that fit wide maps, frontier panels over one extent with the map under them, the
start and the reachable area in the world figure, and one axis-label convention."""

from types import SimpleNamespace

import gtsam
import matplotlib.colors as mcolors
import numpy as np
import pytest

from exploration.explorer import Plan
from exploration.goals import FrontierCluster
from sim import figures
from sim.worlds import BUILTIN_WORLDS


@pytest.fixture
def drawn(monkeypatch):
    """The figures the functions would save, kept open instead."""
    kept = []
    monkeypatch.setattr(figures, "save_figure", lambda fig, path, dpi=110: kept.append(fig))
    yield kept
    for fig in kept:
        figures.plt.close(fig)


def path_poses(width: float, height: float, shift: float = 0.0) -> list[gtsam.Pose2]:
    s = np.linspace(0, 1, 100)
    return [gtsam.Pose2(2 + (width - 4) * t + shift, height / 2 + 0.3 * height * np.sin(6 * t), 0) for t in s]


def map_of(width: float, height: float, resolution: float = 0.1) -> np.ndarray:
    prob = np.full((round(height / resolution), round(width / resolution)), 0.5)
    prob[10:-10, 10:-10] = 0.05
    prob[10:-10, 10] = 0.95
    return prob


def legend_entries(fig):
    legend = fig.legends[0] if fig.legends else fig.axes[0].get_legend()
    return legend, {t.get_text(): h for t, h in zip(legend.get_texts(), legend.legend_handles)}


def color_of(handle):
    if hasattr(handle, "get_markerfacecolor") and handle.get_linestyle() in ("None", "", " "):
        return mcolors.to_rgba(handle.get_markerfacecolor())
    return mcolors.to_rgba(handle.get_color() if hasattr(handle, "get_color") else handle.get_facecolor())


def test_map_figure_lines_show_on_the_legend_and_the_map(drawn):
    width, height = 20.0, 20.0
    figures.map_figure("unused.png", map_of(width, height), (0, width, 0, height),
                       path_poses(width, height, 0.2), path_poses(width, height), [((3, 3), (5, 4))], "cave")
    (fig,) = drawn
    legend, entries = legend_entries(fig)
    assert {"true path", "SLAM estimate", "loop closures (1)", "start", "end (true)",
            "end (estimate)"} <= set(entries)
    background = mcolors.to_rgba(legend.get_frame().get_facecolor() if legend.get_frame_on()
                                 else fig.get_facecolor())
    colors = {label: color_of(h) for label, h in entries.items()}
    for label, color in colors.items():
        # seen on the legend's background, and on the map's free (white) and occupied (black) cells
        for backdrop in (background, (1, 1, 1, 1), (0, 0, 0, 1)):
            assert np.abs(np.subtract(color[:3], backdrop[:3])).sum() > 0.3, label
    assert colors["true path"] != colors["SLAM estimate"]
    ax = fig.axes[0]
    # the markers are where the paths start and end
    start = next(line for line in ax.get_lines() if line.get_label() == "start")
    end = next(line for line in ax.get_lines() if line.get_label() == "end (true)")
    truth = path_poses(width, height)
    np.testing.assert_allclose(np.ravel(start.get_xydata()), [truth[0].x(), truth[0].y()])
    np.testing.assert_allclose(np.ravel(end.get_xydata()), [truth[-1].x(), truth[-1].y()])


def test_map_figure_draws_occupancy_in_grey_with_a_colour_bar(drawn):
    figures.map_figure("unused.png", map_of(10, 10), (0, 10, 0, 10), path_poses(10, 10), path_poses(10, 10))
    (fig,) = drawn
    ax, bar = fig.axes
    (image,) = ax.get_images()
    assert image.get_cmap().name == "gray_r" and image.get_clim() == (0, 1)
    assert bar.get_ylabel().startswith("occupancy probability")
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x [m]", "y [m]")


@pytest.mark.parametrize("size", [(40, 18), (60, 34), (20, 20)])
def test_map_figure_title_fits_over_wide_maps(drawn, size):
    """A long title over a wide, short map stays over the map: not into the colour bar, not off
    the figure."""
    width, height = size
    title = "hospital_section.yaml (gp): 250 m, coverage 71.2 %, no_reachable_goal after 6000 steps"
    figures.map_figure("unused.png", map_of(width, height), (0, width, 0, height),
                       path_poses(width, height), path_poses(width, height), (), title)
    (fig,) = drawn
    ax, bar = fig.axes
    fig.canvas.draw()
    text, box = ax.title.get_window_extent(), ax.get_window_extent()
    assert box.x0 - 1 <= text.x0 and text.x1 <= box.x1 + 1
    assert text.x1 < bar.get_window_extent().x0
    assert ax.title.get_text().replace("\n", " ") == title


def snapshot(step: int, width_cells: int, height_cells: int, grid: bool, with_map: bool = True):
    """A frontier snapshot over a map frame of the given size (0.1 m cells, origin 0)."""
    f = np.zeros((height_cells, width_cells))
    f[5:-5, width_cells - 8] = 1.0 if grid else 1.5
    if not grid:
        f[5:-5, 3] = -0.8                                     # a wall: F is negative there
    iy, ix = np.nonzero(f > 0)
    points = 0.1 * np.column_stack([ix, iy])
    cluster = FrontierCluster(points, points.mean(axis=0), 1.0, 1.0, points[0], 0.5)
    plan = Plan(points[0], np.array([[1.0, 1.0], points[0]]), new_goal=True, clusters=[cluster], frontier=f)
    prob = np.full(f.shape, 0.5)
    prob[5:-5, 4:-8] = 0.1
    prob[5:-5, 3] = 0.9
    snap = SimpleNamespace(step=step, pose=gtsam.Pose2(1.0, 1.0, 0.0), plan=plan, origin=np.zeros(2),
                           resolution=0.1)
    if with_map:
        snap.prob = prob
    return snap


@pytest.mark.parametrize("grid", [False, True])
def test_frontier_panels_share_one_extent_and_explain_their_markers(drawn, grid):
    # the map grows during the run: the panels must still show the same extent
    snaps = [snapshot(0, 40, 30, grid), snapshot(50, 80, 30, grid), snapshot(90, 80, 60, grid),
             snapshot(140, 120, 60, grid)]
    figures.frontier_figure("unused.png", snaps)
    (fig,) = drawn
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_images()]
    assert len(panels) == 4
    assert len({ax.get_xlim() for ax in panels}) == 1 and len({ax.get_ylim() for ax in panels}) == 1
    x0, x1 = panels[0].get_xlim()
    y0, y1 = panels[0].get_ylim()
    assert x1 - x0 >= 11.0 and y1 - y0 >= 5.0                  # the largest map's frontier is in view
    _, entries = legend_entries(fig)
    assert {"robot (estimate)", "chosen goal", "path to the goal"} <= set(entries)
    assert any(label.startswith("map:") for label in entries)
    if grid:
        assert "frontier cells" in entries and any("frontier regions" in label for label in entries)
    else:
        assert any("k-means clusters" in label for label in entries)
        (bar,) = [ax for ax in fig.axes if ax.get_ylabel().startswith("C-frontier value F")]
    for ax, snap in zip(panels, snaps):
        # the map is under the frontier: walls give the frontier its context
        assert ax.get_images()[0].get_cmap().name == "gray_r"
        np.testing.assert_array_equal(ax.get_images()[0].get_array(), snap.prob)
        assert ax.get_xlabel() in ("", "x [m]") and ax.get_ylabel() in ("", "y [m]")


def test_frontier_figure_without_maps_draws_all_of_f(drawn):
    """Snapshots that carry no map: F alone, walls where it is negative, on the colour bar."""
    figures.frontier_figure("unused.png", [snapshot(0, 40, 30, False, with_map=False)])
    (fig,) = drawn
    (bar,) = [ax for ax in fig.axes if ax.get_ylabel().startswith("C-frontier value F")]
    assert bar.get_ylim()[0] == -1.0


def test_world_figure_marks_the_start_and_shades_what_is_reachable(drawn):
    cave = BUILTIN_WORLDS["cave"]()
    world, start = cave.world, (cave.start.x(), cave.start.y())
    figures.world_figure("unused.png", world, start, radius=0.25)
    (fig,) = drawn
    ax = fig.axes[0]
    walls, shaded = ax.get_images()
    reach = world.reachable(start, 0.25)
    np.testing.assert_array_equal(~np.ma.getmaskarray(shaded.get_array()), reach)
    area = reach.sum() * np.prod(world.resolution)
    _, entries = legend_entries(fig)
    assert f"reachable free space, robot radius 0.25 m: {area:.1f} m²" in entries
    (marker,) = [line for line in ax.get_lines() if line.get_marker() == "o"]
    np.testing.assert_allclose(np.ravel(marker.get_xydata()), start)
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x [m]", "y [m]")


def test_world_figure_without_a_start_is_the_world_alone(drawn):
    figures.world_figure("unused.png", BUILTIN_WORLDS["cave"]().world)
    (fig,) = drawn
    assert len(fig.axes[0].get_images()) == 1 and not fig.legends


def test_campaign_figures_use_the_same_unit_convention(monkeypatch):
    """Every axis with a unit reads ``quantity [unit]``, as the map figures' ``x [m]``."""
    from sim import campaign_figures

    kept = []
    monkeypatch.setattr(campaign_figures, "save_figure", lambda fig, path, dpi=110: kept.append(fig))
    run = {"step": np.arange(3.0), "time_s": np.arange(3.0), "travel_m": np.arange(3.0),
           "coverage": np.linspace(0, 1, 3), "entropy_nats": np.arange(3.0)}
    campaign_figures.travel_figure("unused.png", {"gp": [{"travel_distance_m": 10.0}]}, "cave")
    campaign_figures.coverage_figure("unused.png", {"gp": [run]}, "cave")
    campaign_figures.entropy_band_figure("unused.png", {"gp": [run]}, "cave")
    labels = [label for fig in kept for ax in fig.axes for label in (ax.get_xlabel(), ax.get_ylabel()) if label]
    assert labels and all("(" not in label for label in labels), labels
    assert "travel distance [m]" in labels and "coverage [%]" in labels
    for fig in kept:
        figures.plt.close(fig)
