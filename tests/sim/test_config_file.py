"""The configuration file: dump → load, errors named by their dotted key, and runs that save and
reproduce their configuration."""

import json
import types
import typing

import numpy as np
import pytest
from pydantic import BaseModel
from typer.testing import CliRunner

from sim.cli import app
from sim.config_file import ConfigError, dumps_config, read_config, tomllib
from sim.episode import EpisodeConfig

runner = CliRunner()


def one_line(output):
    """CLI output with rich's error box and line wrapping removed."""
    return " ".join(output.replace("│", " ").split())


def sections(model=EpisodeConfig, prefix=""):
    """(dotted name, model) of every section of the configuration, the root first."""
    found = [(prefix, model)]
    for name, field in model.model_fields.items():
        if isinstance(field.annotation, type) and issubclass(field.annotation, BaseModel):
            found += sections(field.annotation, f"{prefix}{name}.")
    return found


def leaves(table, prefix=""):
    """Dotted names of every setting in a nested dict."""
    return {key for name, value in table.items()
            for key in (leaves(value, f"{prefix}{name}.") if isinstance(value, dict) else [prefix + name])}


def test_dump_holds_every_setting_and_loads_back_equal(tmp_path):
    text = dumps_config(EpisodeConfig())
    expected = {prefix + name for prefix, model in sections() for name, field in model.model_fields.items()
                if not (isinstance(field.annotation, type) and issubclass(field.annotation, BaseModel))
                and field.default is not None}                  # TOML has no null: None is left out
    expected -= {"stack.explorer.robot_radius"}                      # derived from robot.radius
    assert leaves(tomllib.loads(text)) == expected
    assert "# β of eq. 10\nbeta = 2.5" in text                      # descriptions as comments
    changed = EpisodeConfig.model_validate({
        "max_steps": 17, "lidar": {"dropout_value": "nan", "fov_deg": 270.0},
        "stack": {"poses": "truth", "explorer": {"method": "grid", "goals": {"alpha": 3.5}},
                  "com": {"obstacle": {"length_bounds": (0.1, 0.4)}, "fit_hyperparameters": False},
                  "slam": {"loop_closure": {"yaw_offsets_deg": [0.0, 30.0]}},
                  "navigation": {"follower": {"lookahead": 0.7}}}})
    path = tmp_path / "cfg.toml"
    path.write_text(dumps_config(changed))
    assert read_config(path) == changed and read_config(path) != EpisodeConfig()


def test_a_setting_that_may_be_none_defaults_to_none():
    """TOML has no null: None is left out of the file, so it must also be the default."""
    for prefix, model in sections():
        for name, field in model.model_fields.items():
            args = typing.get_args(field.annotation)
            if typing.get_origin(field.annotation) in (typing.Union, types.UnionType) and type(None) in args:
                assert field.default is None, f"{prefix}{name} may be None but defaults to {field.default}"


def test_none_is_left_out_and_reads_back_as_none(tmp_path):
    class Section(BaseModel):
        limit: float | None = None
        steps: int = 3

    path = tmp_path / "s.toml"
    for section in (Section(), Section(limit=2.5, steps=4)):
        path.write_text(dumps_config(section))
        assert read_config(path, Section) == section
    assert "limit" not in tomllib.loads(dumps_config(Section()))


def test_every_section_rejects_unknown_keys():
    for prefix, model in sections():
        assert model.model_config.get("extra") == "forbid", prefix or "root"


@pytest.mark.parametrize("text, message", [
    ("[stack.explorer.goals]\nalfa = 3\n",
     "cfg.toml: stack.explorer.goals.alfa: unknown setting (did you mean alpha?)"),
    ("[stack.explorer.goals]\nalpha = -1\n",
     "cfg.toml: stack.explorer.goals.alpha: Input should be greater than or equal to 0"),
    ("[stack.slam.front_end.registration]\nvoxel_sizes = [1.0, \"fine\"]\n",
     "cfg.toml: stack.slam.front_end.registration.voxel_sizes[1]: Input should be a valid number"),
    ("[stack.com.free]\nnu = 2.0\n", "cfg.toml: stack.com.free.nu: Value error, Matérn nu must be"),
    ("[stack.explorer]\nrobot_radius = 0.3\n",
     "cfg.toml: Value error, stack.explorer.robot_radius 0.3 m differs from robot.radius 0.25 m: the "
     "explorer plans for the robot's radius, set robot.radius only"),
    ("max_steps = 3\n[lidar\nbeams = 3\n", "cfg.toml: Expected ']' at the end of a table declaration "
     "(at line 2, column 7)"),
])
def test_bad_files_are_named_with_the_key_and_problem(tmp_path, text, message):
    path = tmp_path / "cfg.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        read_config(path)
    assert message in str(err.value).replace(str(tmp_path) + "/", "")


@pytest.mark.parametrize("command", [["explore"], ["compare"], ["replay", "x.clf"], ["map", "x.clf"],
                                     ["config", "dump"]])
def test_every_command_rejects_a_bad_file_with_exit_code_2(tmp_path, command):
    path = tmp_path / "cfg.toml"
    path.write_text("[stack.slam.loop_closure]\nsearch_radius = 0\n")
    result = runner.invoke(app, command + ["--config", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2, result.output
    assert "stack.slam.loop_closure.search_radius: Input should be greater than 0" in one_line(result.output)
    assert not (tmp_path / "o").exists()


def test_config_dump_writes_the_defaults(tmp_path):
    result = runner.invoke(app, ["config", "dump"])
    assert result.exit_code == 0 and result.output == dumps_config(EpisodeConfig())
    path = tmp_path / "yaml_made.toml"
    (tmp_path / "cfg.yaml").write_text("lidar:\n  beams: 91\n")     # YAML is read too, by its suffix
    result = runner.invoke(app, ["config", "dump", "--config", str(tmp_path / "cfg.yaml"), "--out", str(path)])
    assert result.exit_code == 0, result.output
    assert read_config(path) == EpisodeConfig(lidar={"beams": 91})


def room(tmp_path):
    from PIL import Image

    pixels = np.full((60, 100), 255, dtype=np.uint8)  # 5 m x 3 m at 0.05 m, walls around
    pixels[:2], pixels[-2:], pixels[:, :2], pixels[:, -2:] = 0, 0, 0, 0
    Image.fromarray(pixels).save(tmp_path / "room.png")
    return ["--world", str(tmp_path / "room.png"), "--size", "5", "3", "--seed", "3"]


def test_a_saved_configuration_reproduces_its_run_and_a_changed_one_changes_it(tmp_path):
    first = tmp_path / "first"
    result = runner.invoke(app, ["explore", *room(tmp_path), "--method", "grid", "--max-steps", "12",
                                 "--out", str(first)])
    assert result.exit_code == 0, result.output
    saved = read_config(first / "config.toml")
    assert saved.max_steps == 12 and saved.stack.explorer.method == "grid"
    again = tmp_path / "again"
    result = runner.invoke(app, ["explore", *room(tmp_path), "--config", str(first / "config.toml"),
                                 "--out", str(again)])
    assert result.exit_code == 0, result.output
    a, b = (json.loads((run / "metrics.json").read_text()) for run in (first, again))
    assert a.pop("wall_time_s") > a.pop("onboard_time_s") > 0 and b.pop("wall_time_s") > b.pop("onboard_time_s") > 0
    assert a == b and a["steps"] == 12 and a["method"] == "grid"
    # a file's settings reach the run: fewer steps, a slower laser (sim time = steps / rate)
    changed = tmp_path / "changed.toml"
    changed.write_text("max_steps = 7\n[lidar]\nrate_hz = 5.0\n")
    result = runner.invoke(app, ["explore", *room(tmp_path), "--config", str(changed), "--out", str(tmp_path / "c")])
    assert result.exit_code == 0, result.output
    m = json.loads((tmp_path / "c" / "metrics.json").read_text())
    assert m["steps"] == 7 and m["sim_time_s"] == pytest.approx(7 / 5.0)


def test_the_explorer_plans_for_the_robots_radius_set_in_one_place(tmp_path):
    """robot.radius is the one setting; the explorer's radius is derived from it, not dumped, and
    a file that sets it to another value is refused."""
    assert EpisodeConfig().stack.explorer.robot_radius == EpisodeConfig().robot.radius
    path = tmp_path / "cfg.toml"
    path.write_text("[robot]\nradius = 0.3\n")
    cfg = read_config(path)
    assert cfg.stack.explorer.robot_radius == 0.3
    assert cfg.overridden(method="grid").stack.explorer.robot_radius == 0.3
    assert "robot_radius" not in dumps_config(cfg)
    path.write_text(dumps_config(cfg))
    assert read_config(path) == cfg
    path.write_text("[robot]\nradius = 0.3\n[stack.explorer]\nrobot_radius = 0.3\n")
    assert read_config(path) == cfg                                  # the same value is no conflict
    with pytest.raises(ValueError, match="robot_radius 0.4 m differs from robot.radius 0.25 m"):
        EpisodeConfig(stack={"explorer": {"robot_radius": 0.4}})


def test_dumped_defaults_carry_no_float_noise():
    """Every float of the default configuration is written as the short decimal it was meant to
    be (0.05**2 is 0.0025000000000000005): no shorter decimal within one ulp of it."""
    text = dumps_config(EpisodeConfig())
    assert "alpha1 = 0.0025\n" in text and "0000000" not in text

    def noisy(value):
        return isinstance(value, float) and any(
            0 < abs(float(f"{value:.{d}g}") - value) <= np.spacing(abs(value)) for d in range(1, 16))

    def floats(table):
        for value in table.values():
            if isinstance(value, dict):
                yield from floats(value)
            else:
                yield from (value if isinstance(value, list) else [value])

    assert not [v for v in floats(tomllib.loads(text)) if noisy(v)]
