"""The run as an animation: compact frames recorded during the run, drawn after it.

Recording keeps what each frame shows in small arrays (the map as uint8 probabilities on at
most ``MAX_CELLS`` cells a side, float32 points), so a long run's frames stay a few MB; the
trajectories are not copied per frame, they are the run's own, cut at the frame's step.
"""

from __future__ import annotations

import shutil
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from exploration.stack import Stack, StackStep
from slam.atomic import replaced_atomically
from slam.poses import pose_array

#: Longest side of a recorded map, cells: finer maps are strided down to it.
MAX_CELLS = 400
#: uint8 code of a map cell nothing was observed in (|p − 0.5| ≤ 0.01); 0..254 code p.
UNSEEN = 255
#: Frames per second of the written animation (one frame every ``animate_every`` steps).
FPS = 10


@dataclass
class Frame:
    """What the animation shows at one step.

    ``prob`` (h, w) uint8 codes the map's occupancy probability as round(254 p), UNSEEN where
    unobserved, over ``extent`` (xmin, xmax, ymin, ymax) in meters. ``pose`` (3,) is the
    estimate (x, y, θ); ``goal`` (2,) or None and ``path`` (k, 2) are the explorer's;
    ``frontier`` (n, 2) are the C-frontier cluster points with their cluster in ``labels``
    (n,) (the grid baseline: its frontier cells, one label); ``loops`` (m, 2, 2) are the loop
    closures as segments between the keyframes' current estimates.
    """

    step: int
    prob: np.ndarray
    extent: tuple[float, float, float, float]
    pose: np.ndarray
    goal: np.ndarray | None
    path: np.ndarray
    frontier: np.ndarray
    labels: np.ndarray
    loops: np.ndarray


class FrameRecorder:
    """Keeps a Frame every ``every`` steps of a run: an observer of ``run_episode``."""

    def __init__(self, every: int):
        self.every = every
        self.frames: list[Frame] = []
        self._frontier = np.zeros((0, 2), np.float32)
        self._labels = np.zeros(0, np.int16)

    def __call__(self, step: int, t: float, stack: Stack, out: StackStep, scan, truth) -> None:
        if out.plan is not None and (out.plan.new_goal or out.plan.goal is None):
            self._keep_frontier(out.plan)
        if step % self.every == 0:
            self.frames.append(self._capture(step, stack, out.pose))

    def finish(self, step: int, stack: Stack, pose) -> None:
        """The run's last step is always a frame."""
        if not self.frames or self.frames[-1].step != step:
            self.frames.append(self._capture(step, stack, pose))

    def _keep_frontier(self, plan) -> None:
        """The clusters of the last goal choice (a plan that keeps its goal has none)."""
        points = [k.points for k in plan.clusters]
        self._frontier = np.vstack(points).astype(np.float32) if points else np.zeros((0, 2), np.float32)
        self._labels = np.repeat(np.arange(len(points), dtype=np.int16), [len(p) for p in points])

    def _capture(self, step: int, stack: Stack, pose) -> Frame:
        prob = stack.map.prob()
        stride = max(1, -(-max(prob.shape) // MAX_CELLS))   # every stride-th cell: a preview
        prob = prob[::stride, ::stride]
        coded = np.round(254 * prob).astype(np.uint8)
        coded[np.abs(prob - 0.5) <= 0.01] = UNSEEN
        h, w = coded.shape
        size = stride * stack.map.frame.resolution
        x0, _, y0, _ = stack.map.frame.extent
        plan = stack.plan
        return Frame(step, coded, (x0, x0 + w * size, y0, y0 + h * size),
                     pose_array([pose])[0],
                     None if plan.goal is None else np.array(plan.goal, dtype=float),
                     plan.path.astype(np.float32), self._frontier, self._labels,
                     stack.loop_segments().astype(np.float32))


def ffmpeg_path() -> str | None:
    """The ffmpeg binary to write MP4 with: ``ffmpeg`` on PATH, else the one the imageio-ffmpeg
    package ships (a wheel from the package index, the test extra's), else None."""
    found = shutil.which("ffmpeg")
    if found is not None:
        return found
    try:
        import imageio_ffmpeg
    except ImportError:
        return None
    try:
        return imageio_ffmpeg.get_ffmpeg_exe()
    except RuntimeError:                     # a platform its wheel has no binary for
        return None


def write_animation(folder: str | Path, result, fps: int = FPS, progress: bool = False) -> list[Path]:
    """animation.gif (Pillow) of ``result.frames``, and animation.mp4 when there is an ffmpeg
    (``ffmpeg_path``: on PATH or imageio-ffmpeg's; else a warning says it was skipped); returns the files written. ``progress`` shows a
    progress bar over the frames drawn.

    Each frame: the true world faded, the map (unobserved cells transparent), the frontier
    clusters and the goal with its path, the estimated trajectory up to the frame (the true
    one thin), the robot and the loop closures.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FFMpegWriter, PillowWriter
    from matplotlib.collections import LineCollection

    from sim.figures import ESTIMATE, LOOP, TRUE_PATH, X_LABEL, Y_LABEL, positions

    folder = Path(folder)
    world, frames = result.world, result.frames
    estimate, truth = positions(result.estimate), positions(result.truth)
    m = result.metrics
    width, height = world.size
    fig, ax = plt.subplots(figsize=(6, 6 * height / width + 0.4))
    ax.imshow(world.occupied, origin="lower", extent=world.extent, cmap="Blues", vmin=0, vmax=2.5,
              interpolation="nearest")
    world_map = ax.imshow(np.ma.masked_all((1, 1)), origin="lower", cmap="gray_r", vmin=0, vmax=1,
                          alpha=0.85, interpolation="nearest")
    frontier = ax.scatter([], [], s=2, c=[], cmap="tab10", vmin=0, vmax=10)
    (path,) = ax.plot([], [], "--", color="magenta", lw=1.0)
    (goal,) = ax.plot([], [], "o", mfc="none", mec="magenta", ms=10, mew=2, label="goal")
    # the estimate wide and the truth thin on top of it, as in map_trajectory.png
    (estimate_line,) = ax.plot([], [], "-", color=ESTIMATE, lw=1.8, label="estimate")
    (true_line,) = ax.plot([], [], "-", color=TRUE_PATH, lw=0.7, label="true path")
    (robot,) = ax.plot([], [], "^", mfc=ESTIMATE, mec="black", ms=7)
    loops = LineCollection([], colors=LOOP, lw=1.2, label="loop closure")
    ax.add_collection(loops)
    xmin, xmax, ymin, ymax = world.extent
    ax.set(xlim=(xmin, xmax), ylim=(ymin, ymax), aspect="equal", xlabel=X_LABEL, ylabel=Y_LABEL)
    ax.legend(loc="upper right", fontsize=7)
    # fixed margins, no layout engine: with one, savefig draws every frame twice
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.08, top=0.94)

    def draw(f: Frame) -> None:
        world_map.set_data(np.ma.masked_equal(f.prob, UNSEEN) / 254.0)
        world_map.set_extent(f.extent)
        frontier.set_offsets(f.frontier.reshape(-1, 2))
        frontier.set_array(f.labels % 10)
        path.set_data(f.path[:, 0], f.path[:, 1])
        g = np.zeros((0, 2)) if f.goal is None else f.goal[None]
        goal.set_data(g[:, 0], g[:, 1])
        true_line.set_data(truth[: f.step + 1, 0], truth[: f.step + 1, 1])
        estimate_line.set_data(estimate[: f.step + 1, 0], estimate[: f.step + 1, 1])
        robot.set_data([f.pose[0]], [f.pose[1]])
        loops.set_segments(f.loops)
        ax.set_title(f"{m['world']} ({m['method']}, {m['poses']}): step {f.step}, "
                     f"{len(f.loops)} loop closures", fontsize=9)

    ffmpeg = ffmpeg_path()
    with matplotlib.rc_context({"animation.ffmpeg_path": ffmpeg or "ffmpeg"}):
        writers = {"animation.gif": PillowWriter(fps=fps)}
        if FFMpegWriter.isAvailable():
            writers["animation.mp4"] = FFMpegWriter(fps=fps)
        else:
            warnings.warn("ffmpeg is not on PATH: animation.mp4 skipped, animation.gif only "
                          "(install ffmpeg, or pip install imageio-ffmpeg, for the MP4)", stacklevel=2)
        written = []
        bar = tqdm(total=len(frames) * len(writers), desc="animation", unit="frame", disable=not progress)
        for name, writer in writers.items():
            bar.set_postfix_str(name)
            with replaced_atomically(folder / name) as tmp:
                with writer.saving(fig, tmp, dpi=80):
                    for f in frames:
                        draw(f)
                        writer.grab_frame()
                        bar.update()
            written.append(folder / name)
        bar.close()
    plt.close(fig)
    return written
