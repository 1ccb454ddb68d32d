"""Shortest paths on a grid: a Dijkstra distance field from the robot, and paths down it.

One field per planning cycle gives both the path length dᵢ to every frontier cluster (eq. 11)
and the path to the chosen goal.
"""

from __future__ import annotations

import heapq
import math

import numba
import numpy as np
from scipy import ndimage

_STEPS = np.array([[1, 0], [-1, 0], [0, 1], [0, -1], [1, 1], [1, -1], [-1, 1], [-1, -1]])


@numba.njit(cache=True)
def _dijkstra(passable, cost, start_iy, start_ix, cell, steps, dist, length, parent, until):
    h, w = passable.shape
    dist[start_iy, start_ix] = 0.0
    length[start_iy, start_ix] = 0.0
    heap = [(0.0, start_iy * w + start_ix)]
    while heap:
        d, flat = heapq.heappop(heap)
        iy, ix = flat // w, flat % w
        if d > dist[iy, ix]:
            continue
        if flat == until:       # settled: its path is final
            break
        for k in range(steps.shape[0]):
            ny, nx = iy + steps[k, 1], ix + steps[k, 0]
            if ny < 0 or nx < 0 or ny >= h or nx >= w or not passable[ny, nx]:
                continue
            diagonal = steps[k, 0] != 0 and steps[k, 1] != 0
            # no corner cutting: a diagonal step needs both side cells free
            if diagonal and not (passable[iy, nx] and passable[ny, ix]):
                continue
            step = cell * math.sqrt(2.0) if diagonal else cell
            nd = d + step * 0.5 * (cost[iy, ix] + cost[ny, nx])
            if nd < dist[ny, nx]:
                dist[ny, nx] = nd
                length[ny, nx] = length[iy, ix] + step
                parent[ny, nx] = flat
                heapq.heappush(heap, (nd, ny * w + nx))


def distance_field(passable: np.ndarray, start: tuple[int, int], cell: float,
                   cost: np.ndarray | None = None, until: tuple[int, int] | None = None):
    """Cheapest paths from ``start`` = (ix, iy) over ``passable`` cells (8-connected), and
    their lengths: a step costs its length weighted by the mean ``cost`` of its two cells.
    With ``until`` (ix, iy), the search stops once that cell's path is final: its length and
    path are those of the whole field, the cells not yet settled may read longer or inf.

    Args:
        passable: (h, w) bool, cells the robot's centre may occupy.
        start: the robot's cell (ix, iy); it is always treated as passable.
        cell: cell size in meters.
        cost: (h, w) weights >= 1 per meter (e.g. ``costmap.wall_cost``); None: all 1, the
            shortest paths.

    Returns:
        dist: (h, w) meters along the cheapest path, inf where unreachable; parent: (h, w)
        flat index of the previous cell on it (-1 at the start and unreachable cells).
    """
    passable = np.array(passable, dtype=bool)
    h, w = passable.shape
    ix, iy = int(start[0]), int(start[1])
    if not (0 <= ix < w and 0 <= iy < h):
        raise ValueError(f"start cell ({ix}, {iy}) is outside the {w} x {h} grid")
    passable[iy, ix] = True
    cost = np.ones((h, w)) if cost is None else np.asarray(cost, dtype=float)
    if cost.shape != (h, w):
        raise ValueError(f"cost {cost.shape} and passable {(h, w)} must be grids of the same shape")
    total, dist = np.full((h, w), np.inf), np.full((h, w), np.inf)
    parent = np.full((h, w), -1, dtype=np.int64)
    stop = -1 if until is None else int(until[1]) * w + int(until[0])
    _dijkstra(passable, cost, iy, ix, float(cell), _STEPS, total, dist, parent, stop)
    return dist, parent


def path_to(parent: np.ndarray, goal: tuple[int, int]) -> np.ndarray:
    """(k, 2) cells (ix, iy) from the field's start to ``goal``, both included."""
    h, w = parent.shape
    flat = int(goal[1]) * w + int(goal[0])
    cells = [flat]
    while parent.flat[flat] >= 0:
        flat = int(parent.flat[flat])
        cells.append(flat)
    cells = np.array(cells[::-1])
    return np.column_stack([cells % w, cells // w])


def _disc(radius: int) -> tuple[np.ndarray, np.ndarray]:
    yy, xx = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    disc = xx**2 + yy**2 <= radius**2
    return disc, np.column_stack([xx[disc], yy[disc]])


def near_distance(dist: np.ndarray, radius: int, cells: np.ndarray) -> np.ndarray:
    """(k,) the smallest ``dist`` within ``radius`` cells of each of ``cells`` (k, 2) (ix, iy)
    (off the map: inf): the path length to a place from which the robot is that close to the
    cell. Read at the cells asked about alone (a goal choice asks about its frontier points):
    the whole map's took a third of each choice on office_g's late map."""
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
    out = np.empty(len(cells))
    _near(np.asarray(dist, dtype=float), _disc(radius)[1].astype(np.int64), cells, out)
    return out


@numba.njit(cache=True)
def _near(dist, offsets, cells, out):
    h, w = dist.shape
    for k in range(cells.shape[0]):
        best = np.inf
        for j in range(offsets.shape[0]):
            x, y = cells[k, 0] + offsets[j, 0], cells[k, 1] + offsets[j, 1]
            if 0 <= x < w and 0 <= y < h and dist[y, x] < best:
                best = dist[y, x]
        out[k] = best


def best_cell_near(dist: np.ndarray, cell, radius: int, blocked: np.ndarray | None = None) -> np.ndarray:
    """The cell (ix, iy) within ``radius`` cells of ``cell`` with the smallest ``dist``; with
    ``blocked`` (h, w) bool, the cells the laser cannot see through, the one with the smallest
    ``dist`` of those that see ``cell`` (``sees``), when one does and is reachable: a goal
    from which the frontier it serves is seen (lab_a's grid run was sent round a corner to a
    goal by a doorway's near end, from which the wall beside the doorway hid the room behind
    it; the region looked too small and the room was left)."""
    h, w = dist.shape
    candidates = np.asarray(cell) + _disc(radius)[1]
    inside = ((candidates[:, 0] >= 0) & (candidates[:, 0] < w)
              & (candidates[:, 1] >= 0) & (candidates[:, 1] < h))
    candidates = candidates[inside]
    d = dist[candidates[:, 1], candidates[:, 0]]
    if blocked is not None:
        order = np.argsort(d, kind="stable")
        order = order[np.isfinite(d[order])]
        for part in np.array_split(order, np.arange(_SIGHTS, len(order), _SIGHTS)):
            seen = seen_from(blocked, candidates[part], cell)
            if seen.any():
                return candidates[part[np.argmax(seen)]]
    return candidates[np.argmin(d)]


#: ``best_cell_near`` checks the sight lines of this many candidates at a time, nearest first.
_SIGHTS = 64


def nearest_reachable_cell(dist: np.ndarray, cell, radius: int) -> np.ndarray | None:
    """The cell (ix, iy) with a finite ``dist`` within ``radius`` cells of ``cell`` nearest to
    it in a straight line, or None."""
    h, w = dist.shape
    _, offsets = _disc(radius)
    candidates = np.asarray(cell) + offsets[np.argsort(np.hypot(*offsets.T), kind="stable")]
    inside = ((candidates[:, 0] >= 0) & (candidates[:, 0] < w)
              & (candidates[:, 1] >= 0) & (candidates[:, 1] < h))
    candidates = candidates[inside]
    finite = np.isfinite(dist[candidates[:, 1], candidates[:, 0]])
    return candidates[np.argmax(finite)] if finite.any() else None


class Approach:
    """Where to look at a frontier no reachable cell is near (a room's far side seen as a few
    beams through its door): the reachable cell nearest to it in a straight line that sees it
    (no ``blocked`` cell on the segment), more than ``min_path`` meters of path from the robot
    and no farther than ``view`` meters from the frontier.

    Args:
        dist: (h, w) path length from the robot (inf where unreachable), ``distance_field``'s.
        blocked: (h, w) bool, cells the laser cannot see through.
        resolution: cell size, meters.
    """

    def __init__(self, dist: np.ndarray, blocked: np.ndarray, resolution: float, view: float,
                 min_path: float):
        self.dist, self.blocked, self.view, self.min_path = dist, blocked, view, min_path
        self.resolution = resolution
        self._away = self._nearest = None      # the field to the reachable cells, when asked

    def goal(self, cells: np.ndarray) -> np.ndarray | None:
        """The cell (ix, iy) from which to look at the frontier ``cells`` (k, 2) (ix, iy), or
        None when no such cell is within ``view``, sees it, and is not where the robot is."""
        if self._away is None:
            self._away, self._nearest = ndimage.distance_transform_edt(
                ~np.isfinite(self.dist), sampling=self.resolution, return_indices=True)
        away = self._away[cells[:, 1], cells[:, 0]]
        for k in np.argsort(away, kind="stable")[:16]:
            if away[k] > self.view:
                return None
            iy, ix = self._nearest[:, cells[k, 1], cells[k, 0]]
            if self.dist[iy, ix] > self.min_path and sees(self.blocked, (ix, iy), cells[k]):
                return np.array([ix, iy])
        return None


def sees(blocked: np.ndarray, a, b) -> bool:
    """No ``blocked`` cell between cells ``a`` and ``b`` (ix, iy), sampled every half cell."""
    return bool(seen_from(blocked, np.asarray(a)[None], b)[0])


def seen_from(blocked: np.ndarray, starts: np.ndarray, b) -> np.ndarray:
    """(k,) bool: ``sees(blocked, a, b)`` for each cell ``a`` of ``starts`` (k, 2), at once: the
    segment to ``b`` sampled at ``n`` points ``i / (n - 1)`` of the way, its end exactly."""
    starts = np.asarray(starts).reshape(-1, 2)
    d = np.asarray(b) - starts
    n = np.maximum(2, (2 * np.hypot(d[:, 0], d[:, 1])).astype(int) + 1)
    segment = np.repeat(np.arange(len(starts)), n)
    i = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    t = i * np.repeat(1.0 / (n - 1), n)
    t[np.cumsum(n) - 1] = 1.0
    ix = np.round(starts[segment, 0] + t * d[segment, 0]).astype(int)
    iy = np.round(starts[segment, 1] + t * d[segment, 1]).astype(int)
    return ~np.logical_or.reduceat(blocked[iy, ix], np.cumsum(n) - n)
