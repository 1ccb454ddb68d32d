"""The options the `gpexplore` commands share, each defined once: its type, its validation (typer
rejects a bad value with exit code 2, naming the option) and its help text."""

from __future__ import annotations

import math
from enum import Enum
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.markup import escape

from sim.worlds import BUILTIN_WORLDS


class Method(str, Enum):
    """The explorer: C-frontier on the COM, or the log-odds grid's nearest frontier."""

    gp = "gp"
    grid = "grid"


class Poses(str, Enum):
    """Where a run's poses come from: Pose SLAM, or the true poses (perfect localisation)."""

    slam = "slam"
    truth = "truth"


class LogPoses(str, Enum):
    """The poses a log is mapped at: the log's own (a bag's odometry), or the SLAM replay's."""

    log = "log"
    slam = "slam"


class Solver(str, Enum):
    """GTSAM's optimiser of a pose graph: Powell's dog-leg or Levenberg–Marquardt."""

    dogleg = "dogleg"
    lm = "lm"


class Engine(str, Enum):
    """Where a campaign's runs execute: a process pool here, or a Dask cluster."""

    local = "local"
    dask = "dask"


#: The built-in worlds, which come with a start and a scripted tour.
Builtin = Enum("Builtin", {name: name for name in BUILTIN_WORLDS}, type=str)


# --- validation shared by several options ---------------------------------------------------

def numbers(usage: str):
    """The parser of each value of a tuple option such as ``--start X Y THETA``. Click hands the
    option exactly as many words as it takes, so a number left out shows up here as the next
    option's name: ``--start 5 5 --out X`` is ``--start X Y THETA needs 3 numbers, got '--out'``."""
    count = len(usage.split()) - 1

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise typer.BadParameter(f"{usage} needs {count} numbers, got {text!r}")
        return value

    return parse


def positive(value: Optional[float]) -> Optional[float]:
    """A length (m) or resolution: positive and finite."""
    if value is not None and not (value > 0 and math.isfinite(value)):
        raise typer.BadParameter(f"{value} is not a positive finite number")
    return value


def fraction(value: float) -> float:
    """A fraction in [0, 1); NaN is none."""
    if not 0 <= value < 1:
        raise typer.BadParameter(f"{value} is not a fraction in [0, 1)")
    return value


def comma_list(choices: type[Enum] | None = None):
    """The parser of each value of a repeatable option that also takes a comma-separated list:
    ``--methods gp,grid`` is ``--methods gp --methods grid``; with ``choices``, each name must be
    one of them."""

    def parse(text: str) -> list:
        names = [n.strip() for n in text.split(",") if n.strip()]
        if not names:
            raise typer.BadParameter(f"{text!r} names nothing")
        if choices is None:
            return names
        have = [c.value for c in choices]
        unknown = [n for n in names if n not in have]
        if unknown:
            raise typer.BadParameter(f"{unknown[0]!r} is not one of {', '.join(map(repr, have))}")
        return [choices(n) for n in names]

    return parse


def distinct(values: list[list]) -> list:
    """The names of a repeatable comma-list option, in order, each once."""
    names = [n for group in values for n in group]
    twice = list(dict.fromkeys(n for n in names if names.count(n) > 1))
    if twice:
        raise typer.BadParameter(f"{', '.join(getattr(n, 'value', n) for n in twice)} given twice")
    return names


def episode_config(path: Optional[Path]):
    """The whole configuration (``EpisodeConfig``) in ``path``, TOML or YAML by its suffix; the
    defaults without one. A bad file is a usage error naming the file, the dotted key and the
    problem: ``cfg.toml: stack.explorer.goals.alpha: Input should be greater than or equal to 0``."""
    from sim.config_file import ConfigError, read_config
    from sim.episode import EpisodeConfig

    if path is None:
        return EpisodeConfig()
    try:
        return read_config(path)
    except ConfigError as err:
        raise typer.BadParameter(str(err), param_hint="'--config'") from None


def _check_config(path: Optional[Path]) -> Optional[Path]:
    episode_config(path)
    return path


# --- the options ----------------------------------------------------------------------------

WORLD_HELP = f"built-in name ({', '.join(BUILTIN_WORLDS)}), bitmap (PNG/PGM) or ROS map_server .yaml"
LOG_HELP = ("CARMEN log (.clf/.log, optionally .gz) or ROS bag (ROS 1 .bag; ROS 2 bag directory, "
            ".db3 or .mcap)")

World = Annotated[str, typer.Option(help=WORLD_HELP)]
WorldArgument = Annotated[str, typer.Argument(help=WORLD_HELP)]
Worlds = Annotated[list[str], typer.Option(
    parser=comma_list(), callback=distinct, metavar="WORLD,…",
    help=f"worlds, comma-separated or repeated: {WORLD_HELP}")]
Size = Annotated[Optional[tuple[float, float]], typer.Option(
    parser=numbers("--size W H"), metavar="W H",
    help="size of a bitmap world in meters (stretched as Stage does; the Stage cave is 20 20)")]
Resolution = Annotated[Optional[float], typer.Option(
    callback=positive, help="resolution of a bitmap world, m/pixel (instead of --size)")]
Start = Annotated[Optional[tuple[float, float, float]], typer.Option(
    parser=numbers("--start X Y THETA"), metavar="X Y THETA",
    help="start pose (m, m, rad); default: the built-in world's start, else a free corner")]

Seed = Annotated[int, typer.Option(min=0, help="seed of every random draw")]
Seeds = Annotated[int, typer.Option(min=1, help="runs per world and method, seeds 0..N-1")]
MethodOption = Annotated[Optional[Method], typer.Option(
    "--method", help="gp (C-frontier on the COM) or grid (nearest frontier on a log-odds grid); "
    "default: the configuration's stack.explorer.method, gp")]
Methods = Annotated[list[Method], typer.Option(
    parser=comma_list(Method), callback=distinct, metavar="METHOD,…",
    help="methods to compare, comma-separated or repeated: gp, grid")]
PosesOption = Annotated[Optional[Poses], typer.Option(
    "--poses", help="slam (Pose SLAM) or truth (perfect localisation); default: the "
    "configuration's stack.poses, slam")]
MaxSteps = Annotated[Optional[int], typer.Option(
    min=1, help="scans before a run stops; default: the configuration's max_steps, 6000")]

Config = Annotated[Optional[Path], typer.Option(
    exists=True, dir_okay=False, is_eager=True, callback=_check_config,
    help=escape("configuration file, TOML or YAML (`gpexplore config dump` writes one; settings "
                "left out keep their defaults); replay and map read its [stack.slam] and "
                "[stack.com] sections"))]
Out = Annotated[Path, typer.Option(file_okay=False, help="output directory (a run owns it: see --overwrite)")]
Overwrite = Annotated[bool, typer.Option(
    "--overwrite", help="replace an earlier run's results in --out (it is cleared first; a folder "
    "gpexplore did not write is never cleared)")]

Log = Annotated[Path, typer.Argument(exists=True, metavar="LOG", help=LOG_HELP)]
SkipMalformed = Annotated[bool, typer.Option(
    help="CARMEN logs: skip malformed lines (counted, the first one named) instead of failing")]
ScanTopic = Annotated[Optional[str], typer.Option(
    help="ROS bags: the sensor_msgs/LaserScan topic (default: the only one, or /scan)")]
OdomTopic = Annotated[Optional[str], typer.Option(
    help="ROS bags: the nav_msgs/Odometry topic (default: the only one, or /odom)")]
