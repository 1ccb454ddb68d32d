import shutil

import numpy as np
import pytest
from PIL import Image

from sim import animation
from sim.animation import MAX_CELLS, UNSEEN, FrameRecorder, write_animation
from sim.episode import EpisodeConfig, run_episode
from exploration.stack import StackConfig
from sim.worlds import BUILTIN_WORLDS

EVERY = 7


def cave_run(method: str, animate_every: int, watch=None):
    cave = BUILTIN_WORLDS["cave"]()
    config = EpisodeConfig(max_steps=90, animate_every=animate_every,
                           stack=StackConfig(poses="truth", explorer={"method": method}))
    return run_episode(cave.world, cave.start, config, seed=3, watch=watch)


@pytest.fixture(scope="module", params=["gp", "grid"])
def run(request):
    """A short run; ``last_plan`` and ``goal_choice`` are the last plan and the last that chose
    a goal (or ended exploring), each with the map origin and resolution then."""
    seen = {"goal_choices": 0}

    def watch(step, t, stack, out, scan, truth):
        if out.plan is not None:
            seen["last_plan"] = (out.plan, stack.map.frame.origin.copy(), stack.map.frame.resolution)
            if out.plan.new_goal or out.plan.goal is None:
                seen["goal_choice"] = seen["last_plan"]
                seen["goal_choices"] += 1

    result = cave_run(request.param, EVERY, watch)
    result.last_plan, result.goal_choice = seen["last_plan"], seen["goal_choice"]
    result.goal_choices = seen["goal_choices"]
    return result


def test_a_frame_every_n_steps_and_at_the_last_step(run):
    steps = run.metrics["steps"]
    expected = list(range(0, steps, EVERY))
    if expected[-1] != steps - 1:
        expected.append(steps - 1)
    assert [f.step for f in run.frames] == expected


def test_frames_hold_the_run_at_their_step(run):
    for f in run.frames:
        p = run.estimate[f.step]
        np.testing.assert_allclose(f.pose, [p.x(), p.y(), p.theta()])
    last = run.frames[-1]
    stack = run.stack
    # the last frame shows the final map, plan and the whole estimated trajectory
    np.testing.assert_array_equal(last.goal, stack.plan.goal)
    np.testing.assert_allclose(last.path, stack.plan.path, atol=1e-5)
    prob = stack.map.prob()
    assert max(prob.shape) <= MAX_CELLS and last.prob.shape == prob.shape
    seen = last.prob != UNSEEN
    np.testing.assert_array_equal(seen, np.abs(prob - 0.5) > 0.01)
    np.testing.assert_allclose(last.prob[seen] / 254, prob[seen], atol=0.5 / 254)
    x0, x1, y0, y1 = last.extent
    resolution = stack.map.frame.resolution
    assert (x1 - x0, y1 - y0) == pytest.approx((prob.shape[1] * resolution, prob.shape[0] * resolution))
    # the map grows while the robot explores
    assert (run.frames[0].prob != UNSEEN).sum() < seen.sum()


def test_the_frontier_is_the_last_goal_choices(run):
    """The frames show the frontier clusters the last goal was chosen from, in meters: the
    k-means clusters (gp), or the frontier regions (grid)."""
    assert run.goal_choices >= 2
    last = run.frames[-1]
    clusters = run.goal_choice[0].clusters
    assert clusters
    np.testing.assert_allclose(last.frontier, np.vstack([k.points for k in clusters]), atol=1e-5)
    np.testing.assert_array_equal(np.bincount(last.labels), [len(k.points) for k in clusters])


def test_gif_has_one_frame_per_recorded_frame(run, tmp_path):
    written = write_animation(tmp_path, run)
    assert tmp_path / "animation.gif" in written
    with Image.open(tmp_path / "animation.gif") as gif:
        assert gif.n_frames == len(run.frames)
        assert gif.size[0] >= 400


def test_frames_are_reproducible_and_do_not_change_the_run(run):
    method = run.metrics["method"]
    again = cave_run(method, EVERY)
    plain = cave_run(method, 0)
    assert plain.frames == []
    for a, b in zip(run.frames, again.frames, strict=True):
        for name, value in vars(a).items():
            np.testing.assert_array_equal(value, getattr(b, name), err_msg=name)
    m, p = dict(run.metrics), dict(plain.metrics)
    for metrics in (m, p):
        metrics.pop("wall_time_s"), metrics.pop("onboard_time_s")
    assert m == p


@pytest.mark.skipif(animation.ffmpeg_path() is None, reason="no ffmpeg: on PATH nor imageio-ffmpeg's")
def test_mp4_when_there_is_an_ffmpeg(run, tmp_path):
    written = write_animation(tmp_path, run)
    assert tmp_path / "animation.mp4" in written
    head = (tmp_path / "animation.mp4").read_bytes()[:12]
    assert head[4:8] == b"ftyp"     # an MP4 (ISO media) file


def test_without_ffmpeg_on_path_imageio_ffmpegs_binary_writes_the_mp4(run, tmp_path, monkeypatch):
    """The test extra's imageio-ffmpeg gives CI an ffmpeg from the package index."""
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    which = shutil.which
    monkeypatch.setattr(shutil, "which", lambda name, *args, **kw: None if name == "ffmpeg" else which(name, *args, **kw))
    assert animation.ffmpeg_path() == imageio_ffmpeg.get_ffmpeg_exe()
    written = write_animation(tmp_path, run)
    assert tmp_path / "animation.mp4" in written
    assert (tmp_path / "animation.mp4").read_bytes()[4:8] == b"ftyp"
    import matplotlib

    assert matplotlib.rcParams["animation.ffmpeg_path"] == "ffmpeg"       # set for the writing only


def test_large_maps_are_recorded_strided_over_the_same_extent(run, monkeypatch):
    monkeypatch.setattr(animation, "MAX_CELLS", 50)
    recorder = FrameRecorder(every=1)
    recorder.finish(0, run.stack, run.estimate[0])
    small, full = recorder.frames[0], run.frames[-1]
    assert max(small.prob.shape) <= 50 < max(full.prob.shape)
    stride = -(-max(full.prob.shape) // 50)
    np.testing.assert_array_equal(small.prob, full.prob[::stride, ::stride])
    # the same corner; the far edges overhang by less than one strided cell
    assert small.extent[0] == full.extent[0] and small.extent[2] == full.extent[2]
    cell = stride * run.stack.map.frame.resolution
    assert 0 <= small.extent[1] - full.extent[1] < cell and 0 <= small.extent[3] - full.extent[3] < cell


def test_without_ffmpeg_the_mp4_is_skipped_with_a_warning(run, tmp_path, monkeypatch):
    from matplotlib.animation import FFMpegWriter

    monkeypatch.setattr(FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    with pytest.warns(UserWarning, match="ffmpeg is not on PATH: animation.mp4 skipped"):
        written = write_animation(tmp_path, run)
    assert written == [tmp_path / "animation.gif"]


def test_rendering_shows_progress_when_asked(run, tmp_path, monkeypatch, capsys):
    from matplotlib.animation import FFMpegWriter

    monkeypatch.setattr(FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    with pytest.warns(UserWarning):
        write_animation(tmp_path, run)
    assert capsys.readouterr().err == ""                 # quiet unless asked
    with pytest.warns(UserWarning):
        write_animation(tmp_path, run, progress=True)
    n = len(run.frames)
    err = capsys.readouterr().err
    assert "animation" in err and f"{n}/{n}" in err     # a bar over the frames drawn, to the end
