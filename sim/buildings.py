"""Seeded office and lab floor plans: held-out buildings to explore, written as ROS map_server
maps with a suite manifest (``sim.suite.suite_maps`` reads it).

A building is drawn the way its plan is laid out: the footprint (a rectangle or an L) inside a
thick outer wall (``footprint``); a recursive split of the floor (BSP) whose first cuts may leave
corridors between bands of rooms and whose other cuts are interior walls 1-4 cells thick
(``split_floor``); doors on a random spanning tree of the walls the spaces share, a few more to
close loops, corridors opened into each other where they meet (``place_doors``); desks, shelves,
tables and pillars in the rooms (``furnish``). Every draw comes from one ``numpy`` Generator
seeded by the building's seed. The result is checked (``passage_problems``): its free space is
one region in which every passage admits a disc of 0.8 m, so a 0.25 m robot can see all of it.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image
from scipy import ndimage

from sim.world import World
from slam.atomic import write_bytes_atomic, write_text_atomic

#: PNG grey levels (map_server, trinary mode): free, occupied (walls, furniture), unknown (outside).
FREE_LEVEL, OCCUPIED_LEVEL, UNKNOWN_LEVEL = 255, 0, 205
#: Meters: a part of the floor at least this long may get a corridor along it.
CORRIDOR_MIN_LENGTH = 10.0
#: m²: rooms at least this large may hold pillars.
PILLAR_ROOM_M2 = 40.0
#: Meters: a spot where the robot's centre fits may lie this far from the core of passages
#: (``passage_problems``), as it does in a room's corner; farther, it is a dead end narrower than
#: the passage.
DEAD_END = 0.3
#: Meters: two doors in one wall keep at least this much wall between them.
DOOR_SPACING = 1.0
#: The manifest's columns: those ``sim.suite.suite_maps`` reads (name, file), then the figures of
#: the suite's own manifest and the generator's.
MANIFEST_COLUMNS = ["name", "file", "seed", "width_m", "height_m", "resolution_m_per_px", "free_area_m2",
                    "rooms", "corridors", "doors", "narrowest_door_m", "furniture", "l_shaped"]


@dataclass(frozen=True)
class BuildingStyle:
    """What a generated building may be. Lengths in meters; a (low, high) pair is drawn uniformly.

    Attributes:
        resolution: cell size, m.
        width, height: the footprint's outer size.
        l_shaped: chance that a corner of the footprint is left out (an L-shaped building).
        outer_wall: outer wall thickness.
        inner_wall_px: interior wall thickness, cells (both ends included); a building draws its
            usual thickness and uses another for a wall with chance ``odd_wall``.
        corridor: corridor width.
        corridor_chance: chance of a corridor in the first cut of a part of the floor at least
            ``CORRIDOR_MIN_LENGTH`` long and wide enough for rooms on both sides; half that in
            later cuts.
        room_depth: depth of a band of rooms along a corridor.
        room_side: a room's shortest side; the longest side a room keeps unsplit is drawn in
            [0.6, 1] times the second.
        row_chance: chance that a long band of rooms is split into equal rooms (offices in a row).
        hall_side, hall_chance: a part of the floor whose sides are all at most ``hall_side`` is
            left whole (an open lab, a hall) with chance ``hall_chance``.
        door: door width.   corner_door: chance that a door is flush with its wall's end.
        extra_doors: chance that a shared wall gets a door beyond the spanning tree's.
        furniture_per_m2: mean furniture blocks per m² of room.
        passage: the narrowest opening anywhere: doors, and beside furniture.
        robot_radius: the robot the plan is checked for (``passage_problems``), m.
        margin: unknown space drawn around the outer wall.
    """

    resolution: float = 0.05
    width: tuple[float, float] = (15.0, 60.0)
    height: tuple[float, float] = (15.0, 40.0)
    l_shaped: float = 0.35
    outer_wall: tuple[float, float] = (0.25, 0.45)
    inner_wall_px: tuple[int, int] = (1, 4)
    odd_wall: float = 0.3
    corridor: tuple[float, float] = (1.2, 2.5)
    corridor_chance: float = 0.85
    room_depth: tuple[float, float] = (3.0, 7.0)
    room_side: tuple[float, float] = (2.5, 9.0)
    row_chance: float = 0.5
    hall_side: float = 14.0
    hall_chance: float = 0.1
    door: tuple[float, float] = (0.8, 1.2)
    corner_door: float = 0.3
    extra_doors: float = 0.12
    furniture_per_m2: float = 0.12
    passage: float = 0.8
    robot_radius: float = 0.25
    margin: float = 0.5

    def cells(self, meters: float) -> int:
        """``meters`` as a whole number of cells, rounded."""
        return int(round(meters / self.resolution))

    def cells_at_least(self, meters: float) -> int:
        """The fewest whole cells spanning at least ``meters``."""
        return int(math.ceil(meters / self.resolution - 1e-9))


@dataclass(frozen=True)
class Rect:
    """Cells [x0, x1) x [y0, y1) of an (h, w) grid, row 0 at the bottom (``World``'s convention);
    axis 0 is x, axis 1 is y."""

    x0: int
    y0: int
    x1: int
    y1: int

    @staticmethod
    def spanning(axis: int, lo: int, hi: int, other_lo: int, other_hi: int) -> Rect:
        """The rect [lo, hi) along ``axis`` and [other_lo, other_hi) along the other axis."""
        return Rect(lo, other_lo, hi, other_hi) if axis == 0 else Rect(other_lo, lo, other_hi, hi)

    @property
    def width(self) -> int:
        return self.x1 - self.x0

    @property
    def height(self) -> int:
        return self.y1 - self.y0

    @property
    def cells(self) -> tuple[slice, slice]:
        """Index of its cells in an (h, w) grid."""
        return np.s_[self.y0:self.y1, self.x0:self.x1]

    def lo(self, axis: int) -> int:
        return self.x0 if axis == 0 else self.y0

    def hi(self, axis: int) -> int:
        return self.x1 if axis == 0 else self.y1

    def size(self, axis: int) -> int:
        return self.hi(axis) - self.lo(axis)

    def cut(self, axis: int, at: int, wall: int) -> tuple[Rect, Rect]:
        """The two parts on either side of a wall ``wall`` cells thick across ``axis`` at ``at``:
        [lo, at) and [at + wall, hi) along ``axis``."""
        o = 1 - axis
        return (Rect.spanning(axis, self.lo(axis), at, self.lo(o), self.hi(o)),
                Rect.spanning(axis, at + wall, self.hi(axis), self.lo(o), self.hi(o)))

    def grown(self, cells: int) -> Rect:
        return Rect(self.x0 - cells, self.y0 - cells, self.x1 + cells, self.y1 + cells)

    def clipped(self, other: Rect) -> Rect | None:
        """The part of this rect inside ``other``; None if they do not overlap."""
        r = Rect(max(self.x0, other.x0), max(self.y0, other.y0), min(self.x1, other.x1), min(self.y1, other.y1))
        return r if r.width > 0 and r.height > 0 else None

    def gap(self, other: Rect) -> float:
        """Cells: the Euclidean gap between the two rects (0 if they touch or overlap)."""
        dx = max(other.x0 - self.x1, self.x0 - other.x1, 0)
        dy = max(other.y0 - self.y1, self.y0 - other.y1, 0)
        return math.hypot(dx, dy)

    def mirrored(self, axis: int, lo: int, hi: int) -> Rect:
        """This rect reflected across the middle of [lo, hi) along ``axis``."""
        o = 1 - axis
        return Rect.spanning(axis, lo + hi - self.hi(axis), lo + hi - self.lo(axis), self.lo(o), self.hi(o))


@dataclass(frozen=True)
class Space:
    """A room or a corridor: a free rect bounded by walls."""

    rect: Rect
    kind: str  # "room" or "corridor"


@dataclass(frozen=True)
class SharedWall:
    """The wall between spaces ``a`` and ``b``: crossed along ``axis`` from ``a``'s side
    (cells [g0, g1) across) and shared over [lo, hi) along the other axis."""

    a: int
    b: int
    axis: int
    g0: int
    g1: int
    lo: int
    hi: int

    def opening(self, d0: int, d1: int) -> Rect:
        """The wall's cells over [d0, d1) along it: an opening there joins ``a`` and ``b``."""
        return Rect.spanning(self.axis, self.g0, self.g1, d0, d1)


@dataclass(frozen=True)
class Footprint:
    """The building's outline on a canvas of ``shape`` (h, w) cells: ``outline`` inside the margin,
    less ``void`` (the missing corner of an L); ``floors``, the free rects inside the outer wall
    (one, or the two arms of an L with an interior wall between them)."""

    shape: tuple[int, int]
    outline: Rect
    void: Rect | None
    floors: tuple[Rect, ...]


@dataclass(frozen=True)
class Building:
    """A generated floor plan.

    Attributes:
        name: ``building_<seed>`` (four digits at least).   seed: the seed it was drawn from.
        free: (h, w) bool, row 0 at the bottom: free cells.
        inside: (h, w) bool: the footprint (free space, walls, furniture); outside it is unknown.
        resolution: cell size, m.
        spaces: its rooms and corridors.   doors: the door openings (cells of walls removed),
            the openings where corridors meet not included.   furniture: the blocks in the rooms.
        l_shaped: whether a corner of the footprint is left out.
    """

    name: str
    seed: int
    free: np.ndarray
    inside: np.ndarray
    resolution: float
    spaces: tuple[Space, ...]
    doors: tuple[Rect, ...]
    furniture: tuple[Rect, ...]
    l_shaped: bool

    def world(self) -> World:
        """The true world: everything but the free cells is a wall, named as its map file."""
        return World(~self.free, (self.resolution, self.resolution), name=f"{self.name}.yaml")

    @property
    def free_area_m2(self) -> float:
        return float(self.free.sum() * self.resolution**2)

    def levels(self) -> np.ndarray:
        """(h, w) uint8 grey levels, row 0 at the bottom: free white, walls black, outside unknown."""
        return np.where(self.free, FREE_LEVEL, np.where(self.inside, OCCUPIED_LEVEL, UNKNOWN_LEVEL)).astype(np.uint8)


def building_name(seed: int) -> str:
    return f"building_{seed:04d}"


def building(seed: int, style: BuildingStyle = BuildingStyle()) -> Building:
    """The floor plan of seed ``seed`` (a non-negative integer) in ``style``: the same seed gives
    the same bitmap.

    Raises:
        ValueError: the plan fails its check (``passage_problems``): a bug of the generator.
    """
    rng = np.random.default_rng(seed)
    walls = _WallDraw(style, rng)
    plan = footprint(style, rng, walls)
    spaces = [space for floor in plan.floors for space in split_floor(floor, style, rng, walls)]
    shared = shared_walls(spaces, style.inner_wall_px[1], style.cells_at_least(style.passage))
    doors, junctions = place_doors(spaces, shared, style, rng)
    furniture = [block for space in spaces if space.kind == "room" for block in furnish(space.rect, doors, style, rng)]
    free, inside = draw(plan, [s.rect for s in spaces] + doors + junctions, furniture)
    name = building_name(seed)
    problems = passage_problems(free, style.resolution, style.passage, style.robot_radius)
    if problems:
        raise ValueError(f"{name}: the generated plan is not explorable in full: {'; '.join(problems)}")
    return Building(name, seed, free, inside, style.resolution, tuple(spaces), tuple(doors), tuple(furniture),
                    plan.void is not None)


def draw(plan: Footprint, openings: list[Rect], blocks: list[Rect]) -> tuple[np.ndarray, np.ndarray]:
    """(free, inside), (h, w) bool grids of ``plan.shape``: free where ``openings`` (the spaces,
    doors, junctions) are and ``blocks`` (furniture) are not; inside the outline but its void."""
    inside = np.zeros(plan.shape, dtype=bool)
    inside[plan.outline.cells] = True
    if plan.void is not None:
        inside[plan.void.cells] = False
    free = np.zeros(plan.shape, dtype=bool)
    for rect in openings:
        free[rect.cells] = True
    for block in blocks:
        free[block.cells] = False
    return free, inside


class _WallDraw:
    """Interior wall thicknesses of one building: mostly its usual one, sometimes another."""

    def __init__(self, style: BuildingStyle, rng: np.random.Generator):
        self.low, self.high = style.inner_wall_px
        self.odd = style.odd_wall
        self.rng = rng
        self.usual = self.any()

    def any(self) -> int:
        return int(self.rng.integers(self.low, self.high + 1))

    def __call__(self) -> int:
        return self.any() if self.rng.random() < self.odd else self.usual


def footprint(style: BuildingStyle, rng: np.random.Generator, walls: Callable[[], int]) -> Footprint:
    """The outline: width x height drawn from ``style``, an outer wall of ``style.outer_wall``,
    ``style.margin`` of unknown around; with chance ``style.l_shaped`` a corner of 30-50 % of
    each side is left out and the L inside is cut into its two arms by an interior wall
    (``walls()`` cells thick), the long arm along x or y at random."""
    width, height = style.cells(rng.uniform(*style.width)), style.cells(rng.uniform(*style.height))
    margin, thick = style.cells(style.margin), style.cells(rng.uniform(*style.outer_wall))
    shape = (height + 2 * margin, width + 2 * margin)
    outline = Rect(margin, margin, margin + width, margin + height)
    X0, Y0, X1, Y1 = outline.x0, outline.y0, outline.x1, outline.y1
    if rng.random() >= style.l_shaped:
        return Footprint(shape, outline, None, (Rect(X0 + thick, Y0 + thick, X1 - thick, Y1 - thick),))
    vw, vh = round(rng.uniform(0.3, 0.5) * width), round(rng.uniform(0.3, 0.5) * height)
    wall = walls()
    # drawn with the missing corner at the top right, then mirrored to the corner drawn
    void = Rect(X1 - vw, Y1 - vh, X1, Y1)
    if rng.random() < 0.5:      # a full-height arm on the left, the rest of the bottom on the right
        arms = (Rect(X0 + thick, Y0 + thick, X1 - vw - thick, Y1 - thick),
                Rect(X1 - vw - thick + wall, Y0 + thick, X1 - thick, Y1 - vh - thick))
    else:                       # a full-width arm at the bottom, the rest of the left side above
        arms = (Rect(X0 + thick, Y0 + thick, X1 - thick, Y1 - vh - thick),
                Rect(X0 + thick, Y1 - vh - thick + wall, X1 - vw - thick, Y1 - thick))
    for axis, (lo, hi) in enumerate([(X0, X1), (Y0, Y1)]):
        if rng.random() < 0.5:
            void = void.mirrored(axis, lo, hi)
            arms = tuple(a.mirrored(axis, lo, hi) for a in arms)
    return Footprint(shape, outline, void, arms)


def split_floor(rect: Rect, style: BuildingStyle, rng: np.random.Generator, walls: Callable[[], int],
                depth: int = 0) -> list[Space]:
    """The spaces of a recursive split (BSP) of the free ``rect``.

    A part long and wide enough may get a corridor along its long side, between a band of rooms
    ``style.room_depth`` deep and the rest (chance ``style.corridor_chance``, half that below the
    first cut); a long narrow band may become a row of equal rooms; a part whose longest side is
    at most a drawn limit is a room, so is a hall with chance ``style.hall_chance``; any other
    part is cut across its long side (85 %) or its short side at a uniform place leaving
    ``style.room_side[0]`` on each side. Walls are ``walls()`` cells thick.
    """
    long = 0 if rect.width >= rect.height else 1
    short = 1 - long
    min_side = style.cells(style.room_side[0])
    min_depth = style.cells(style.room_depth[0])
    width = style.cells(rng.uniform(*style.corridor))
    chance = style.corridor_chance if depth == 0 else style.corridor_chance / 2
    if (rect.size(long) >= style.cells(CORRIDOR_MIN_LENGTH)
            and rect.size(short) >= 2 * min_depth + width + 2 * style.inner_wall_px[1]
            and rng.random() < chance):
        return _corridor_split(rect, long, width, style, rng, walls, depth)

    if rect.size(short) <= style.cells(style.room_depth[1]) and rect.size(long) >= 2.5 * rect.size(short) \
            and rng.random() < style.row_chance:
        return [Space(r, "room") for r in _row_of_rooms(rect, long, style, rng, walls)]
    limit = style.cells(rng.uniform(0.6, 1.0) * style.room_side[1])
    hall = max(rect.width, rect.height) <= style.cells(style.hall_side) and rng.random() < style.hall_chance
    if rect.size(long) <= limit or hall:
        return [Space(rect, "room")]
    wall = walls()
    axis = long if rng.random() < 0.85 else short
    if rect.size(axis) < 2 * min_side + wall:
        axis = 1 - axis
        if rect.size(axis) < 2 * min_side + wall:
            return [Space(rect, "room")]
    at = rect.lo(axis) + min_side + int(rng.integers(0, rect.size(axis) - 2 * min_side - wall + 1))
    low, high = rect.cut(axis, at, wall)
    return split_floor(low, style, rng, walls, depth + 1) + split_floor(high, style, rng, walls, depth + 1)


def _corridor_split(rect: Rect, long: int, width: int, style: BuildingStyle, rng: np.random.Generator,
                    walls: Callable[[], int], depth: int) -> list[Space]:
    """A corridor ``width`` cells wide along axis ``long`` of ``rect``, a band of rooms on one side
    (on the low or high side at random), the rest of the part on the other, each split again."""
    short = 1 - long
    wall_band, wall_rest = walls(), walls()
    room = style.cells(rng.uniform(*style.room_depth))
    band = min(room, rect.size(short) - wall_band - width - wall_rest - style.cells(style.room_depth[0]))
    if rng.random() < 0.5:
        rooms, remainder = rect.cut(short, rect.lo(short) + band, wall_band)
        corridor, rest = remainder.cut(short, remainder.lo(short) + width, wall_rest)
    else:
        remainder, rooms = rect.cut(short, rect.hi(short) - band - wall_band, wall_band)
        rest, corridor = remainder.cut(short, remainder.hi(short) - width - wall_rest, wall_rest)
    return (split_floor(rooms, style, rng, walls, depth + 1) + [Space(corridor, "corridor")]
            + split_floor(rest, style, rng, walls, depth + 1))


def _row_of_rooms(rect: Rect, long: int, style: BuildingStyle, rng: np.random.Generator,
                  walls: Callable[[], int]) -> list[Rect]:
    """``rect`` cut across ``long`` into equal rooms about 3-5 m wide (at least
    ``style.room_side[0]``), all walls of one thickness."""
    wall = walls()
    min_side = style.cells(style.room_side[0])
    wanted = style.cells(rng.uniform(max(3.0, style.room_side[0]), 5.0))
    n = max(1, min(round((rect.size(long) + wall) / (wanted + wall)), (rect.size(long) + wall) // (min_side + wall)))
    rooms, rest = [], rect
    for k in range(n - 1, 0, -1):
        side = (rest.size(long) - k * wall) // (k + 1)
        room, rest = rest.cut(long, rest.lo(long) + side, wall)
        rooms.append(room)
    return rooms + [rest]


def shared_walls(spaces: list[Space], thickest: int, narrowest: int) -> list[SharedWall]:
    """The walls (at most ``thickest`` cells thick) that two spaces share over at least
    ``narrowest`` cells, each once. A space is wider than any wall, so the cells between two
    spaces that close are wall only."""
    found = []
    for i, a in enumerate(spaces):
        for j in range(i + 1, len(spaces)):
            b = spaces[j]
            for axis in (0, 1):
                o = 1 - axis
                lo, hi = max(a.rect.lo(o), b.rect.lo(o)), min(a.rect.hi(o), b.rect.hi(o))
                if hi - lo < narrowest:
                    continue
                if 0 < b.rect.lo(axis) - a.rect.hi(axis) <= thickest:
                    found.append(SharedWall(i, j, axis, a.rect.hi(axis), b.rect.lo(axis), lo, hi))
                elif 0 < a.rect.lo(axis) - b.rect.hi(axis) <= thickest:
                    found.append(SharedWall(j, i, axis, b.rect.hi(axis), a.rect.lo(axis), lo, hi))
    return found


def place_doors(spaces: list[Space], shared: list[SharedWall], style: BuildingStyle,
                rng: np.random.Generator) -> tuple[list[Rect], list[Rect]]:
    """(doors, junctions): corridors that meet are opened into each other over all the wall they
    share (junctions); doors ``style.door`` wide join the spaces along a spanning tree of the
    shared walls (Kruskal on random keys, a wall between two rooms ranked after a room's wall on a
    corridor), then each shared wall gets one more with chance ``style.extra_doors``.

    Raises:
        ValueError: the spaces do not form one connected plan (a bug of the split).
    """
    parent = list(range(len(spaces)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    corridor = [s.kind == "corridor" for s in spaces]
    junctions, doors = [], []
    on_wall: dict[int, list[tuple[int, int]]] = {}
    for w in shared:
        if corridor[w.a] and corridor[w.b]:
            junctions.append(w.opening(w.lo, w.hi))
            parent[root(w.a)] = root(w.b)
    keys = rng.random(len(shared)) + np.array([0.0 if corridor[w.a] or corridor[w.b] else 0.5 for w in shared])
    rooms_walls = [k for k in np.argsort(keys, kind="stable") if not (corridor[shared[k].a] and corridor[shared[k].b])]
    for k in rooms_walls:
        w = shared[k]
        if root(w.a) != root(w.b):
            parent[root(w.a)] = root(w.b)
            span = _door_span(w, [], style, rng)
            on_wall[k] = [span]
            doors.append(w.opening(*span))
    if len({root(i) for i in range(len(spaces))}) > 1:
        raise ValueError("the split left spaces that share no wall wide enough for a door")
    for k in sorted(rooms_walls):
        if rng.random() < style.extra_doors:
            span = _door_span(shared[k], on_wall.get(k, []), style, rng)
            if span is not None:
                on_wall.setdefault(k, []).append(span)
                doors.append(shared[k].opening(*span))
    return doors, junctions


def _door_span(wall: SharedWall, taken: list[tuple[int, int]], style: BuildingStyle,
               rng: np.random.Generator) -> tuple[int, int] | None:
    """[d0, d1) along ``wall`` for a door ``style.door`` wide (at most the shared span), flush
    with one end of the span with chance ``style.corner_door``, else anywhere along it, kept
    ``DOOR_SPACING`` from the doors ``taken`` on it; None when five draws find no place."""
    width = min(style.cells(rng.uniform(*style.door)), wall.hi - wall.lo)
    spacing = style.cells(DOOR_SPACING)
    for _ in range(5):
        if rng.random() < style.corner_door:
            d0 = wall.lo if rng.random() < 0.5 else wall.hi - width
        else:
            d0 = int(rng.integers(wall.lo, wall.hi - width + 1))
        if all(d0 + width + spacing <= t0 or d0 >= t1 + spacing for t0, t1 in taken):
            return d0, d0 + width
    return None


def furnish(room: Rect, doors: list[Rect], style: BuildingStyle, rng: np.random.Generator) -> list[Rect]:
    """Furniture blocks in ``room``: desks and shelves against a wall (70 %; in a corner 40 % of
    those), tables standing free, and pillars in rooms of ``PILLAR_ROOM_M2`` or more; Poisson
    ``style.furniture_per_m2`` per m², four tries each.

    A block keeps clear of the passage: on each side it touches the room's wall or leaves at
    least ``style.passage`` plus a cell to it, it stays that far from every other block, and it
    leaves that much around each door (``doors``); so no opening narrower than the passage is
    made, and no pocket closed.
    """
    clear = style.cells(style.passage) + 1
    keep_out = [z for z in (d.grown(clear).clipped(room) for d in doors) if z is not None]
    area = room.width * room.height * style.resolution**2
    blocks: list[Rect] = []
    for _ in range(rng.poisson(style.furniture_per_m2 * area)):
        for _attempt in range(4):
            block = _draw_block(room, area, clear, style, rng)
            if block is not None and _keeps_clear(block, room, blocks, keep_out, clear):
                blocks.append(block)
                break
    return blocks


def _draw_block(room: Rect, area: float, clear: int, style: BuildingStyle, rng: np.random.Generator) -> Rect | None:
    """One furniture block in ``room``, ``clear`` cells from its walls where it does not touch
    them; None when the one drawn does not fit."""
    if rng.random() < 0.7:      # against a wall: a desk, a shelf, a cabinet
        along = int(rng.integers(2))
        across = 1 - along
        depth, length = style.cells(rng.uniform(0.4, 0.8)), style.cells(rng.uniform(0.6, 2.5))
        if length > room.size(along) or depth + clear > room.size(across):
            return None
        if rng.random() < 0.4:
            start = room.lo(along) if rng.random() < 0.5 else room.hi(along) - length
        else:
            room_left = room.size(along) - length - 2 * clear
            if room_left < 0:
                return None
            start = room.lo(along) + clear + int(rng.integers(0, room_left + 1))
        base = room.lo(across) if rng.random() < 0.5 else room.hi(across) - depth
        return Rect.spanning(along, start, start + length, base, base + depth)
    if area >= PILLAR_ROOM_M2 and rng.random() < 0.4:
        sx = sy = style.cells(rng.uniform(0.3, 0.6))
    else:                       # a table
        sx, sy = style.cells(rng.uniform(0.8, 1.8)), style.cells(rng.uniform(0.8, 2.4))
        if rng.random() < 0.5:
            sx, sy = sy, sx
    room_x, room_y = room.width - sx - 2 * clear, room.height - sy - 2 * clear
    if room_x < 0 or room_y < 0:
        return None
    x0 = room.x0 + clear + int(rng.integers(0, room_x + 1))
    y0 = room.y0 + clear + int(rng.integers(0, room_y + 1))
    return Rect(x0, y0, x0 + sx, y0 + sy)


def _keeps_clear(block: Rect, room: Rect, blocks: list[Rect], keep_out: list[Rect], clear: int) -> bool:
    sides = (block.x0 - room.x0, room.x1 - block.x1, block.y0 - room.y0, room.y1 - block.y1)
    return (all(s == 0 or s >= clear for s in sides)
            and all(block.gap(b) >= clear for b in blocks)
            and all(block.clipped(z) is None for z in keep_out))


def passage_problems(free: np.ndarray, resolution: float, passage: float = 0.8,
                     radius: float = 0.25) -> list[str]:
    """What keeps a disc robot of ``radius`` m from exploring the (h, w) bool ``free`` (row 0 at
    the bottom, off the grid occupied) in full through openings of at least ``passage`` m; empty
    when nothing does.

    Measured on the grid refined twice (each cell cut into 2 x 2), where the distance between a
    cell's centre and the nearest wall cell's centre resolves an axis-aligned gap exactly: the
    middle of a gap of n cells lies n·resolution/2 from both sides. Checked: (a) the free cells
    are one 4-connected region (no closed pocket); (b) the core, the cells at least passage/2
    from every wall, is one 4-connected region (no opening narrower than the passage between two
    parts); (c) every cell at least ``radius`` from the walls lies within ``DEAD_END`` m of the
    core (no dead end narrower than the passage); (d) every run of free cells along a row or a
    column is at least the passage long (``shortest_run``: an opening too narrow is found even
    where another way leads round it, which (b) misses). Places are given in meters.
    """
    problems = []
    half = resolution / 2

    def where(mask: np.ndarray, step: float) -> str:
        iy, ix = np.argwhere(mask).mean(axis=0)
        return f"({(ix + 0.5) * step:.2f}, {(iy + 0.5) * step:.2f}) m"

    labels, n = ndimage.label(free)
    if n != 1:
        sizes = np.bincount(labels.ravel())[1:]
        problems.append(f"the free space is {n} regions" + (
            f", the smallest {sizes.min() * resolution**2:.2f} m² at "
            f"{where(labels == 1 + int(np.argmin(sizes)), resolution)}" if n else ""))
    fine = np.repeat(np.repeat(free, 2, axis=0), 2, axis=1)
    to_wall = ndimage.distance_transform_edt(np.pad(fine, 1))[1:-1, 1:-1]      # fine cells
    core = to_wall >= passage / 2 / half - 1e-9
    labels, n = ndimage.label(core)
    if n != 1:
        sizes = np.bincount(labels.ravel())[1:]
        problems.append(f"openings narrower than {passage} m cut the space into {n} parts" + (
            f", the smallest at {where(labels == 1 + int(np.argmin(sizes)), half)}" if n else ""))
    if n:
        fits = to_wall >= radius / half - 1e-9
        dead = fits & (ndimage.distance_transform_edt(~core) > DEAD_END / half)
        if dead.any():
            problems.append(f"{dead.sum() * half**2:.2f} m² where the robot fits lie more than {DEAD_END} m "
                            f"from the {passage} m passages, around {where(dead, half)}")
    for axis, name in ((1, "row"), (0, "column")):
        short = shortest_run(free, axis)
        if short is not None and short[0] * resolution < passage - 1e-9:
            cells, iy, ix = short
            problems.append(f"a {name} crosses an opening of {cells * resolution:.2f} m at "
                            f"({(ix + 0.5) * resolution:.2f}, {(iy + 0.5) * resolution:.2f}) m")
    return problems


def shortest_run(free: np.ndarray, axis: int) -> tuple[int, int, int] | None:
    """(cells, row, column of its first cell) of the shortest run of free cells along ``axis``
    (1: along rows, 0: along columns) of the (h, w) bool ``free``, walls or the grid's edge at
    both ends: the narrowest opening of the plan along that axis, measured exactly, even one that
    has another way round it; None without free cells."""
    grid = free if axis == 1 else free.T
    edges = np.diff(np.pad(grid, ((0, 0), (1, 1))).astype(np.int8), axis=1)
    rows, starts = np.nonzero(edges == 1)
    _, ends = np.nonzero(edges == -1)      # row-major order pairs each run's start with its end
    if len(starts) == 0:
        return None
    k = int(np.argmin(ends - starts))
    first = (rows[k], starts[k]) if axis == 1 else (starts[k], rows[k])
    return int(ends[k] - starts[k]), int(first[0]), int(first[1])


# --- writing buildings as a suite ---------------------------------------------------------------

def write_map(folder: str | Path, b: Building) -> Path:
    """``<name>.png`` and ``<name>.yaml`` of ``b`` in ``folder`` as map_server reads them
    (``sim.world_io.read_ros_map``: trinary, origin at 0, not negated); the YAML's path."""
    folder = Path(folder)
    png = io.BytesIO()
    Image.fromarray(np.flipud(b.levels())).save(png, format="PNG")
    write_bytes_atomic(folder / f"{b.name}.png", png.getvalue())
    yaml_path = folder / f"{b.name}.yaml"
    write_text_atomic(yaml_path, f"image: {b.name}.png\nresolution: {b.resolution}\norigin: [0.0, 0.0, 0.0]\n"
                                 "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n")
    return yaml_path


def manifest_row(b: Building) -> dict:
    """``b``'s line of a suite manifest (``MANIFEST_COLUMNS``)."""
    h, w = b.free.shape
    doors = [max(d.width, d.height) * b.resolution for d in b.doors]     # walls are thinner than doors
    return {"name": b.name, "file": f"{b.name}.yaml", "seed": b.seed, "width_m": round(w * b.resolution, 3),
            "height_m": round(h * b.resolution, 3), "resolution_m_per_px": b.resolution,
            "free_area_m2": round(b.free_area_m2, 2), "rooms": sum(s.kind == "room" for s in b.spaces),
            "corridors": sum(s.kind == "corridor" for s in b.spaces), "doors": len(b.doors),
            "narrowest_door_m": round(min(doors), 3) if doors else "", "furniture": len(b.furniture),
            "l_shaped": "yes" if b.l_shaped else "no"}


def write_buildings(folder: str | Path, seeds, style: BuildingStyle = BuildingStyle()) -> Path:
    """The buildings of ``seeds`` in ``folder`` (``write_map``) and their ``manifest.csv``, in the
    order of ``seeds``; the manifest's path. The same seeds and style write the same files."""
    folder = Path(folder)
    rows = []
    for seed in seeds:
        b = building(int(seed), style)
        write_map(folder, b)
        rows.append(manifest_row(b))
    text = io.StringIO()
    sheet = csv.DictWriter(text, MANIFEST_COLUMNS, lineterminator="\n")
    sheet.writeheader()
    sheet.writerows(rows)
    write_text_atomic(folder / "manifest.csv", text.getvalue())
    return folder / "manifest.csv"
