import sys

import pytest
from typer.testing import CliRunner

from sim.cli import app

runner = CliRunner()
SHORT_RUN = ["explore", "--world", "cave", "--poses", "truth", "--max-steps", "40", "--seed", "1"]


def test_rerun_without_the_sdk_exits_2_with_the_install_line(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "rerun", None)   # import rerun raises ImportError
    result = runner.invoke(app, SHORT_RUN + ["--out", str(tmp_path), "--rerun", str(tmp_path / "run.rrd")])
    assert result.exit_code == 2
    assert "pip install gpexplore[viz]" in result.output
    assert not (tmp_path / "metrics.json").exists()


def test_rerun_needs_an_rrd_file(tmp_path):
    result = runner.invoke(app, SHORT_RUN + ["--out", str(tmp_path), "--rerun", str(tmp_path / "run.txt")])
    assert result.exit_code == 2 and "--rerun" in result.output


def test_rerun_records_the_run_and_animate_writes_the_gif(tmp_path):
    pytest.importorskip("rerun")
    from PIL import Image

    recording = tmp_path / "rec" / "run.rrd"
    result = runner.invoke(app, SHORT_RUN + ["--out", str(tmp_path), "--rerun", str(recording), "--animate"])
    assert result.exit_code == 0, result.output
    assert recording.stat().st_size > 10_000
    # 40 steps, a frame every 10 (--animate's default) and the last: 0, 10, 20, 30, 39
    with Image.open(tmp_path / "figures" / "animation.gif") as gif:
        assert gif.n_frames == 5
