"""Fuzz tests of every file reader: any input gives either a parsed result or one clear error of
the reader's own type whose message names the file (and the line where there is one); never
another exception type, never a traceback on the command line.

Deterministic (``derandomize``) and bounded, so that CI runs the same examples in a few seconds.
"""

import gzip
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from sim.config_file import ConfigError, read_config
from sim.world_io import RosMap, read_ros_map
from slam.carmen import CarmenLog, LogFormatError
from slam.evaluation import RelationsError, read_relations
from slam.g2o import G2oFormatError, read_g2o

FUZZ = settings(max_examples=150, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


#: Every example's files, removed when the test process ends (function-scoped fixtures such as
#: tmp_path would be shared by all of a test's examples).
_FILES = tempfile.TemporaryDirectory(prefix="gpexplore-fuzz-")


def written(name: str, data: bytes | str) -> Path:
    """``data`` in a file ``name`` of a fresh folder of its own."""
    path = Path(tempfile.mkdtemp(dir=_FILES.name)) / name
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def assert_names(err: Exception, path: Path, line: bool = False) -> None:
    """The message starts with the file's path (and ``:N:`` for a line), on one line per problem."""
    message = str(err)
    event(f"error: {' '.join(message[len(str(path)):].split()[:4])}"[:60])
    assert message.startswith(str(path)), message
    if line:
        assert re.match(re.escape(str(path)) + r"(:\d+)?: \S", message), message
    for text in message.splitlines():
        assert text.startswith(str(path)), message
    assert not any(phrase in message for phrase in PYTHON_INTERNALS), message


#: Python's own messages, which say nothing about the file: a reader words its errors itself.
PYTHON_INTERNALS = ("list index out of range", "invalid literal for", "could not convert", "not enough values",
                    "too many values", "NoneType", "object is not")


# --- building blocks -------------------------------------------------------------------------

NUMBER = st.one_of(
    st.integers(-3, 400).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["0", "1", "-1", "0.5", "nan", "inf", "-inf", "1e999", "1e-320", "81.91", "9" * 30]),
)
JUNK = st.one_of(st.text(st.characters(blacklist_categories=("Zs", "Zl", "Zp", "Cc", "Cs")), min_size=1, max_size=6),
                 st.sampled_from(["host", "x", "#", "[", "]", "=", '"', "\x00", "é"]))
TOKEN = st.one_of(NUMBER, NUMBER, NUMBER, JUNK)


def tagged(tags: list[str], length: tuple[int, int]):
    """Lines of a tag and ``length`` tokens, most of them numbers."""
    return st.builds(lambda tag, rest: " ".join([tag, *rest]), st.sampled_from(tags),
                     st.lists(TOKEN, min_size=length[0], max_size=length[1]))


def document(lines):
    """A file's text: ``lines`` joined, with blank and comment lines among them."""
    return st.lists(st.one_of(lines, lines, lines, st.just(""), st.just("# comment"),
                              st.lists(TOKEN, max_size=6).map(" ".join)),
                    max_size=12).map("\n".join)


# --- CARMEN ----------------------------------------------------------------------------------

SMALL = st.floats(-50, 90, allow_nan=False).map(lambda v: f"{v:.3f}")


@st.composite
def mutated(draw, tokens):
    """A well-formed line's ``tokens``, often with one dropped, replaced or repeated."""
    tokens = list(tokens)
    for _ in range(draw(st.sampled_from([0, 0, 1, 2]))):
        i = draw(st.integers(0, len(tokens) - 1))
        how = draw(st.sampled_from(["drop", "replace", "repeat"]))
        if how == "drop" and len(tokens) > 1:
            del tokens[i]
        elif how == "replace":
            tokens[i] = draw(TOKEN)
        else:
            tokens.insert(i, tokens[i])
    return " ".join(tokens)


@st.composite
def carmen_line(draw):
    kind = draw(st.sampled_from(["FLASER", "FLASER", "ODOM", "ROBOTLASER1", "PARAM", "other"]))
    stamp = [draw(SMALL), "host", draw(SMALL)]
    if kind == "FLASER":
        n = draw(st.integers(1, 5))
        tokens = ["FLASER", str(n), *draw(st.lists(SMALL, min_size=n + 6, max_size=n + 6)), *stamp]
    elif kind == "ODOM":
        tokens = ["ODOM", *draw(st.lists(SMALL, min_size=6, max_size=6)), *stamp]
    elif kind == "ROBOTLASER1":
        n, m = draw(st.integers(1, 4)), draw(st.integers(0, 2))
        tokens = ["ROBOTLASER1", "0", "-1.57", "3.14", "0.785", "80", "0.01", "0", str(n),
                  *draw(st.lists(SMALL, min_size=n, max_size=n)), str(m), *draw(st.lists(SMALL, min_size=m, max_size=m)),
                  *draw(st.lists(SMALL, min_size=12, max_size=12)), *stamp]
    elif kind == "PARAM":
        tokens = ["PARAM", draw(JUNK), draw(TOKEN)]
    else:
        return draw(tagged(["FLASER", "ODOM", "ROBOTLASER1", "RAWLASER1", "TRUEPOS"], (0, 20)))
    return draw(mutated(tokens))


CARMEN_LINES = carmen_line()


@FUZZ
@given(text=document(CARMEN_LINES), skip=st.booleans())
def test_carmen_reader(text, skip):
    path = written("log.clf", text)
    try:
        log = CarmenLog(path, skip_malformed=skip)
    except LogFormatError as err:
        assert_names(err, path, line=True)
        return
    event(f"parsed ({'skipped lines' if log.skipped else 'all lines'})")
    assert len(log) >= 1 and all(np.isfinite([r.pose.x(), r.pose.y(), r.pose.theta()]).all() for r in log)


@FUZZ
@given(data=st.binary(max_size=200), compress=st.booleans())
def test_carmen_reader_on_bytes_and_broken_gzip(data, compress):
    path = written("log.clf.gz", gzip.compress(data)[: len(data) // 2 + 10] if compress else data)
    try:
        CarmenLog(path)
    except LogFormatError as err:
        assert_names(err, path)


# --- g2o -------------------------------------------------------------------------------------

@st.composite
def g2o_graphs(draw):
    """A small valid graph (vertices, a chain of edges and a loop), some lines mutated, some
    vertices left undeclared, with other lines among them."""
    k = draw(st.integers(2, 5))
    declared = draw(st.lists(st.integers(0, k - 1), unique=True, max_size=k))
    lines = [f"VERTEX_SE2 {i} {draw(SMALL)} {draw(SMALL)} {draw(SMALL)}".split() for i in declared]
    info = ["1", "0", "0", "1", "0", "1"]
    edges = [(i, i + 1) for i in range(k - 1)] + [(k - 1, 0)]
    lines += [["EDGE_SE2", str(i), str(j), draw(SMALL), draw(SMALL), "0.1", *info] for i, j in edges]
    lines = [draw(mutated(line)) if draw(st.integers(0, 3)) == 0 else " ".join(line) for line in lines]
    lines += draw(st.lists(tagged(["VERTEX_SE2", "EDGE_SE2", "VERTEX_XY", "FIX", "#"], (0, 12)), max_size=2))
    return "\n".join(draw(st.permutations(lines)))


@FUZZ
@given(text=g2o_graphs())
def test_g2o_reader(text):
    path = written("graph.g2o", text)
    try:
        graph = read_g2o(path)
    except G2oFormatError as err:
        assert_names(err, path, line=True)
        return
    event("parsed")
    assert graph.edges and {k for e in graph.edges for k in e[:2]} <= graph.poses.keys()
    graph.values()                                     # every id is a GTSAM key
    for warning in graph.warnings:
        assert_names(warning, path, line=True)


# --- relations -------------------------------------------------------------------------------

RELATION_LINES = st.one_of(st.lists(SMALL, min_size=8, max_size=8).flatmap(mutated),
                           st.lists(NUMBER, min_size=6, max_size=10).map(" ".join))


@FUZZ
@given(text=document(RELATION_LINES), binary=st.binary(max_size=40), use_binary=st.booleans())
def test_relations_reader(text, binary, use_binary):
    path = written("log.relations", binary if use_binary else text)
    try:
        relations = read_relations(path)
    except RelationsError as err:
        assert_names(err, path, line=True)
        return
    event("parsed")
    assert np.isfinite(relations.delta).all() and len(relations.t1) == len(relations.delta)


# --- ROS map YAML ----------------------------------------------------------------------------

YAML_VALUE = st.one_of(
    NUMBER, JUNK, st.just("map.pgm"), st.just("missing.pgm"), st.just("[0, 0, 0]"), st.just("[1.5, -2]"),
    st.just("[0, 0, 0.5]"), st.just("[a, b]"), st.just("{x: 1}"), st.just("trinary"), st.just("raw"),
    st.just("scale"), st.just("''"), st.just("~"), st.just("[unclosed"), st.just("!!binary AAAA"),
)
YAML_KEYS = ["image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"]


@st.composite
def ros_maps(draw):
    """A valid map_server YAML with 0 to 2 keys changed, dropped or added, sometimes a broken
    first line; and a PGM image, valid, truncated, ASCII or junk."""
    meta = {"image": "map.pgm", "resolution": draw(st.sampled_from(["0.05", "1", "0.1"])),
            "origin": draw(st.sampled_from(["[0, 0, 0]", "[-3.2, 4, 0]", "[1.5, -2]"])),
            "negate": draw(st.sampled_from(["0", "1"])), "occupied_thresh": "0.65", "free_thresh": "0.196",
            "mode": draw(st.sampled_from(["trinary", "scale", "raw"]))}
    for _ in range(draw(st.integers(0, 2))):
        key = draw(st.sampled_from(YAML_KEYS + ["other"]))
        if draw(st.booleans()):
            meta[key] = draw(YAML_VALUE)
        else:
            meta.pop(key, None)
    text = "\n".join(f"{k}: {v}" for k, v in meta.items())
    if draw(st.integers(0, 9)) == 0:
        text = draw(st.binary(max_size=20))
    elif draw(st.integers(0, 5)) == 0:
        text = draw(st.sampled_from(["", "- a list", "just text", "key: [", "\t: x"])) + "\n" + text
    h, w = draw(st.integers(1, 4)), draw(st.integers(1, 4))
    pixels = draw(st.lists(st.integers(0, 255), min_size=h * w, max_size=h * w))
    image = draw(st.one_of(
        st.just(f"P5\n{w} {h}\n255\n".encode() + bytes(pixels)),
        st.just(f"P5\n{w} {h}\n255\n".encode() + bytes(pixels)),
        st.just(f"P5\n{w} {h + 3}\n255\n".encode() + bytes(pixels)),         # truncated
        st.just(f"P2\n{w} {h}\n255\n".encode() + " ".join(map(str, pixels)).encode()),
        st.binary(max_size=30)))
    return text, image


@FUZZ
@given(case=ros_maps())
def test_ros_map_reader(case):
    text, image = case
    path = written("map.yaml", text)
    (path.parent / "map.pgm").write_bytes(image)
    try:
        ros = read_ros_map(path)
    except (ValueError, FileNotFoundError) as err:
        assert str(err).startswith((str(path), str(path.parent / "map.pgm"), str(path.parent / "missing.pgm"))), err
        event(f"error: {' '.join(str(err)[len(str(path.parent)):].split()[:3])}"[:50])
        return
    event("parsed")
    assert set(np.unique(ros.state)) <= {RosMap.FREE, RosMap.OCCUPIED, RosMap.UNKNOWN}
    assert ros.resolution > 0 and np.isfinite(ros.origin).all()
    ros.world()


# --- TOML configuration ----------------------------------------------------------------------

SECTIONS = ["", "[robot]", "[lidar]", "[odometry]", "[stack]", "[stack.slam]", "[stack.com]", "[stack.explorer]",
            "[stack.explorer.goals]", "[stack.slam.loop_closure]", "[stack.com.training]", "[[stack]]", "[robot",
            "[stack.slam.keyframes]", "[nothing.here]"]
SETTINGS = ["radius", "max_speed", "beams", "max_range", "fov", "max_steps", "metrics_every", "method", "poses",
            "alpha", "enabled", "nu", "length_bounds", "between_sigma_floor", "animate_every", "seed", "typo_key"]
TOML_VALUE = st.one_of(
    NUMBER, st.sampled_from(["true", "false", '"gp"', '"grid"', '"slam"', '"x"', "[1, 2]", "[0.1, 0.1, 0.01]",
                             "[]", "{}", "{a = 1}", "1979-05-27", "[1, \"a\"]", "'''", "-0.0", "nan", "+inf",
                             "99999999999999999999", "1e400", "0x10"]))


def _settings(tree: dict, prefix: str = "") -> list[tuple[str, str]]:
    """(section, key) of every setting of the default configuration."""
    out = []
    for key, value in tree.items():
        if isinstance(value, dict):
            out += _settings(value, f"{prefix}.{key}" if prefix else key)
        else:
            out.append((prefix, key))
    return out


def _real_settings():
    from sim.episode import EpisodeConfig

    return _settings(EpisodeConfig().model_dump(exclude_none=True))


@st.composite
def toml_configs(draw):
    """Real settings with odd values (most of the time), or sections and keys mixed at random."""
    if draw(st.integers(0, 2)):
        chosen = draw(st.lists(st.sampled_from(_real_settings()), unique=True, min_size=1, max_size=4))
        lines = []
        for section in dict.fromkeys(sec for sec, _ in chosen):
            lines.append(f"[{section}]" if section else "")
            lines += [f"{key} = {draw(TOML_VALUE)}" for sec, key in chosen if sec == section]
        return "\n".join(lines)
    lines = []
    for section in draw(st.lists(st.sampled_from(SECTIONS), unique=True, max_size=5)):
        if section:
            lines.append(section)
        for key in draw(st.lists(st.sampled_from(SETTINGS), unique=True, max_size=3)):
            lines.append(f"{key} = {draw(TOML_VALUE)}")
    return "\n".join(lines)


@FUZZ
@given(text=toml_configs(), suffix=st.sampled_from([".toml", ".toml", ".yaml"]))
def test_config_reader(text, suffix):
    path = written("config" + suffix, text)
    try:
        read_config(path)
    except ConfigError as err:
        assert_names(err, path)
        return
    event("parsed")


@pytest.mark.parametrize("reader, error, name, size", [
    (read_g2o, G2oFormatError, "graph.g2o", 200), (read_config, ConfigError, "config.toml", 100),
])
def test_reader_on_bytes(reader, error, name, size):
    """Any bytes: the graph or the configuration, or the reader's own error naming the file."""

    @FUZZ
    @given(data=st.binary(max_size=size))
    def read(data):
        path = written(name, data)
        try:
            reader(path)
        except error as err:
            assert_names(err, path)

    read()


@pytest.mark.parametrize("reader, error, name", [
    (CarmenLog, LogFormatError, "gone.clf"), (read_g2o, G2oFormatError, "gone.g2o"),
    (read_relations, RelationsError, "gone.relations"), (read_config, ConfigError, "gone.toml"),
])
def test_a_missing_file_is_the_readers_error_or_file_not_found(tmp_path, reader, error, name):
    with pytest.raises((error, FileNotFoundError)) as err:
        reader(tmp_path / name)
    assert str(err.value).startswith(str(tmp_path / name))
