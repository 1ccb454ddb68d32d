"""The `gpexplore replay` and `gpexplore posegraph` commands."""

import json

import numpy as np
from typer.testing import CliRunner

from sim.cli import app

runner = CliRunner()


def test_posegraph_prints_chi2_and_writes(tmp_path):
    graph = tmp_path / "tri.g2o"
    graph.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.2 0.1 0\nVERTEX_SE2 2 1.9 1.1 1.7\n"
                     "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 1000\nEDGE_SE2 1 2 1 0 1.5708 100 0 0 100 0 1000\n"
                     "EDGE_SE2 0 2 2 0 1.5708 100 0 0 100 0 1000\n")
    out = tmp_path / "opt.g2o"
    result = runner.invoke(app, ["posegraph", str(graph), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "chi2" in result.output and out.exists()
    after = float(result.output.split("chi2 (g2o EdgeSE2):")[1].split("->")[1].split()[0])
    assert after < 1e-8          # a consistent triangle is solved exactly
    result = runner.invoke(app, ["posegraph", str(graph), "--out", str(out)])
    assert result.exit_code == 0, result.output                           # an existing file is replaced


def test_posegraph_says_what_it_optimises_before_each_silent_stage(tmp_path):
    """GTSAM's optimize and the χ² refinement are one call each (INTEL with lm: seconds of
    silence): a status line on stderr names each before it runs; stdout keeps the results."""
    graph = tmp_path / "tri.g2o"
    graph.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.2 0.1 0\nVERTEX_SE2 2 1.9 1.1 1.7\n"
                     "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 1000\nEDGE_SE2 1 2 1 0 1.5708 100 0 0 100 0 1000\n"
                     "EDGE_SE2 0 2 2 0 1.5708 100 0 0 100 0 1000\n")
    result = runner.invoke(app, ["posegraph", str(graph), "--method", "lm"])
    assert result.exit_code == 0, result.output
    assert "optimising 3 poses, 3 edges: GTSAM lm (QR) ..." in result.stderr
    assert "Levenberg–Marquardt on g2o's exact chi2 ..." in result.stderr
    assert "optimising" not in result.stdout and "chi2 (g2o EdgeSE2)" in result.stdout


def test_posegraph_bad_file_names_the_line(tmp_path):
    graph = tmp_path / "bad.g2o"
    graph.write_text("EDGE_SE2 0 1 1 0\n")
    result = runner.invoke(app, ["posegraph", str(graph)])
    assert result.exit_code == 2 and "bad.g2o:1" in "".join(result.output.split())


def test_replay_bad_inputs_are_clear(tmp_path):
    empty = tmp_path / "empty.clf"
    empty.write_text("# nothing\n")
    result = runner.invoke(app, ["replay", str(empty), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "no laser messages" in " ".join(result.output.split())
    missing = tmp_path / "missing.clf"
    result = runner.invoke(app, ["replay", str(missing)])                 # named by typer, before any work
    assert result.exit_code == 2
    assert f"'LOG':path'{missing}'doesnotexist" in "".join(result.output.replace("│", "").split())


def test_replay_small_log_with_foreign_relations(tmp_path, shared_data):
    # the first 150 scans of CSAIL; a relations file from another time base is refused clearly
    lines = (shared_data / "logs" / "mit-csail.clf").read_text().splitlines()[:150]
    log = tmp_path / "short.clf"
    log.write_text("\n".join(lines) + "\n")
    relations = tmp_path / "other.relations"
    relations.write_text("12.0 13.0 0.1 0 0 0 0 0\n")
    out = tmp_path / "o"
    result = runner.invoke(app, ["replay", str(log), "--out", str(out), "--relations", str(relations)])
    assert result.exit_code == 2 and "different time bases" in " ".join(result.output.split())
    result = runner.invoke(app, ["replay", str(log), "--out", str(out)])
    assert result.exit_code == 0, result.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["scans"] == 150 and (out / "trajectory.png").exists()
    assert metrics["software"]["packages"]["numpy"] == np.__version__     # what it was computed with


def test_replay_config_file_is_validated(tmp_path, shared_data):
    import yaml

    from sim.config_file import read_config
    from slam.config import SlamConfig

    lines = (shared_data / "logs" / "mit-csail.clf").read_text().splitlines()[:60]
    log = tmp_path / "short.clf"
    log.write_text("\n".join(lines) + "\n")
    config = SlamConfig()
    config.loop_closure.enabled = False
    good = tmp_path / "good.yaml"                     # YAML is read too, by its suffix
    good.write_text(yaml.safe_dump({"stack": {"slam": config.model_dump()}}))
    result = runner.invoke(app, ["replay", str(log), "--out", str(tmp_path / "o"), "--config", str(good)])
    assert result.exit_code == 0, result.output
    assert read_config(tmp_path / "o" / "config.toml").stack.slam == config     # the run's configuration
    bad = tmp_path / "bad.yaml"
    bad.write_text("stack:\n  slam:\n    loop_closure:\n      serch_radius: 3\n")
    result = runner.invoke(app, ["replay", str(log), "--config", str(bad)])
    assert result.exit_code == 2
    assert "stack.slam.loop_closure.serch_radius: unknown setting" in " ".join(result.output.split())


def tiny_log(path, scans=5):
    """A CARMEN log of ``scans`` FLASER lines, 3 beams, stamps 100.0, 100.1, ..."""
    lines = [f"FLASER 3 1.0 1.0 1.0 {0.1 * k:.1f} 0 0 {0.1 * k:.1f} 0 0 {100 + 0.1 * k:.1f} host {100 + 0.1 * k:.1f}"
             for k in range(scans)]
    path.write_text("\n".join(lines) + "\n")
    return path


def no_work(*args, **kwargs):
    raise AssertionError("the replay started before its inputs were checked")


def test_replay_checks_relations_and_output_before_the_replay(tmp_path, monkeypatch):
    import sim.logs

    monkeypatch.setattr(sim.logs, "replay_log", no_work)
    log = tiny_log(tmp_path / "tiny.clf")
    out = tmp_path / "o"
    bad = tmp_path / "bad.relations"
    bad.write_text("100.0 100.2 0.2 0 0 0 0 0\n100.0 100.2 0.2 0 0 0 0\n")
    binary = tmp_path / "binary.relations"
    binary.write_bytes(b"\xff\xfe\x00\x01")
    foreign = tmp_path / "foreign.relations"
    foreign.write_text("12.0 13.0 0.1 0 0 0 0 0\n")
    for relations, message in [(bad, "bad.relations:2: relation line has 7 fields, expected 8"),
                               (binary, "binary.relations: not a text file"),
                               (foreign, "different time bases")]:
        result = runner.invoke(app, ["replay", str(log), "--out", str(out), "--relations", str(relations)])
        assert result.exit_code == 2 and "'--relations'" in one_line(result.output), result.output
        assert squeezed(message) in squeezed(result.output) and not out.exists()
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("x")
    result = runner.invoke(app, ["replay", str(log), "--out", str(tmp_path / "mine")])
    assert result.exit_code == 2 and "not a gpexplore run folder" in one_line(result.output)


def one_line(output):
    return " ".join(output.replace("│", " ").split())


def squeezed(text):
    """``text`` without whitespace and rich's box: a wrapped path compares equal."""
    return "".join(text.replace("│", "").split())


def test_posegraph_warns_of_an_undeclared_vertex_and_names_a_missing_file(tmp_path):
    graph = tmp_path / "g.g2o"
    graph.write_text("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 7 1 0 0 1 0 0 1 0 1\n")
    result = runner.invoke(app, ["posegraph", str(graph)])
    assert result.exit_code == 0, result.output
    assert squeezed(f"warning: {graph}:2: an edge refers to vertex 7") in squeezed(result.output)
    result = runner.invoke(app, ["posegraph", str(tmp_path / "gone.g2o")])
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert squeezed(f"Invalid value for 'GRAPH': file '{tmp_path / 'gone.g2o'}' does not exist.") in squeezed(result.output)
