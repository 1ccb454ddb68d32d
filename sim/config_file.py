"""gpexplore's configuration as a file: the full root model (EpisodeConfig) written as TOML, with
each field's description as a comment, and read back from TOML (or YAML, by suffix).

TOML has no null: a field whose value is None is left out of the file, and a field left out
takes its default. A field that may be None therefore has None as its default, so that
writing and reading a configuration gives the same one back.
"""

from __future__ import annotations

import difflib
import re
import sys
import textwrap
from pathlib import Path

import tomli_w
import yaml
from pydantic import BaseModel, ValidationError

from sim.episode import DERIVED_SETTINGS, EpisodeConfig
from slam.atomic import write_text_atomic

if sys.version_info >= (3, 11):
    import tomllib
else:                                   # pragma: no cover - the backport on Python 3.10
    import tomli as tomllib

#: The name every run writes its configuration under, next to its metrics.json.
CONFIG_NAME = "config.toml"

_HEADER = """\
# gpexplore configuration: every section, with its defaults unless changed.
# Read by `--config FILE` of explore, compare, campaign, replay and map (replay and map use the
# [stack.slam] and [stack.com] sections). Keys left out keep their defaults; TOML has no
# null, so a setting that is None is left out.
"""


class ConfigError(ValueError):
    """A configuration file that cannot be read, parsed or validated; the message names the file
    and, for a bad value, the dotted key: ``cfg.toml: stack.explorer.goals.alpha: ...``."""


def read_config(path: str | Path, model: type[BaseModel] = EpisodeConfig) -> BaseModel:
    """The configuration in ``path``: YAML for .yaml/.yml, TOML otherwise.

    Raises:
        ConfigError: the file is missing, not valid TOML/YAML (the line is named), has an
            unknown key, or a value out of range (each named by its dotted key).
    """
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{path}: cannot read: {err}") from None
    try:
        data = (yaml.safe_load(text) if path.suffix in (".yaml", ".yml") else tomllib.loads(text)) or {}
    except (tomllib.TOMLDecodeError, yaml.YAMLError) as err:
        raise ConfigError(f"{path}: {' '.join(str(err).split())}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a table of settings, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise ConfigError(validation_message(err, model, path)) from None


def dumps_config(config: BaseModel) -> str:
    """``config`` as TOML, every field written (None ones and, for the root EpisodeConfig, those
    derived from others, ``DERIVED_SETTINGS``, left out), its description above it."""
    derived = DERIVED_SETTINGS if isinstance(config, EpisodeConfig) else None
    text = tomli_w.dumps(config.model_dump(exclude_none=True, exclude=derived))
    return _HEADER + "\n" + _describe(text, type(config))


def write_config(path: str | Path, config: BaseModel) -> None:
    """Write ``config`` as TOML to ``path``, atomically."""
    write_text_atomic(path, dumps_config(config))


def validation_message(err: ValidationError, model: type[BaseModel],
                       source: str | Path | None = None) -> str:
    """One line per problem of ``model``'s validation: ``source: dotted.key: what is wrong``; an
    unknown key comes with the closest known ones of its section."""
    prefix = f"{source}: " if source is not None else ""
    lines = []
    for e in err.errors():
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            known = _section(model, e["loc"][:-1]).model_fields
            close = difflib.get_close_matches(str(e["loc"][-1]), known, n=2)
            msg = "unknown setting" + (f" (did you mean {' or '.join(close)}?)" if close else "")
        lines.append(f"{prefix}{_key(e['loc'])}{msg}")
    return "\n".join(lines)


def _section(root: type[BaseModel], names) -> type[BaseModel]:
    """The model of the section at dotted path ``names`` under ``root``."""
    for name in names:
        root = root.model_fields[name].annotation
    return root


def _key(loc: tuple) -> str:
    """'stack.slam.keyframes.between_sigma_floor[2]: ' from pydantic's error location."""
    key = "".join(f"[{part}]" if isinstance(part, int) else f".{part}" for part in loc).lstrip(".")
    return f"{key}: " if key else ""


_TABLE = re.compile(r"^\[([\w.]+)\]$")
_SETTING = re.compile(r"^(\w+) = ")


def _describe(text: str, root: type[BaseModel]) -> str:
    """Put each field's description, as a comment, above its line in tomli-w's output."""
    lines, model = [], root
    for line in text.splitlines():
        if table := _TABLE.match(line):
            model = _section(root, table.group(1).split("."))
            lines += _comment((model.__doc__ or "").strip().split("\n\n")[0])
        elif setting := _SETTING.match(line):
            lines += _comment(model.model_fields[setting.group(1)].description or "")
        lines.append(line)
    return "\n".join(lines) + "\n"


def _comment(text: str) -> list[str]:
    """``text`` as TOML comment lines of at most 96 characters."""
    return textwrap.wrap(" ".join(text.split()), 96, initial_indent="# ", subsequent_indent="# ")
