"""Costmap for planning: where the robot's centre may go, derived from occupancy probabilities."""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy import ndimage
from pydantic import BaseModel, ConfigDict, Field, model_validator


class CostmapConfig(BaseModel):
    """Thresholds that split a probability map into free, occupied and unknown cells."""

    model_config = ConfigDict(extra="forbid")

    free_below: float = Field(0.35, gt=0, lt=1, description="Λ below this is free")
    occupied_above: float = Field(0.65, gt=0, lt=1, description="Λ above this is occupied")
    margin: float = Field(0.02, ge=0, description="meters of clearance added to the robot "
                          "radius, beyond the hits (2 sigma of the range noise): a 0.25 m robot "
                          "fits through doors wider than 0.54 m; the navigator's guard keeps it "
                          "off what the current scan shows")
    unknown_clearance: float = Field(
        0.1, ge=0, description="meters the robot's centre keeps from unknown cells; occupied "
        "cells are kept at radius + margin. The COM leaves a band near walls unknown, so "
        "inflating unknown space by the full radius would close doors the robot fits through")

    near_wall_cost: float = Field(
        0.0, ge=0, description="extra cost per meter of path at radius + margin from an occupied "
        "cell, falling linearly to 0 at preferred_clearance, so paths keep off walls where there "
        "is room")
    off_centre_cost: float = Field(
        3.0, ge=1, description="cost factor of a cell passable only off its centre (such cells "
        "are passable only where they join two regions of cells clear at their centres: a door "
        "whose clear span holds no cell centre): paths take them where they must, not to hug a "
        "wall, which leaves the guard no room for the follower's cut corners")
    squeeze: float = Field(
        0.05, ge=0, description="meters a passage joining two regions of clear cells may read "
        "narrower than radius + margin and still be planned through, as an off-centre cell: "
        "the hits stand up to 5-9 cm (90th percentile) inside free space from pose error, so "
        "a door the robot fits through with centimetres to spare reads narrower than it is; "
        "the navigator threads it from the live scan, and gives it up when it cannot")
    preferred_clearance: float = Field(
        0.6, gt=0, description="meters from an occupied cell beyond which a path costs its length")

    @model_validator(mode="after")
    def _ordered(self):
        if not self.free_below <= self.occupied_above:
            raise ValueError(f"free_below {self.free_below} must not exceed occupied_above "
                             f"{self.occupied_above}")
        return self


def classify(prob: np.ndarray, config: CostmapConfig):
    """(free, occupied) (h, w) bool masks; cells in neither are unknown."""
    occupied = prob > config.occupied_above
    free = (prob < config.free_below) & ~occupied
    return free, occupied


def passable(prob: np.ndarray, resolution: float, radius: float, config: CostmapConfig,
             hits: np.ndarray | None = None, origin=(0.0, 0.0), trail: np.ndarray | None = None):
    """Where the robot's centre may go, through which point of each cell, and what a meter of
    path costs there.

    Args:
        prob: (h, w) occupancy probability; cell (0, 0)'s centre at ``origin`` (2,), meters.
        hits: (k, 2) the measured laser endpoints (m) the map was built from. Clearance is then
            measured to the points themselves, at the point of each cell farthest from them: a
            door whose clear span (its width less the robot's diameter and margins) is
            narrower than a cell may have no cell centre in it, yet a point of a cell. Without
            hits, clearance is measured from the cell centres to the occupied cells' edges, half
            a cell nearer than their centres (what made a cell occupied may lie anywhere in
            it), which can close a 0.75 m door to a 0.25 m robot.
        trail: (k, 2) where the robot's centre has been, in order, meters: the known-free
            cells it crossed are passable at the crossing point, costed as off-centre cells. It
            passed there, though the map's noise may narrow a door it passed with a centimetre
            to spare below the clearance asked.

    Returns:
        ok: (h, w) bool, known-free cells with a point more than ``radius + margin`` meters from
            any obstacle, more than ``unknown_clearance`` from any unknown cell (off the map
            counts as unknown), and the cells of the trail.
        cost: (h, w) ``wall_cost`` of each cell, times ``off_centre_cost`` where only a point
            off the centre is clear, for ``paths.distance_field``.
        offset: (h, w, 2) meters from each cell's centre to that point, where a path through
            the cell should pass (0 where the centre is clear).
    """
    free, occupied = classify(prob, config)
    ok, cost, offset = _clear(free, occupied, resolution, radius, config, hits, origin)
    if trail is not None:
        cells, through = driven(trail, resolution, origin, prob.shape)
        add = free[cells[:, 1], cells[:, 0]] & ~ok[cells[:, 1], cells[:, 0]]
        iy, ix = cells[add, 1], cells[add, 0]
        ok[iy, ix], offset[iy, ix] = True, through[add]
        cost[iy, ix] *= config.off_centre_cost
    return ok, cost, offset


def _clear(free: np.ndarray, occupied: np.ndarray, resolution: float, radius: float,
           config: CostmapConfig, hits: np.ndarray | None,
           origin) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``passable``'s (ok, cost, offset) from the (h, w) ``free`` and ``occupied`` cells and the
    hits alone, without the trail."""
    offset = np.zeros(free.shape + (2,))
    clear = radius + config.margin
    near_unknown = _disc_offsets(resolution, config.unknown_clearance)
    to_occupied = np.zeros(free.shape)
    if hits is None:
        to_occupied = _distance_to(occupied, resolution) - resolution / 2
    elif not len(hits):
        to_occupied[free] = np.inf
    if hits is None or not len(hits):
        room = np.zeros_like(free)
        _rooms(free, occupied, near_unknown, room)
        return room & (to_occupied > clear), wall_cost(to_occupied, radius, config), offset
    bound = max(config.preferred_clearance, clear + resolution)
    origin = np.asarray(origin, float)
    hits = np.asarray(hits, float)
    # past ``clear`` the clearance only sets the wall cost, flat when near_wall_cost is 0
    squared = _SCATTERED.squared(hits.reshape(-1, 2), origin, resolution, free.shape,
                                 bound if config.near_wall_cost > 0 else clear)
    # cells whose centre is not clear, but a point of which may be (clearance is 1-Lipschitz),
    # where they could join two regions of centre-clear cells: searched for that point
    ok, index = np.empty_like(free), np.empty(free.shape, np.int64)
    low = clear - config.squeeze - resolution / math.sqrt(2)
    maybe = _split(free, occupied, near_unknown, squared, clear, low, to_occupied, ok, index)
    rooms, _ = ndimage.label(ok, structure=_EIGHT)
    linking = _links(rooms, index, maybe, np.ones(len(maybe), np.bool_))
    iy, ix = maybe[linking] // free.shape[1], maybe[linking] % free.shape[1]
    shift, clearance = clearest_points(hits, origin, resolution, free.shape, np.column_stack([ix, iy]),
                                       bound)
    to_occupied[iy, ix] = clearance
    clear_off_centre = np.zeros(len(maybe), np.bool_)
    clear_off_centre[linking] = clearance > clear - config.squeeze
    through = _links(rooms, index, maybe, clear_off_centre)[linking]
    off_centre = np.zeros_like(ok)
    off_centre[iy[through], ix[through]] = True
    offset[iy[through], ix[through]] = shift[through]
    cost = wall_cost(to_occupied, radius, config)
    cost[off_centre] *= config.off_centre_cost
    return ok | off_centre, cost, offset


def _disc_offsets(resolution: float, distance: float) -> np.ndarray:
    """(k, 2) (dx, dy) cell offsets whose centres lie within ``distance`` meters of a cell's."""
    r = int(math.floor(distance / resolution))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    disc = np.sqrt((yy * resolution) ** 2 + (xx * resolution) ** 2) <= distance
    return np.column_stack([xx[disc], yy[disc]]).astype(np.int64)


@numba.njit(cache=True, inline="always")
def _in_room(free, occupied, near_unknown, iy, ix):
    """Is the free cell (iy, ix) farther than the ``near_unknown`` offsets from every unknown
    cell (neither free nor occupied; off the map counts as one)?"""
    h, w = free.shape
    for k in range(near_unknown.shape[0]):
        y, x = iy + near_unknown[k, 1], ix + near_unknown[k, 0]
        if y < 0 or x < 0 or y >= h or x >= w or not (free[y, x] or occupied[y, x]):
            return False
    return True


@numba.njit(cache=True)
def _rooms(free, occupied, near_unknown, room):
    """Mark in ``room`` (h, w) the free cells farther than the ``near_unknown`` offsets (a
    disc, ``_disc_offsets``) from every unknown cell."""
    h, w = free.shape
    for iy in range(h):
        for ix in range(w):
            room[iy, ix] = free[iy, ix] and _in_room(free, occupied, near_unknown, iy, ix)


@numba.njit(cache=True)
def _split(free, occupied, near_unknown, squared, clear, low, to_occupied, ok, index):
    """One pass over the grid: ``to_occupied`` (h, w) the clearance of each free cell (the
    square root of ``squared``, the hits' squared distance field; 0 elsewhere), ``ok`` the
    cells of a room (``_rooms``) clearer than ``clear`` at their centre, and the flat indices,
    in row-major order, of the room's other cells clearer than ``low`` (returned; ``index``
    (h, w) holds each one's place in them, -1 at every other cell)."""
    h, w = free.shape
    maybe = np.empty(h * w, np.int64)
    n = 0
    for iy in range(h):
        for ix in range(w):
            index[iy, ix] = -1
            ok[iy, ix] = False
            if not free[iy, ix]:
                to_occupied[iy, ix] = 0.0
                continue
            d = math.sqrt(squared[iy, ix])
            to_occupied[iy, ix] = d
            if not _in_room(free, occupied, near_unknown, iy, ix):
                continue
            if d > clear:
                ok[iy, ix] = True
            elif d > low:
                index[iy, ix] = n
                maybe[n] = iy * w + ix
                n += 1
    return maybe[:n].copy()


_EIGHT = np.ones((3, 3), dtype=bool)


def distance_to_points(points: np.ndarray, origin, resolution: float, shape: tuple[int, int],
                       bound: float) -> np.ndarray:
    """(h, w) meters from each cell centre of the (h, w) ``shape`` grid (cell (0, 0)'s centre
    at ``origin``) to the nearest of ``points`` (k, 2), inf where none is nearer than ``bound``:
    each point writes its distance into the cells within ``bound`` of it, so the cost is the
    points times the cells of that disc, whatever the map's size; points that extend those of
    a recent call on the same grid (``_Scattered``) cost only what they add."""
    return np.sqrt(_SCATTERED.squared(np.asarray(points, dtype=float).reshape(-1, 2), origin,
                                      resolution, shape, bound))


class _Scattered:
    """The last few squared-distance fields of ``distance_to_points``, one per grid and bound,
    with the points scattered into them. A map's hits only grow between its rebuilds (each
    update appends its own; a rebuild after a loop closure moves them all), so a field whose
    points begin the new ones is brought up to date by scattering the rest: the minimum over
    the points is the minimum of the two parts. The replanner reads the hits every cycle, and
    scattering all of them cost office_d's runs a fifth of their time."""

    def __init__(self, size: int = 4):
        self.size = size
        self.fields: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    def squared(self, points: np.ndarray, origin, resolution: float, shape: tuple[int, int],
                bound: float) -> np.ndarray:
        key = (float(origin[0]), float(origin[1]), float(resolution), tuple(shape), float(bound))
        done, d2 = self.fields.pop(key, (np.zeros((0, 2)), None))
        if d2 is None or not extends(points, done):
            done, d2 = done[:0], np.full(shape, np.inf)
        new = np.ascontiguousarray(points[len(done):])
        if len(new):
            _scatter_distances(new, float(origin[0]), float(origin[1]), float(resolution), float(bound), d2)
        _keep(self.fields, key, (kept(points), d2), self.size)
        return d2


def _keep(cache: dict, key: tuple, value: tuple, size: int) -> None:
    """Put ``value`` under ``key``, the newest, and drop the oldest past ``size`` entries."""
    cache[key] = value
    while len(cache) > size:
        cache.pop(next(iter(cache)))


def kept(points: np.ndarray) -> np.ndarray:
    """``points`` as a cache keeps them to check the next call's against (``extends``): a
    read-only array as it is, taken never to change (``LogOddsGrid.hits`` hands out read-only
    views of a buffer it only appends to), else a copy."""
    return points if not points.flags.writeable else points.copy()


def extends(points: np.ndarray, done: np.ndarray) -> bool:
    """Do ``points`` (k, 2) begin with ``done`` (j, 2), kept by ``kept``? At once where both
    are read-only views from the same address (a longer view of the buffer ``done`` came
    from: comparing 770 000 hits at every replan cost office_g's run as much as what they
    add), else by comparing them."""
    if len(done) > len(points):
        return False
    head = points[:len(done)]
    if not (head.flags.writeable or done.flags.writeable) and head.strides == done.strides and (
            head.__array_interface__["data"][0] == done.__array_interface__["data"][0]):
        return True
    return np.array_equal(head, done)


_SCATTERED = _Scattered()


@numba.njit(cache=True)
def _scatter_distances(points, x0, y0, resolution, bound, d2):
    h, w = d2.shape
    reach = int(math.ceil(bound / resolution))
    limit = bound * bound
    for k in range(points.shape[0]):
        px, py = points[k, 0], points[k, 1]
        cx, cy = int(round((px - x0) / resolution)), int(round((py - y0) / resolution))
        for iy in range(max(0, cy - reach), min(h, cy + reach + 1)):
            dy = y0 + resolution * iy - py
            for ix in range(max(0, cx - reach), min(w, cx + reach + 1)):
                dx = x0 + resolution * ix - px
                dd = dx * dx + dy * dy
                if dd < limit and dd < d2[iy, ix]:
                    d2[iy, ix] = dd


def _links(rooms: np.ndarray, index: np.ndarray, cells: np.ndarray, among: np.ndarray) -> np.ndarray:
    """(n,) bool: which of ``cells`` (n,), flat indices of cells of the (h, w) grid (``index``
    (h, w) holds the place in them of each cell that is one, -1 elsewhere), lie in an
    8-connected group of the cells flagged ``among`` (n,) that touches two or more of the
    ``rooms`` (h, w), labels of the 8-connected groups of some cells (0: none): passages (a
    door whose clear span holds no cell centre), not the rim of one room along its walls.
    The groups are found among the cells alone, not over the grid."""
    return _two_rooms(rooms, index, np.ascontiguousarray(cells, np.int64),
                      np.ascontiguousarray(among, np.bool_))


@numba.njit(cache=True)
def _root(parent, k):
    while parent[k] != k:
        parent[k] = parent[parent[k]]
        k = parent[k]
    return k


@numba.njit(cache=True)
def _two_rooms(rooms, index, cells, among):
    """``_links``: the groups joined by union-find over each cell's neighbours, then each
    group's first room, and any other room ends it."""
    h, w = rooms.shape
    n = cells.shape[0]
    parent = np.arange(n)
    for k in range(n):
        if not among[k]:
            continue
        iy, ix = cells[k] // w, cells[k] % w
        for y in range(max(iy - 1, 0), min(iy + 2, h)):
            for x in range(max(ix - 1, 0), min(ix + 2, w)):
                j = index[y, x]
                if j >= 0 and among[j]:
                    a, b = _root(parent, k), _root(parent, j)
                    if a != b:
                        parent[max(a, b)] = min(a, b)
    first = np.zeros(n, np.int64)
    two = np.zeros(n, np.bool_)
    for k in range(n):
        if not among[k]:
            continue
        group = _root(parent, k)
        if two[group]:
            continue
        iy, ix = cells[k] // w, cells[k] % w
        for y in range(max(iy - 1, 0), min(iy + 2, h)):
            for x in range(max(ix - 1, 0), min(ix + 2, w)):
                room = rooms[y, x]
                if room > 0:
                    if first[group] == 0:
                        first[group] = room
                    elif first[group] != room:
                        two[group] = True
    out = np.zeros(n, np.bool_)
    for k in range(n):
        out[k] = among[k] and two[_root(parent, k)]
    return out


def clearest_points(points: np.ndarray, origin, resolution: float, shape: tuple[int, int],
                    cells: np.ndarray, bound: float, levels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Per cell (ix, iy) of ``cells`` (n, 2) on the (h, w) ``shape`` grid (cell (0, 0)'s centre
    at ``origin``, side ``resolution``): the offset (n, 2) from its centre to its point
    farthest from ``points`` (k, 2), and that distance (n,), inf where it is ``bound`` or more,
    by a pattern search: the best of a 3 x 3 lattice round the best point so far, its step a
    third of a cell and then a third of the last (0.4 mm on 0.1 m cells after 3 levels).
    Within a passage, the distance to the walls rises towards its middle line, so the search
    climbs to it.

    The points are sorted by the grid's cell holding them (``_Sorted``); a cell's search reads
    only those within its centre's clearance plus a cell's diagonal of its centre, which hold
    the nearest point to every point of the cell. So its answer stands while no point is added
    within that reach: a cell searched by a recent call on the same grid, whose points begin
    the new ones, is searched again only if one of the new points falls there (``_Found``)."""
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    # buckets that can hold a point within bound + a diagonal of a cell's centre, either side
    pad = int(math.ceil((bound + math.sqrt(2.0) * resolution) / resolution)) + 1
    found = _FOUND.for_points(points, origin, resolution, shape, bound, levels)
    todo = cells[found.reach[cells[:, 1], cells[:, 0]] < 0]
    if len(todo):
        keys, sorted_points = _SORTED.by_bucket(points, origin, resolution, shape, pad)
        shift, clearance, reach = np.zeros((len(todo), 2)), np.full(len(todo), np.inf), np.zeros(len(todo))
        _pattern_search(sorted_points, keys, shape[1] + 2 * pad, pad, float(origin[0]), float(origin[1]),
                        float(resolution), todo, float(bound), levels, shift, clearance, reach)
        found.shift[todo[:, 1], todo[:, 0]] = shift
        found.clearance[todo[:, 1], todo[:, 0]] = clearance
        found.reach[todo[:, 1], todo[:, 0]] = reach
    return found.shift[cells[:, 1], cells[:, 0]], found.clearance[cells[:, 1], cells[:, 0]]


class _Found:
    """The answers of ``clearest_points`` on one grid, per cell: the shift, the clearance and
    the reach its search read points within (< 0: not searched, or a point came within it
    since), for the points ``done``."""

    def __init__(self, shape: tuple[int, int]):
        self.done = np.zeros((0, 2))
        self.shift = np.zeros(tuple(shape) + (2,))
        self.clearance = np.full(shape, np.inf)
        self.reach = np.full(shape, -1.0)


class _Founds:
    """The last few grids' ``_Found``, one per grid, bound and levels of search. Points that
    begin with a grid's ``done`` points add to them: the answers of the cells within the reach
    of one of the new points are forgotten, the others stand (exact: a search reads only the
    points within its reach). Other points forget every answer (after a map's rebuild)."""

    def __init__(self, size: int = 4):
        self.size = size
        self.found: dict[tuple, _Found] = {}

    def for_points(self, points: np.ndarray, origin, resolution: float, shape: tuple[int, int],
                   bound: float, levels: int) -> _Found:
        key = (float(origin[0]), float(origin[1]), float(resolution), tuple(shape), float(bound), levels)
        found = self.found.pop(key, None)
        if found is None or not extends(points, found.done):
            found = _Found(shape)
        new = np.ascontiguousarray(points[len(found.done):])
        if len(new) and len(found.done):
            _forget(new, float(origin[0]), float(origin[1]), float(resolution),
                    bound + math.sqrt(2.0) * resolution, found.reach)
        found.done = kept(points)
        _keep(self.found, key, found, self.size)
        return found


_FOUND = _Founds()


@numba.njit(cache=True)
def _forget(points, x0, y0, resolution, most, reach):
    """Mark unsearched (-1) each cell of ``reach`` (h, w) that one of ``points`` lies within
    the reach of (which is at most ``most`` meters), or a nanometre past it."""
    h, w = reach.shape
    cells = int(math.ceil(most / resolution))
    for k in range(points.shape[0]):
        px, py = points[k, 0], points[k, 1]
        cx, cy = int(round((px - x0) / resolution)), int(round((py - y0) / resolution))
        for iy in range(max(0, cy - cells), min(h, cy + cells + 1)):
            dy = y0 + resolution * iy - py
            for ix in range(max(0, cx - cells), min(w, cx + cells + 1)):
                dx = x0 + resolution * ix - px
                if reach[iy, ix] >= 0 and math.sqrt(dx * dx + dy * dy) <= reach[iy, ix] + 1e-9:
                    reach[iy, ix] = -1.0


class _Sorted:
    """The points of recent ``clearest_points`` calls sorted by the bucket (a cell of the grid
    padded by ``pad`` cells each side) holding them, one per grid and padding. Like
    ``_Scattered``'s fields, a sorting whose points begin the new ones takes the rest in by
    merging their sorted keys with its own: sorting all of office_g's 770 000 hits took a
    quarter of each of its late replans."""

    def __init__(self, size: int = 4):
        self.size = size
        self.sorted_: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def by_bucket(self, points: np.ndarray, origin, resolution: float, shape: tuple[int, int],
                  pad: int) -> tuple[np.ndarray, np.ndarray]:
        """(m,) the buckets' flat indices (row-major on the padded grid), ascending, and (m, 2)
        the points in them, in that order: the points off the padded grid are left out."""
        key = (float(origin[0]), float(origin[1]), float(resolution), tuple(shape), int(pad))
        done, keys, inside = self.sorted_.pop(key, (np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros((0, 2))))
        if not extends(points, done):
            done, keys, inside = done[:0], keys[:0], inside[:0]
        new = points[len(done):]
        h, w = shape[0] + 2 * pad, shape[1] + 2 * pad
        at = np.round((new - np.asarray(origin, float)) / resolution).astype(np.int64) + pad
        on = (at[:, 0] >= 0) & (at[:, 0] < w) & (at[:, 1] >= 0) & (at[:, 1] < h)
        keys = np.concatenate([keys, at[on, 1] * w + at[on, 0]])
        inside = np.concatenate([inside, new[on]])
        order = np.argsort(keys, kind="stable")     # two sorted runs, merged
        keys, inside = keys[order], np.ascontiguousarray(inside[order])
        _keep(self.sorted_, key, (kept(points), keys, inside), self.size)
        return keys, inside


_SORTED = _Sorted()


@numba.njit(cache=True)
def _pattern_search(points, keys, w, pad, x0, y0, resolution, cells, bound, levels, shift,
                    clearance, reach):
    diagonal = math.sqrt(2.0) * resolution
    half = resolution / 2
    for i in range(cells.shape[0]):
        cx, cy = x0 + resolution * cells[i, 0], y0 + resolution * cells[i, 1]
        bx, by = cells[i, 0] + pad, cells[i, 1] + pad
        nearest = math.inf      # the centre's clearance: rings of buckets out from its own
        for r in range(pad + 1):
            if nearest <= (r - 0.5) * resolution:
                break
            for yy in range(by - r, by + r + 1):
                stride = 1 if yy == by - r or yy == by + r else 2 * r   # a ring's rows, its sides
                for xx in range(bx - r, bx + r + 1, stride):
                    first = np.searchsorted(keys, yy * w + xx)
                    for k in range(first, np.searchsorted(keys, yy * w + xx + 1)):
                        nearest = min(nearest, math.sqrt((points[k, 0] - cx) ** 2
                                                         + (points[k, 1] - cy) ** 2))
        # the nearest point to any point of the cell lies within this of its centre
        radius = min(nearest, bound) + diagonal
        reach[i] = radius
        around = min(pad, int(math.ceil(radius / resolution + 0.5)))
        rows = np.empty((2 * around + 1, 2), np.int64)    # each row's run of points
        count = 0
        for j in range(2 * around + 1):
            yy = by - around + j
            rows[j, 0] = np.searchsorted(keys, yy * w + bx - around)
            rows[j, 1] = np.searchsorted(keys, yy * w + bx + around + 1)
            count += rows[j, 1] - rows[j, 0]
        near = np.empty((count, 2))
        n = 0
        for j in range(2 * around + 1):
            for k in range(rows[j, 0], rows[j, 1]):
                if math.sqrt((points[k, 0] - cx) ** 2 + (points[k, 1] - cy) ** 2) <= radius:
                    near[n] = points[k]
                    n += 1
        bestx, besty = cx, cy
        best = nearest if nearest < bound else math.inf
        step = resolution / 3
        for _ in range(levels):
            lx, ly, ld = bestx, besty, -1.0
            for j in range(-1, 2):
                for m in range(-1, 2):
                    px = min(max(bestx + step * m, cx - half), cx + half)
                    py = min(max(besty + step * j, cy - half), cy + half)
                    d = math.inf
                    for q in range(n):
                        d = min(d, math.sqrt((near[q, 0] - px) ** 2 + (near[q, 1] - py) ** 2))
                    d = d if d < bound else math.inf
                    if d > ld:
                        lx, ly, ld = px, py, d
            if ld > best:
                bestx, besty, best = lx, ly, ld
            step /= 3
        shift[i, 0], shift[i, 1], clearance[i] = bestx - cx, besty - cy, best


def driven(trail: np.ndarray, resolution: float, origin, shape, max_step: float = 1.0):
    """The cells the robot's centre crossed along ``trail`` (k, 2), its past positions in
    order (meters; a step longer than ``max_step`` m, a jump of the estimate, is left out),
    each with the crossing point nearest to its centre. They join side by side: where the
    trail passes from a cell to a diagonal one (at, or within a sample of, their common
    corner), the side cell it passes nearer is crossed too, since paths take no diagonal step
    past a blocked side cell (889_05: a robot that had driven in on a 45° line, and stood
    inside the costmap's clearance, had a trail of corner-joined cells and no way out).

    Returns:
        cells: (n, 2) (ix, iy) on the (h, w) ``shape`` grid whose cell (0, 0)'s centre is at
            ``origin``, in row-major order; offset: (n, 2) meters from each cell's centre to
            that point.
    """
    trail = np.ascontiguousarray(np.asarray(trail, float).reshape(-1, 2))
    x0, y0 = (float(c) for c in np.asarray(origin, float))
    h, w = (int(n) for n in shape)
    resolution = float(resolution)
    # compiled, sample by sample, each value by the same floating-point operations as the
    # vectorised form it replaced (the same offsets to the last bit; 6 -> 0.33 ms on a late
    # 2047-pose trail); each cell's nearest point found with the cells put in row-major order
    # by two counting sorts, not on arrays over the span of their flat indices (a whole map's)
    points = _samples(trail, resolution, float(max_step))
    cells, offset = _crossings(points, x0, y0, resolution, h, w)
    first = _nearest_per_cell(cells, offset, h, w)
    return cells[first], offset[first]


@numba.njit(cache=True)
def _samples(trail, resolution, max_step):
    """(m, 2) points every ``resolution`` / 4 or less along each step of ``trail`` (k, 2) no
    longer than ``max_step``, both its ends included, in the trail's order."""
    quarter = resolution / 4
    counts = np.zeros(max(trail.shape[0] - 1, 0), np.int64)
    for s in range(counts.shape[0]):
        dx, dy = trail[s + 1, 0] - trail[s, 0], trail[s + 1, 1] - trail[s, 1]
        length = math.sqrt(dx * dx + dy * dy)
        if length <= max_step:
            counts[s] = int(math.ceil(length / quarter)) + 1
    points = np.empty((counts.sum(), 2))
    n = 0
    for s in range(counts.shape[0]):
        ax, ay = trail[s, 0], trail[s, 1]
        dx, dy = trail[s + 1, 0] - ax, trail[s + 1, 1] - ay
        last = max(counts[s] - 1, 1)
        for i in range(counts[s]):
            t = i / last
            points[n, 0], points[n, 1] = ax + t * dx, ay + t * dy
            n += 1
    return points


@numba.njit(cache=True)
def _crossings(points, x0, y0, resolution, h, w):
    """(n, 2) the cells of ``points`` (m, 2), then the side cells passed at their diagonal
    steps, those on the (h, w) grid alone, and (n, 2) meters from each cell's centre to its
    point: the sample itself, or for a side cell the middle of the step clipped to the cell."""
    m = points.shape[0]
    cells = np.empty((2 * m, 2), np.int64)      # each sample's, then at most one side's a step
    crossing = np.empty((2 * m, 2))             # the point of each
    half = resolution / 2
    sides = m
    for k in range(m):
        cx = int(round((points[k, 0] - x0) / resolution))
        cy = int(round((points[k, 1] - y0) / resolution))
        cells[k, 0], cells[k, 1] = cx, cy
        crossing[k, 0], crossing[k, 1] = points[k, 0], points[k, 1]
        if k > 0 and abs(cx - cells[k - 1, 0]) == 1 and abs(cy - cells[k - 1, 1]) == 1:
            mx, my = (points[k - 1, 0] + points[k, 0]) / 2, (points[k - 1, 1] + points[k, 1]) / 2
            # the side cells (cx, last cy) and (last cx, cy): the one nearer the step's middle
            ax, ay = x0 + resolution * cx, y0 + resolution * cells[k - 1, 1]
            bx, by = x0 + resolution * cells[k - 1, 0], y0 + resolution * cy
            if math.sqrt((mx - ax) * (mx - ax) + (my - ay) * (my - ay)) <= math.sqrt(
                    (mx - bx) * (mx - bx) + (my - by) * (my - by)):
                sx, sy = cx, cells[k - 1, 1]
            else:
                sx, sy = cells[k - 1, 0], cy
            centre_x, centre_y = x0 + resolution * sx, y0 + resolution * sy
            cells[sides, 0], cells[sides, 1] = sx, sy
            crossing[sides, 0] = centre_x + min(max(mx - centre_x, -half), half)
            crossing[sides, 1] = centre_y + min(max(my - centre_y, -half), half)
            sides += 1
    offset = np.empty((sides, 2))
    n = 0
    for k in range(sides):
        cx, cy = cells[k, 0], cells[k, 1]
        if 0 <= cx < w and 0 <= cy < h:
            cells[n, 0], cells[n, 1] = cx, cy
            offset[n, 0] = crossing[k, 0] - (x0 + resolution * cx)
            offset[n, 1] = crossing[k, 1] - (y0 + resolution * cy)
            n += 1
    return cells[:n], offset[:n]


@numba.njit(cache=True)
def _nearest_per_cell(cells, offset, h, w):
    """(c,) the place in ``cells`` (n, 2) on the (h, w) grid of each cell's point nearest its
    centre (``offset`` (n, 2) from it), the first of those as near, one a cell in row-major
    order. Sorted stably by column, then by row, each cell's places are a run in their order."""
    order = _stably_sorted(_stably_sorted(np.arange(cells.shape[0]), cells[:, 0], w), cells[:, 1], h)
    first = np.empty(cells.shape[0], np.int64)
    count = 0
    nearest = math.inf
    for j in range(order.shape[0]):
        k = order[j]
        gap = math.sqrt(offset[k, 0] * offset[k, 0] + offset[k, 1] * offset[k, 1])
        if j == 0 or cells[k, 0] != cells[order[j - 1], 0] or cells[k, 1] != cells[order[j - 1], 1]:
            first[count] = k
            count += 1
            nearest = gap
        elif gap < nearest:
            first[count - 1] = k
            nearest = gap
    return first[:count]


@numba.njit(cache=True, inline="always")
def _stably_sorted(order, key, size):
    """``order`` (n,) sorted by the ``key`` (in [0, size)) of each, ties kept in their order:
    a counting sort, in time n + size."""
    starts = np.zeros(size + 1, np.int64)
    for k in order:
        starts[key[k] + 1] += 1
    starts = np.cumsum(starts)
    sorted_ = np.empty_like(order)
    for k in order:
        sorted_[starts[key[k]]] = k
        starts[key[k]] += 1
    return sorted_


def wall_cost(to_occupied: np.ndarray, radius: float, config: CostmapConfig) -> np.ndarray:
    """(h, w) cost per meter: 1 + ``near_wall_cost`` at ``radius + margin`` meters from an
    occupied cell, falling linearly to 1 at ``preferred_clearance``."""
    if config.near_wall_cost == 0:
        return np.ones(np.shape(to_occupied))
    closest = radius + config.margin
    span = max(config.preferred_clearance - closest, 1e-9)
    return 1.0 + config.near_wall_cost * np.clip((config.preferred_clearance - to_occupied) / span, 0, 1)


def _distance_to(mask: np.ndarray, resolution: float) -> np.ndarray:
    """(h, w) meters from each cell centre to the nearest cell of ``mask`` (off the map counts)."""
    return ndimage.distance_transform_edt(np.pad(~mask, 1, constant_values=False),
                                          sampling=resolution)[1:-1, 1:-1]
