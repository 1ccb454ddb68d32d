"""Costmap for planning: where the robot's centre may go, derived from occupancy probabilities."""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree
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
    room = free & (_distance_to(~free & ~occupied, resolution) > config.unknown_clearance)
    to_occupied = np.zeros(free.shape)
    if hits is None:
        to_occupied = _distance_to(occupied, resolution) - resolution / 2
    elif not len(hits):
        to_occupied[free] = np.inf
    if hits is None or not len(hits):
        return room & (to_occupied > clear), wall_cost(to_occupied, radius, config), offset
    tree = cKDTree(hits)
    bound = max(config.preferred_clearance, clear + resolution)
    origin = np.asarray(origin, float)
    iy, ix = np.nonzero(free)
    to_occupied[iy, ix] = tree.query(origin + resolution * np.column_stack([ix, iy]),
                                     distance_upper_bound=bound)[0]
    ok = room & (to_occupied > clear)
    # cells whose centre is not clear, but a point of which may be (clearance is 1-Lipschitz),
    # where they could join two regions of centre-clear cells: searched for that point
    maybe = room & ~ok & (to_occupied > clear - config.squeeze - resolution / math.sqrt(2))
    iy, ix = np.nonzero(maybe & _links(ok, maybe))
    shift, clearance = _clearest_points(tree, origin + resolution * np.column_stack([ix, iy]),
                                        resolution, bound)
    to_occupied[iy, ix], offset[iy, ix] = clearance, shift
    off_centre = np.zeros_like(ok)
    off_centre[iy, ix] = clearance > clear - config.squeeze
    off_centre &= _links(ok, off_centre)
    offset[~off_centre] = 0.0
    cost = wall_cost(to_occupied, radius, config)
    cost[off_centre] *= config.off_centre_cost
    return ok | off_centre, cost, offset


_EIGHT = np.ones((3, 3), dtype=bool)


def _links(rooms: np.ndarray, between: np.ndarray) -> np.ndarray:
    """(h, w) bool: the 8-connected groups of ``between`` cells that touch two or more
    8-connected groups of ``rooms`` cells: passages (a door whose clear span holds no cell
    centre), not the rim of one room along its walls."""
    room, _ = ndimage.label(rooms, structure=_EIGHT)
    link, n = ndimage.label(between, structure=_EIGHT)
    if n == 0:
        return np.zeros_like(between)
    h, w = room.shape
    padded = np.pad(room, 1)
    pairs = [np.column_stack([link[between], padded[1 + dy:h + 1 + dy, 1 + dx:w + 1 + dx][between]])
             for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
    pairs = np.unique(np.vstack(pairs), axis=0)
    pairs = pairs[pairs[:, 1] > 0]
    touched = np.bincount(pairs[:, 0], minlength=n + 1)
    return (touched >= 2)[link]


#: 3 x 3 lattice of a pattern search, in units of its step.
_LATTICE = np.array([(i, j) for j in (-1, 0, 1) for i in (-1, 0, 1)], dtype=float)


def _clearest_points(tree: cKDTree, centres: np.ndarray, resolution: float, bound: float,
                     levels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Per cell of side ``resolution`` centred at ``centres`` (n, 2): the offset (n, 2) from
    its centre to its point farthest from the points in ``tree``, and that distance (n,), by a
    pattern search: the best of a 3 x 3 lattice round the best point so far, its step a third
    of a cell and then a third of the last (0.4 mm on 0.1 m cells after 3 levels). Within a
    passage, the distance to the walls rises towards its middle line, so the search climbs to
    it."""
    best = centres.copy()
    clearance = tree.query(centres, distance_upper_bound=bound)[0] if len(centres) else np.zeros(0)
    half, step, rows = resolution / 2, resolution / 3, np.arange(len(centres))
    for _ in range(levels):
        points = np.clip(best[:, None] + step * _LATTICE[None], centres[:, None] - half,
                         centres[:, None] + half)
        d = tree.query(points.reshape(-1, 2), distance_upper_bound=bound)[0].reshape(-1, 9)
        k = np.argmax(d, axis=1)
        better = d[rows, k] > clearance
        best[better], clearance[better] = points[rows, k][better], d[rows, k][better]
        step /= 3
    return best - centres, clearance


def driven(trail: np.ndarray, resolution: float, origin, shape, max_step: float = 1.0):
    """The cells the robot's centre crossed along ``trail`` (k, 2), its past positions in
    order (meters; a step longer than ``max_step`` m, a jump of the estimate, is left out),
    each with the crossing point nearest to its centre.

    Returns:
        cells: (n, 2) (ix, iy) on the (h, w) ``shape`` grid whose cell (0, 0)'s centre is at
            ``origin``; offset: (n, 2) meters from each cell's centre to that point.
    """
    trail = np.asarray(trail, float).reshape(-1, 2)
    a, b = trail[:-1], trail[1:]
    length = np.linalg.norm(b - a, axis=1)
    a, b, length = a[length <= max_step], b[length <= max_step], length[length <= max_step]
    count = np.ceil(length / (resolution / 4)).astype(int) + 1
    step = np.repeat(np.arange(len(a)), count)
    t = (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)) / np.repeat(
        np.maximum(count - 1, 1), count)
    points = a[step] + t[:, None] * (b - a)[step]
    origin = np.asarray(origin, float)
    cells = np.round((points - origin) / resolution).astype(int)
    offset = points - (origin + resolution * cells)
    h, w = shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < w) & (cells[:, 1] >= 0) & (cells[:, 1] < h)
    cells, offset = cells[inside], offset[inside]
    order = np.lexsort([np.linalg.norm(offset, axis=1), cells[:, 1] * w + cells[:, 0]])
    cells, offset = cells[order], offset[order]
    first = np.r_[True, np.any(np.diff(cells, axis=0) != 0, axis=1)][:len(cells)]
    return cells[first], offset[first]


def wall_cost(to_occupied: np.ndarray, radius: float, config: CostmapConfig) -> np.ndarray:
    """(h, w) cost per meter: 1 + ``near_wall_cost`` at ``radius + margin`` meters from an
    occupied cell, falling linearly to 1 at ``preferred_clearance``."""
    closest = radius + config.margin
    span = max(config.preferred_clearance - closest, 1e-9)
    return 1.0 + config.near_wall_cost * np.clip((config.preferred_clearance - to_occupied) / span, 0, 1)


def _distance_to(mask: np.ndarray, resolution: float) -> np.ndarray:
    """(h, w) meters from each cell centre to the nearest cell of ``mask`` (off the map counts)."""
    return ndimage.distance_transform_edt(np.pad(~mask, 1, constant_values=False),
                                          sampling=resolution)[1:-1, 1:-1]
