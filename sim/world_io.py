"""Load worlds from bitmaps (PNG/PGM with a size or a resolution), ROS map_server YAML, or a
built-in name, and choose where a robot starts in them."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import gtsam
import numpy as np
import yaml
from PIL import Image, UnidentifiedImageError

from sim.world import World
from sim.worlds import BUILTIN_WORLDS, corner_start


#: A start from which the robot reaches less free space than this (m²), or less than this share
#: of the free space of the world it fits in, is in an enclosed pocket (the Stage cave's hollow
#: obstacles hold pockets of about 4 m², its open space about 300 m²).
ENCLOSED_AREA_M2 = 5.0
ENCLOSED_SHARE = 0.05


class StartError(ValueError):
    """A start pose where the robot's disc is not in free space."""


@dataclass(frozen=True)
class StartArea:
    """The free space a robot reaches from its start, against all the free space it fits in.

    Attributes:
        start: (x, y) of the start, m.   reachable_m2: reachable free area, m².
        free_m2: area of the world where the robot's disc fits, m².
    """

    start: tuple[float, float]
    reachable_m2: float
    free_m2: float

    @property
    def share(self) -> float:
        """Reachable share of the free space the robot fits in, in [0, 1]."""
        return self.reachable_m2 / self.free_m2 if self.free_m2 > 0 else 0.0

    @property
    def enclosed(self) -> bool:
        """Whether the start is in a pocket: a tiny area, or a tiny share of the world's."""
        return self.reachable_m2 < ENCLOSED_AREA_M2 or self.share < ENCLOSED_SHARE

    def warning(self) -> str | None:
        """What a user should be told about an enclosed start; None for an ordinary one."""
        if not self.enclosed:
            return None
        x, y = self.start
        return (f"the start ({x:.2f}, {y:.2f}) is in an enclosed pocket: it reaches {self.reachable_m2:.1f} m² "
                f"of free space, {100 * self.share:.1f} % of the {self.free_m2:.1f} m² the robot fits in; "
                f"coverage is measured against the pocket only")

    def metrics(self) -> dict:
        """The entries of metrics.json that describe the start's area."""
        return {"reachable_area_m2": self.reachable_m2, "free_area_m2": self.free_m2,
                "reachable_share": self.share, "start_enclosed": self.enclosed}


def start_area(world: World, start_xy: Sequence[float], radius: float) -> StartArea:
    """The reachable free space from ``start_xy`` (m) for a robot of ``radius`` m.

    Raises:
        StartError: the robot's disc at the start is not in free space.
    """
    x, y = float(start_xy[0]), float(start_xy[1])
    try:
        reachable = world.reachable((x, y), radius)
    except ValueError:
        raise StartError(f"start ({x:.2f}, {y:.2f}) is not free for a robot of radius {radius:g} m") from None
    cell = world.resolution[0] * world.resolution[1]
    return StartArea((x, y), float(reachable.sum() * cell), float((world.clearance() >= radius).sum() * cell))


def load_world(spec: str | Path, size: tuple[float, float] | None = None,
               resolution: float | None = None) -> World:
    """A world from a built-in name (``cave``, ``office``), a ``.yaml`` map or a bitmap."""
    spec = str(spec)
    if spec in BUILTIN_WORLDS:
        if size is not None or resolution is not None:
            raise ValueError(f"built-in world '{spec}' has its own scale: do not give a size or resolution")
        return BUILTIN_WORLDS[spec]().world
    path = Path(spec)
    if path.suffix.lower() in (".yaml", ".yml"):
        if size is not None or resolution is not None:
            raise ValueError(f"{path}: a ROS map YAML carries its own resolution; do not give a size")
        return load_ros_map(path)
    if not path.exists():
        names = ", ".join(sorted(BUILTIN_WORLDS))
        raise FileNotFoundError(f"{path}: no such map file (built-in worlds: {names})")
    return load_bitmap(path, size=size, resolution=resolution)


def has_own_scale(spec: str | Path) -> bool:
    """Whether the world ``spec`` carries its scale (a built-in name, a ROS map YAML) rather than
    needing a size or resolution (a bitmap)."""
    return str(spec) in BUILTIN_WORLDS or Path(spec).suffix.lower() in (".yaml", ".yml")


def start_pose(spec: str | Path, world: World, radius: float,
               start: Sequence[float] | None = None) -> gtsam.Pose2:
    """Where a robot of ``radius`` m starts in ``world``, loaded from ``spec``: at ``start`` (X, Y,
    THETA in m, m, rad) when given, else at the built-in world's own start, else at
    ``corner_start``. Raises StartError when the robot's disc there is not free, ValueError when
    the world has no free place at all."""
    if start is not None:
        pose = gtsam.Pose2(*start)
    elif str(spec) in BUILTIN_WORLDS:
        pose = BUILTIN_WORLDS[str(spec)]().start
    else:
        pose = corner_start(world, radius)
    if world.collides((pose.x(), pose.y()), radius):
        raise StartError(f"start ({pose.x():.2f}, {pose.y():.2f}) is not free for a robot of radius "
                         f"{radius} m")
    return pose


def load_bitmap(path: str | Path, size: tuple[float, float] | None = None,
                resolution: float | None = None, threshold: float = 0.5) -> World:
    """A world from a floor-plan bitmap: dark pixels (grey level below ``threshold``) are walls.

    Exactly one of ``size`` = (width, height) in meters, stretching the image as Stage does
    (pixels may become non-square), or ``resolution`` in m/pixel must be given. The image's
    lower-left corner is at (0, 0), x to the right, y up.
    """
    path = Path(path)
    if (size is None) == (resolution is None):
        raise ValueError(f"{path}: a bitmap has no scale of its own: give its size in meters "
                         f"(--size W H) or its resolution (--resolution M_PER_PX), not both")
    grey = _read_grey(path)
    h, w = grey.shape
    if size is not None:
        width, height = (float(s) for s in size)
        if not (width > 0 and height > 0):
            raise ValueError(f"{path}: world size must be positive, got {width} x {height} m")
        res = (width / w, height / h)
    else:
        if not float(resolution) > 0:
            raise ValueError(f"{path}: resolution must be positive, got {resolution} m/px")
        res = (float(resolution), float(resolution))
    return World(np.flipud(grey < threshold), res, (0.0, 0.0), name=path.name)


@dataclass(frozen=True)
class RosMap:
    """A ROS map_server map as map_server reads it.

    Attributes:
        state: (h, w) int8, row 0 at the bottom: ``FREE`` (0), ``OCCUPIED`` (1) or ``UNKNOWN`` (-1).
        resolution: cell size, m.
        origin: (x, y) of the lower-left corner of cell (0, 0), m.
        name: the YAML file's name.
    """

    state: np.ndarray
    resolution: float
    origin: tuple[float, float]
    name: str

    FREE = 0
    OCCUPIED = 1
    UNKNOWN = -1

    def world(self) -> World:
        """The true world of this map: only free cells are free; occupied and unknown cells are
        walls (the world is closed where the map does not know it)."""
        return World(self.state != self.FREE, (self.resolution, self.resolution), self.origin, name=self.name)


def load_ros_map(path: str | Path) -> World:
    """A world from a ROS map_server YAML: its free cells are free, its occupied and unknown
    cells are walls (``read_ros_map``)."""
    return read_ros_map(path).world()


def read_ros_map(path: str | Path) -> RosMap:
    """A ROS map_server YAML (image, resolution, origin, negate, thresholds, mode) and its image,
    read as map_server reads them.

    With ``p = (255 - level) / 255`` of a pixel's grey level (``p = level / 255`` with ``negate``),
    modes ``trinary`` and ``scale`` give occupied where ``p > occupied_thresh``, free where
    ``p < free_thresh``, unknown in between (map_saver's 205 is p = 0.196078, just above its
    free_thresh 0.196). Mode ``raw`` takes the level (after ``negate``) as the occupancy in
    percent: above 100 is unknown, the thresholds apply to level / 100 as above.

    Raises:
        FileNotFoundError: the YAML or its image is missing (the file named).
        ValueError: a key is missing or unreadable, or the image is not one (the file and key named).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such map YAML")
    try:
        meta = yaml.safe_load(path.read_bytes().decode())
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not a text file: {err}") from None
    except yaml.YAMLError as err:
        raise ValueError(f"{path}: not valid YAML: {' '.join(str(err).split())}") from None
    except OSError as err:
        raise FileNotFoundError(f"{path}: cannot read: {err}") from None
    if not isinstance(meta, dict):
        raise ValueError(f"{path}: expected a mapping of map_server keys, got {type(meta).__name__}")

    def key(name, convert, default=None):
        if name not in meta:
            if default is None:
                raise ValueError(f"{path}: missing key '{name}'")
            return default
        try:
            return convert(meta[name])
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"{path}: key '{name}' has an unreadable value {meta[name]!r}") from None

    def coordinates(value) -> list[float]:
        if not isinstance(value, (list, tuple)):
            raise TypeError("not a list")
        return [float(v) for v in value]

    def text(value) -> str:
        if not isinstance(value, str) or not value:
            raise TypeError("not a name")
        return value

    image = path.parent / key("image", text)
    resolution = key("resolution", float)
    origin = key("origin", coordinates)
    negate = key("negate", int, 0)
    occupied_thresh = key("occupied_thresh", float, 0.65)
    free_thresh = key("free_thresh", float, 0.196)
    mode = key("mode", str, "trinary")
    if not (resolution > 0 and math.isfinite(resolution)):
        raise ValueError(f"{path}: key 'resolution' must be positive, got {resolution}")
    if len(origin) not in (2, 3) or not all(math.isfinite(v) for v in origin):
        raise ValueError(f"{path}: key 'origin' must be [x, y, yaw] (finite), got {meta['origin']!r}")
    if len(origin) == 3 and origin[2] != 0.0:
        raise ValueError(f"{path}: key 'origin' has yaw {origin[2]}; rotated maps are not supported")
    if not 0 <= free_thresh <= occupied_thresh <= 1:
        raise ValueError(f"{path}: need 0 <= free_thresh <= occupied_thresh <= 1, "
                         f"got {free_thresh}, {occupied_thresh}")
    if mode not in ("trinary", "scale", "raw"):
        raise ValueError(f"{path}: key 'mode' must be trinary, scale or raw, got {mode!r}")
    level = _read_levels(image)
    if negate:
        level = 255.0 - level
    if mode == "raw":
        p = np.where(level <= 100, level / 100.0, np.nan)
    else:
        p = (255.0 - level) / 255.0
    state = np.full(level.shape, RosMap.UNKNOWN, np.int8)
    state[p > occupied_thresh] = RosMap.OCCUPIED
    state[p < free_thresh] = RosMap.FREE
    return RosMap(np.flipud(state), resolution, (origin[0], origin[1]), path.name)


def _read_grey(path: Path) -> np.ndarray:
    """(h, w) grey levels in [0, 1], row 0 at the top of the image."""
    return _read_levels(path) / 255.0


def _read_levels(path: Path) -> np.ndarray:
    """(h, w) grey levels in [0, 255], row 0 at the top of the image; transparent pixels are white."""
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such image file")
    try:
        with Image.open(path) as image:
            if image.mode in ("RGBA", "LA", "P"):
                image = image.convert("RGBA")
                background = Image.new("RGBA", image.size, "white")
                image = Image.alpha_composite(background, image)
            grey = np.asarray(image.convert("L"), dtype=float)
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, Image.DecompressionBombError) as err:
        # Pillow reports some malformed files as SyntaxError or ValueError
        raise ValueError(f"{path}: not a readable image: {err}") from None
    if grey.size == 0:
        raise ValueError(f"{path}: image is empty")
    return grey
