"""A run recorded for the Rerun viewer (``explore --rerun FILE.rrd``), offline to a file.

One 2-D space in world meters: the true world faded, the map (as an image placed by its cell
size and origin), the estimated and true trajectories, the scan in the world at the estimate,
the goal with its path and the loop closures, on the timelines ``step`` and ``time``.
Needs the optional ``rerun-sdk`` (``pip install gpexplore[viz]``).
"""

from __future__ import annotations

from pathlib import Path

import gtsam
import numpy as np

from exploration.stack import Stack, StackStep
from sim.world import World
from slam.scan import LaserScan


def _gray(prob: np.ndarray) -> np.ndarray:
    """(h, w) occupancy probability -> uint8 image, free white, occupied black (map.pgm's)."""
    return np.round(255 * (1 - prob)).astype(np.uint8)


class RerunLog:
    """Logs every scan of a run to ``path`` (.rrd); pass it as ``run_episode``'s ``watch``."""

    def __init__(self, path: str | Path, world: World):
        import rerun as rr
        import rerun.blueprint as rrb

        self.rr = rr
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        self.rec = rr.RecordingStream("gpexplore")
        # one 2-D view from the root, so that the flip of "world" below applies to all of it
        self.rec.save(path, default_blueprint=rrb.Spatial2DView(origin="/", name="gpexplore"))
        # 2-D views draw y downwards: flip the world so that its y axis points up
        self.rec.log("world", rr.Transform3D(mat3x3=np.diag([1.0, -1.0, 1.0])), static=True)
        xmin, _, ymin, _ = world.extent
        self._place("world/true_world", (xmin, ymin), world.resolution, static=True)
        self.rec.log("world/true_world", rr.Image(_gray(world.occupied * 0.3), opacity=0.4,
                                                  draw_order=-20.0), static=True)
        self._estimate: list[tuple[float, float]] = []
        self._truth: list[tuple[float, float]] = []

    def __call__(self, step: int, t: float, stack: Stack, out: StackStep, scan: LaserScan,
                 truth: gtsam.Pose2) -> None:
        rr, rec = self.rr, self.rec
        rec.set_time("step", sequence=step)
        rec.set_time("time", duration=t)
        pose = out.pose
        self._estimate.append((pose.x(), pose.y()))
        self._truth.append((truth.x(), truth.y()))
        rec.log("world/robot", rr.Points2D([self._estimate[-1]], radii=0.12, colors=[220, 30, 30]))
        rec.log("world/scan", rr.Points2D(pose.transformFrom(scan.points().T).T, radii=0.03,
                                          colors=[255, 140, 0]))
        if out.keyframe is not None:
            x0, _, y0, _ = stack.map.frame.extent
            self._place("world/map", (x0, y0), (stack.map.frame.resolution,) * 2)
            rec.log("world/map", rr.Image(_gray(stack.map.prob()), draw_order=-10.0))
            self._trajectories()
        if out.plan is not None:
            plan = out.plan
            if plan.goal is None:
                rec.log("world/goal", rr.Clear(recursive=True))
            else:
                rec.log("world/goal", rr.Points2D([plan.goal], radii=0.2, colors=[255, 0, 255]))
                rec.log("world/goal/path", rr.LineStrips2D([plan.path], colors=[255, 0, 255]))
        if out.loops:
            rec.log("world/loops", rr.LineStrips2D(list(stack.loop_segments()), colors=[0, 255, 0]))

    def close(self) -> None:
        """Log the whole trajectories and write everything to the file."""
        self._trajectories()
        self.rec.flush()

    def _trajectories(self) -> None:
        rr = self.rr
        self.rec.log("world/estimate", rr.LineStrips2D([self._estimate], colors=[220, 30, 30]))
        self.rec.log("world/truth", rr.LineStrips2D([self._truth], colors=[40, 160, 40]))

    def _place(self, entity: str, corner, resolution, static: bool = False) -> None:
        """Image pixels (column, row) -> meters: row 0 is the bottom (y min) row."""
        rx, ry = resolution
        self.rec.log(entity, self.rr.Transform3D(translation=[corner[0], corner[1], 0.0],
                                                 scale=[rx, ry, 1.0]), static=static)
