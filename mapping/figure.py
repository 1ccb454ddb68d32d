"""The paper's Fig. 2 panels for a COM: poses with hits, Λo, Λf and Λ."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def com_figure(path: str | Path, com, poses_xy: np.ndarray, hits_xy: np.ndarray | None = None,
               title: str = "") -> None:
    """Save a 2 x 2 figure: (a) sensor poses (n, 2) and hits (k, 2), (b) Λo, (c) Λf, (d) Λ, each in grey
    as map viewers draw occupancy (free white, occupied black, unseen 0.5 mid-grey)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x0, x1, y0, y1 = com.frame.extent
    fig, axes = plt.subplots(2, 2, figsize=(11, 10), constrained_layout=True)
    ax = axes[0, 0]
    if hits_xy is not None and len(hits_xy):
        ax.plot(hits_xy[:, 0], hits_xy[:, 1], ",", color="0.3")
    ax.plot(poses_xy[:, 0], poses_xy[:, 1], "-", color="tab:red", lw=1)
    ax.set(title="(a) poses and laser hits", xlim=(x0, x1), ylim=(y0, y1), aspect="equal")
    panels = ((axes[0, 1], com.prob_occ(), "(b) obstacle map Λo"),
              (axes[1, 0], com.prob_free(), "(c) free-space map Λf"),
              (axes[1, 1], com.prob(), "(d) continuous occupancy map Λ"))
    for ax, grid, name in panels:
        im = ax.imshow(grid, origin="lower", extent=(x0, x1, y0, y1), cmap="gray_r", vmin=0, vmax=1)
        ax.set(title=name, aspect="equal")
    fig.colorbar(im, ax=axes[:, 1], shrink=0.6, label="occupancy probability (unseen 0.5)")
    for ax in axes.ravel():
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
    if title:
        fig.suptitle(title)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
