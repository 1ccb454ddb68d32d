"""The COM panels draw occupancy in grey, as map viewers do, with axes in ``x [m]``."""

from types import SimpleNamespace

import matplotlib.figure
import numpy as np

from mapping.figure import com_figure


def test_com_panels_are_grey_occupancy_with_one_colour_bar(tmp_path, monkeypatch):
    kept = []
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", lambda fig, *a, **k: kept.append(fig))
    grid = np.linspace(0, 1, 20 * 30).reshape(20, 30)
    com = SimpleNamespace(frame=SimpleNamespace(extent=(0.0, 3.0, 0.0, 2.0)),
                          prob_occ=lambda: grid, prob_free=lambda: grid, prob=lambda: grid)
    com_figure(tmp_path / "com.png", com, np.array([[0.5, 0.5], [1.0, 1.0]]))
    (fig,) = kept
    images = [im for ax in fig.axes for im in ax.get_images()]
    assert len(images) == 3
    assert all(im.get_cmap().name == "gray_r" and im.get_clim() == (0, 1) for im in images)
    (bar,) = [ax for ax in fig.axes if ax.get_ylabel().startswith("occupancy probability")]
    panels = [ax for ax in fig.axes if ax is not bar]
    assert all((ax.get_xlabel(), ax.get_ylabel()) == ("x [m]", "y [m]") for ax in panels)
