"""An independent yardstick for exploration: a short tour that sees every reachable free cell.

``seeing_tour`` estimates how far an explorer that KNEW the map would have to drive for its
laser to see (nearly) every cell the robot can reach. An explorer that does not know the map
has to discover where to look, so it should need more than this, but on a small, simple world
not much more; and it cannot need much less, because a cell that is never seen is not known.
(It can need somewhat less: it also sees while it drives, and a GP map infers a few cells it
never saw. The tour counts only what is seen from its stops.)

The method uses nothing of the project's explorer, frontier or planning code, only the true
``World`` (occupancy, ``reachable``, ``center_of``) and the robot's and laser's parameters:

1. Targets: the reachable free cells (those the robot's centre can reach, as the episode's
   coverage metric counts them), subsampled to ``target_cell`` (0.2 m).
2. Visibility: a target is seen from a point when it lies within the laser's ``max_range`` and
   the straight segment to it crosses no occupied cell (sampled every half grid cell, so a
   segment that grazes a cell's corner may pass; about 0.1 % of pairs on ``two_rooms``). Every
   stop sees 360°, although the laser's field of view is only ``fov_deg`` (180°): the robot
   turns on the spot, and turning costs time but no travel.
3. Stops: candidate viewpoints on a ``viewpoint_cell`` (0.25 m) lattice of reachable cells. The
   start counts as a free stop (the episode begins with a full spin there). A cost-effective
   greedy set cover adds the viewpoint that sees the most unseen targets per meter of detour
   (its cheapest insertion into the tour so far, plus a ``stop_cost``) until ``fraction``
   (99 %) of the targets are seen; a local search then drops stops, or moves one at a time to
   another candidate, while that shortens the tour and keeps ``fraction`` seen. This runs for
   a few stop costs, from 0.05 m to infinite (plain greedy cover), and the shortest tour wins.
4. Distances: shortest paths through the reachable cells on a 16-connected grid (the 8
   neighbours plus the knight's moves) with Euclidean edge lengths, scipy's Dijkstra; a
   straight line is overestimated by at most 2.7 %.
5. Tour: an open path (no return) from the start through every chosen stop, nearest
   neighbour then 2-opt.

So the number estimates the shortest seeing tour from above (set cover and 2-opt are
heuristics, and seeing while driving is ignored); it is not a proven lower bound on any
explorer's travel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from sim.lidar import LidarConfig
from sim.robot import RobotConfig
from sim.world import World


@dataclass(frozen=True)
class SeeingTour:
    """A tour from the start through viewpoints that together see the reachable free cells.

    Attributes:
        length_m: length of the open path start -> stops[0] -> ... -> stops[-1], meters.
        start: (2,) start point, meters.
        stops: (k, 2) the viewpoints in tour order, meters (k = 0: the start sees enough).
        seen: fraction of the targets seen from the start and the stops.
        targets: number of target cells.
    """

    length_m: float
    start: np.ndarray
    stops: np.ndarray
    seen: float
    targets: int


def seeing_tour(world: World, start_xy, robot: RobotConfig | None = None,
                lidar: LidarConfig | None = None, fraction: float = 0.99,
                target_cell: float = 0.2, viewpoint_cell: float = 0.25,
                stop_costs: tuple[float, ...] = (0.05, 0.25, 1.0, 4.0, math.inf)) -> SeeingTour:
    """A short tour from ``start_xy`` whose stops see ``fraction`` of the reachable free cells.

    Args:
        world: the true map.
        start_xy: (2,) where the robot starts, meters.
        robot: its ``radius`` (m) decides which cells are reachable; defaults to ``RobotConfig()``.
        lidar: its ``max_range`` (m) is how far a stop sees; defaults to ``LidarConfig()``.
        fraction: share of the target cells the start and the stops must see together.
        target_cell: spacing of the target cells, meters.
        viewpoint_cell: spacing of the candidate viewpoints, meters.
        stop_costs: meters charged to each stop besides its detour, one greedy cover each
            (``inf``: distance-blind greedy); the shortest tour after local search wins.
    """
    robot, lidar = robot or RobotConfig(), lidar or LidarConfig()
    start = np.asarray(start_xy, dtype=float)
    reach = world.reachable(start, robot.radius)
    targets = world.center_of(_lattice(reach, world.resolution, target_cell))
    candidates = _lattice(reach, world.resolution, viewpoint_cell)
    seen = visible(world, start[None], targets, lidar.max_range)[0]
    if seen.mean() >= fraction:
        return SeeingTour(0.0, start, np.zeros((0, 2)), float(seen.mean()), len(targets))
    sees = visible(world, world.center_of(candidates), targets, lidar.max_range)
    d = _path_lengths(world, reach, world.cell_of(start), candidates)
    tries = [_shorten(d, seen, sees, fraction, _greedy_cover(d, seen, sees, fraction, cost))
             for cost in stop_costs]
    lengths = [_insertion(d, stops)[0] for stops in tries]
    chosen = min((stops for stops, length in zip(tries, lengths) if length <= min(lengths) + 1e-9),
                 key=len)
    order, length = _open_tour(d[np.ix_(np.r_[0, chosen + 1], np.r_[0, chosen + 1])])
    covered = seen | sees[chosen].any(axis=0)
    return SeeingTour(length, start, world.center_of(candidates[chosen[order]]),
                      float(covered.mean()), len(targets))


def step_bound(length_m: float, robot: RobotConfig | None = None, lidar: LidarConfig | None = None,
               spin: float = 2 * math.pi) -> float:
    """Scans an ideal run of ``length_m`` meters takes: driving at full speed after one ``spin``
    (rad) on the spot at the full turn rate, one scan per laser period. Turns at the stops are
    not counted."""
    robot, lidar = robot or RobotConfig(), lidar or LidarConfig()
    return lidar.rate_hz * (length_m / robot.max_speed + spin / robot.max_turn_rate)


def visible(world: World, viewers: np.ndarray, targets: np.ndarray, max_range: float) -> np.ndarray:
    """(n, 2) viewers, (m, 2) targets (meters) -> (n, m) bool: target within ``max_range`` of the
    viewer and the segment between them free of occupied cells.

    The segments are sampled every half grid cell; all pairs advance together, longest first,
    so the loop runs over sample steps (max_range / step of them), never over pairs or cells.
    """
    offset = targets[None] - viewers[:, None]
    distance = np.hypot(offset[..., 0], offset[..., 1])
    vi, ti = np.nonzero(distance <= max_range)
    d = distance[vi, ti]
    by_length = np.argsort(-d)
    vi, ti, d = vi[by_length], ti[by_length], d[by_length]
    unit = offset[vi, ti] / np.maximum(d, 1e-12)[:, None]
    origin = viewers[vi]
    h, w = world.shape
    flat = np.pad(world.occupied, 1, constant_values=True).ravel()   # off the grid is occupied
    (x0, y0), (rx, ry) = world.origin, world.resolution
    step = 0.5 * min(rx, ry)
    blocked = np.zeros(len(d), dtype=bool)
    for s in np.arange(step, max_range, step):
        n = np.searchsorted(-d, -s)           # pairs longer than s: a prefix, longest first
        if n == 0:
            break
        p = origin[:n] + s * unit[:n]
        ix = np.clip(np.floor((p[:, 0] - x0) / rx).astype(int) + 1, 0, w + 1)
        iy = np.clip(np.floor((p[:, 1] - y0) / ry).astype(int) + 1, 0, h + 1)
        blocked[:n] |= flat[iy * (w + 2) + ix]
    out = np.zeros(distance.shape, dtype=bool)
    out[vi, ti] = ~blocked
    return out


def _greedy_cover(d: np.ndarray, seen: np.ndarray, sees: np.ndarray, fraction: float,
                  stop_cost: float) -> np.ndarray:
    """Cost-effective greedy set cover: add the candidate that sees the most unseen targets per
    meter its cheapest insertion adds to the tour (plus ``stop_cost`` m, so that a stop on the
    way is not free; ``inf``: the most unseen targets), until ``fraction`` of them is seen.

    Args:
        d: (n+1, n+1) path lengths, node 0 the start, node j+1 candidate j.
        seen: (m,) targets the start sees.
        sees: (n, m) targets each candidate sees.
    Returns:
        (k,) indices of the chosen candidates.
    """
    seen, chosen = seen.copy(), np.zeros(0, dtype=int)
    while seen.mean() < fraction:
        gain = (sees & ~seen).sum(axis=1)
        if not gain.any():
            raise ValueError(f"no viewpoint sees the last {np.sum(~seen)} of {seen.size} targets")
        score = gain if np.isinf(stop_cost) else gain / (_insertion(d, chosen)[1] + stop_cost)
        best = int(np.argmax(score))
        chosen = np.r_[chosen, best]
        seen |= sees[best]
    return chosen


def _insertion(d: np.ndarray, chosen: np.ndarray) -> tuple[float, np.ndarray]:
    """Length of the tour through ``chosen`` (k,), and (n,) what inserting each candidate at its
    cheapest place (or at the end) would add to it; ``d`` as in ``_greedy_cover``."""
    nodes = np.r_[0, chosen + 1]
    order, length = _open_tour(d[np.ix_(nodes, nodes)])
    path = np.r_[0, chosen[order] + 1]
    into = d[path[:-1], 1:] + d[path[1:], 1:] - d[path[:-1], path[1:]][:, None]
    return length, np.minimum(into.min(axis=0, initial=np.inf), d[path[-1], 1:])


def _shorten(d: np.ndarray, seen: np.ndarray, sees: np.ndarray, fraction: float,
             chosen: np.ndarray) -> np.ndarray:
    """Local search on the stops: of all moves that drop one stop, or move it to the candidate
    with the cheapest insertion into the others' tour, make the one giving the shortest tour
    that still sees ``fraction``, while it is shorter (or as short with fewer stops).
    Arguments as in ``_greedy_cover``; ``chosen`` (k,) is where the search starts."""
    best = _insertion(d, chosen)[0]
    while len(chosen):
        moves = []
        for i in range(len(chosen)):
            others = np.delete(chosen, i)
            base = seen | sees[others].any(axis=0)
            length, added = _insertion(d, others)
            if base.mean() >= fraction:
                moves.append((length, others))
            ok = (sees | base).mean(axis=1) >= fraction
            if ok.any():
                trial = np.r_[others, int(np.argmin(np.where(ok, added, np.inf)))]
                moves.append((_insertion(d, trial)[0], trial))
        shortest = min(length for length, _ in moves)
        length, trial = min((m for m in moves if m[0] <= shortest + 1e-9), key=lambda m: len(m[1]))
        if length < best - 1e-9 or (length <= best + 1e-9 and len(trial) < len(chosen)):
            chosen, best = trial, length
        else:
            break
    return chosen


def _lattice(mask: np.ndarray, resolution, spacing: float) -> np.ndarray:
    """(h, w) bool -> (k, 2) cells (ix, iy) of ``mask`` on a lattice ``spacing`` meters apart."""
    sx, sy = (max(1, round(spacing / r)) for r in resolution)
    sub = np.zeros_like(mask)
    sub[sy // 2::sy, sx // 2::sx] = True
    iy, ix = np.nonzero(mask & sub)
    return np.column_stack([ix, iy])


def _path_lengths(world: World, reach: np.ndarray, start: np.ndarray,
                  candidates: np.ndarray) -> np.ndarray:
    """(k+1, k+1) shortest path lengths (m) through ``reach`` between the start cell and the
    (k, 2) candidate cells, on a 16-connected grid; a move is allowed when every cell its segment
    crosses is reachable."""
    h, w = reach.shape
    rx, ry = world.resolution
    index = np.full((h, w), -1)
    index[reach] = np.arange(reach.sum())
    rows, cols, lengths = [], [], []
    # (dx, dy) and the cells (besides both ends) that the move's segment passes through
    moves = [((1, 0), []), ((0, 1), []), ((1, 1), [(1, 0), (0, 1)]), ((1, -1), [(1, 0), (0, -1)]),
             ((2, 1), [(1, 0), (1, 1)]), ((1, 2), [(0, 1), (1, 1)]),
             ((2, -1), [(1, 0), (1, -1)]), ((1, -2), [(0, -1), (1, -1)])]
    iy, ix = np.nonzero(reach)
    for (dx, dy), through in moves:
        ok = np.ones(len(ix), dtype=bool)
        for cx, cy in [(dx, dy), *through]:
            jx, jy = ix + cx, iy + cy
            inside = (jx >= 0) & (jx < w) & (jy >= 0) & (jy < h)
            ok &= inside
            ok[inside] &= reach[jy[inside], jx[inside]]
        rows.append(index[iy[ok], ix[ok]])
        cols.append(index[iy[ok] + dy, ix[ok] + dx])
        lengths.append(np.full(ok.sum(), math.hypot(dx * rx, dy * ry)))
    n = int(reach.sum())
    graph = sparse.csr_matrix((np.concatenate(lengths), (np.concatenate(rows), np.concatenate(cols))),
                              shape=(n, n))
    nodes = index[np.r_[start[1], candidates[:, 1]], np.r_[start[0], candidates[:, 0]]]
    return dijkstra(graph, directed=False, indices=nodes)[:, nodes]


def _open_tour(d: np.ndarray) -> tuple[np.ndarray, float]:
    """(k+1, k+1) distances, node 0 the start -> (k,) order of nodes 1..k (0-based among the
    stops) and the length of the open path from the start: nearest neighbour, then 2-opt."""
    k = len(d) - 1
    path, left = [0], set(range(1, k + 1))
    while left:
        nxt = min(left, key=lambda j: d[path[-1], j])
        path.append(nxt)
        left.remove(nxt)

    def length(p):
        return float(sum(d[a, b] for a, b in zip(p[:-1], p[1:])))

    improved = True
    while improved:
        improved = False
        for i in range(1, k):
            for j in range(i + 1, k + 1):
                candidate = path[:i] + path[i:j + 1][::-1] + path[j + 1:]
                if length(candidate) < length(path) - 1e-9:
                    path, improved = candidate, True
    return np.array(path[1:], dtype=int) - 1, length(path)
