"""Correlative scan matching (Olson, "Real-time correlative scan matching", ICRA 2009) searched
exactly by branch and bound over precomputed multi-resolution grids (Hess et al., "Real-time loop
closure in 2D LIDAR SLAM", ICRA 2016, Section V).

The search space is a lattice of poses around a guess: rotations ``guess.theta + k δθ`` within
± ``window_deg`` and translations ``guess.xy + (a, b) · resolution`` within ± ``window_xy``. A pose
scores the sum, over the scan points, of a likelihood field ``exp(-d² / 2σ²)`` (d: distance to the
nearest reference point) read at the cell each point falls in; at each rotation the rotated points
are rounded to cells once and every translation shifts them by whole cells. The optimum of that
lattice is found exactly: a node of width 2^h cells is scored on the level-h precomputation grid,
which holds at each cell the maximum of the likelihood over the 2^h × 2^h block of cells above it,
so it bounds every pose of the block; nodes are searched depth first, best child first, and pruned
when their bound is no better than the best pose found.

Its basin is metres and tens of degrees, where ``slam.registration`` corrects about one voxel; it is
meant for the front end when the wheel odometry is missing or wrong and for verifying loop closures,
followed by point-to-line refinement (its own answer is on the lattice).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gtsam
import numba
import numpy as np
from scipy.ndimage import distance_transform_edt

from slam.config import CorrelativeConfig
from slam.registration import transform


@dataclass
class CorrelativeMatch:
    """The optimum of a correlative search.

    Attributes:
        pose: the scan's pose in the grid's frame, on the search lattice.
        score: mean likelihood per scan point at ``pose``, in [0, 1].
        covariance: (3, 3) in the pose's tangent space (x, y, θ in the body frame, like
            ``gtsam.Pose2.localCoordinates``): Olson's weighted second moment of exp(S - S_max)
            over the ± ``covariance_cells`` neighbourhood, S the summed likelihood, plus the
            lattice's quantisation variance (resolution² / 12, angular_step² / 12).
        nodes: search nodes scored by branch and bound (each costs one lookup per point).
        angular_step: δθ of the rotation lattice (rad).
        points: scan points used after range filtering and thinning.
    """

    pose: gtsam.Pose2
    score: float
    covariance: np.ndarray
    nodes: int
    angular_step: float
    points: int


class CorrelativeGrid:
    """The likelihood field of reference points (a submap, in its own frame) and its
    precomputation grids for branch and bound.

    Cell (iy, ix) is centred at ``origin + (ix, iy) · resolution``; the grid covers the points plus a
    margin of 4σ, beyond which the likelihood is taken as 0.

    Args:
        points: (n, 2) reference points in the grid's frame (m); non-finite rows are ignored.
        config: resolution, likelihood_sigma and levels are used.

    Attributes:
        origin: (2,) centre of cell (0, 0) (m).
        likelihood: (h, w) float32 field exp(-d² / 2σ²), row = y.
        precomputed: (levels, h + p, w + p) float32, p = 2^(levels-1) - 1 cells of zero padding on
            the low side of each axis: ``precomputed[l, p + iy, p + ix]`` is the maximum of
            ``likelihood`` over cells [iy, iy + 2^l) × [ix, ix + 2^l) (0 off the grid).
    """

    def __init__(self, points: np.ndarray, config: CorrelativeConfig | None = None):
        self.config = config or CorrelativeConfig()
        c = self.config
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        points = points[np.isfinite(points).all(axis=1)]
        if len(points) == 0:
            raise ValueError("CorrelativeGrid: no finite reference points")
        self.resolution = c.resolution
        margin = math.ceil(4.0 * c.likelihood_sigma / c.resolution) + 1
        self.origin = points.min(axis=0) - margin * c.resolution
        cells = np.rint((points - self.origin) / c.resolution).astype(np.int64)
        w, h = cells.max(axis=0) + margin + 1
        free = np.ones((h, w), bool)
        free[cells[:, 1], cells[:, 0]] = False
        d = distance_transform_edt(free) * c.resolution
        self.likelihood = np.exp(-0.5 * (d / c.likelihood_sigma) ** 2).astype(np.float32)
        self.pad = (1 << (c.levels - 1)) - 1
        self.precomputed = precompute(self.likelihood, c.levels)

    @classmethod
    def from_scans(cls, poses: list[gtsam.Pose2], points: list[np.ndarray],
                   config: CorrelativeConfig | None = None) -> "CorrelativeGrid | None":
        """Scans ((m_i, 2) sensor-frame points) placed at ``poses`` in the grid's frame; None
        when they hold no finite point (a robot crossing a room wider than the laser's range
        sees nothing: office_g's keyframes did so ten in a row)."""
        placed = np.concatenate([transform(p, np.asarray(q, float).reshape(-1, 2))
                                 for p, q in zip(poses, points)])
        if not np.isfinite(placed).all(axis=1).any():
            return None
        return cls(placed, config)

    @property
    def shape(self) -> tuple[int, int]:
        """(h, w) cells of the likelihood field."""
        return self.likelihood.shape


def precompute(likelihood: np.ndarray, levels: int) -> np.ndarray:
    """(levels, h + p, w + p) precomputation grids of an (h, w) field, p = 2^(levels-1) - 1: level l
    at padded cell (j, i) is the maximum over the 2^l × 2^l block of field cells starting at
    (j - p, i - p) (cells off the field count as 0). Built by doubling, l from l - 1:
    P_l[j] = max(P_(l-1)[j], P_(l-1)[j + 2^(l-1)]) along each axis, O(levels · cells)."""
    pad = (1 << (levels - 1)) - 1
    h, w = likelihood.shape
    grids = np.zeros((levels, h + pad, w + pad), np.float32)
    grids[0, pad:, pad:] = likelihood
    for level in range(1, levels):
        half = 1 << (level - 1)
        rows = grids[level - 1].copy()
        rows[:, :-half] = np.maximum(rows[:, :-half], rows[:, half:])
        grids[level] = rows
        grids[level, :-half, :] = np.maximum(rows[:-half, :], rows[half:, :])
    return grids


def angular_step(max_distance: float, resolution: float) -> float:
    """δθ (rad) that moves a point ``max_distance`` m from the sensor by one cell (a chord of one
    cell; Hess et al., Section V): arccos(1 - r² / 2 d_max²)."""
    return math.acos(max(1.0 - resolution**2 / (2.0 * max(max_distance, resolution) ** 2), -1.0))


def thin(points: np.ndarray, max_points: int, min_size: float) -> np.ndarray:
    """At most ``max_points`` of the (n, 2) ``points``: the first point (input order) of each voxel,
    for the smallest voxel size ≥ ``min_size`` (bisected) that keeps no more. Deterministic."""
    if len(points) <= max_points:
        return points

    low = points.min(axis=0)

    def keep(size: float) -> np.ndarray:
        _, first = np.unique(np.floor((points - low) / size).astype(np.int64), axis=0, return_index=True)
        return np.sort(first)

    lo, hi = min_size, 2.0 * max(min_size, float(np.ptp(points, axis=0).max()))
    kept = keep(hi)                        # one voxel holds them all
    if len(keep(lo)) <= max_points:
        return points[keep(lo)]
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        candidate = keep(mid)
        if len(candidate) <= max_points:
            hi, kept = mid, candidate
        else:
            lo = mid
    return points[kept]


@dataclass
class _Search:
    """The lattice of one search: base cell indices of the points at each rotation."""

    bx: np.ndarray          # (k, m) int32 padded column of each point at each rotation, translation a = 0
    by: np.ndarray          # (k, m) int32 row
    thetas: np.ndarray      # (k,) rotations, the searched ones in [k_lo, k_hi)
    k_lo: int
    k_hi: int
    n_xy: int               # translations per axis: offsets 0 .. n_xy - 1 (cells)
    half_xy: int            # offset of the guess (cells)
    step: float
    points: int


def _lattice(grid: CorrelativeGrid, points: np.ndarray, guess: gtsam.Pose2, config: CorrelativeConfig,
             extra: int) -> _Search | None:
    """Filter and thin the scan, choose δθ, and round the rotated points to cells at every rotation
    (with ``extra`` rotations beyond the window on each side, for the covariance)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    points = points[np.isfinite(points).all(axis=1)]
    points = points[np.hypot(points[:, 0], points[:, 1]) <= config.max_range]
    points = thin(points, config.max_points, grid.resolution)
    if len(points) < config.min_points:
        return None
    step = angular_step(float(np.hypot(points[:, 0], points[:, 1]).max()), grid.resolution)
    n_theta = math.ceil(math.radians(config.window_deg) / step - 1e-9)
    half_xy = math.floor(config.window_xy / grid.resolution + 1e-9)
    k = np.arange(-n_theta - extra, n_theta + extra + 1)
    thetas = guess.theta() + k * step
    c, s = np.cos(thetas)[:, None], np.sin(thetas)[:, None]
    x = c * points[:, 0] - s * points[:, 1] + guess.x()
    y = s * points[:, 0] + c * points[:, 1] + guess.y()
    shift = grid.pad - half_xy
    bx = (np.rint((x - grid.origin[0]) / grid.resolution) + shift).astype(np.int32)
    by = (np.rint((y - grid.origin[1]) / grid.resolution) + shift).astype(np.int32)
    return _Search(bx, by, thetas, extra, extra + 2 * n_theta + 1, 2 * half_xy + 1, half_xy, step,
                   len(points))


def score(grid: CorrelativeGrid, points: np.ndarray, pose: gtsam.Pose2,
          config: CorrelativeConfig | None = None) -> float:
    """Mean likelihood, in [0, 1], of the scan at ``pose`` in the grid's frame: the points (m, 2),
    in the scan frame, filtered and thinned as ``match`` does, each read at the cell it falls in
    (0 off the grid). ``match`` maximises this over its lattice (up to the rounding of each point,
    which ``match`` does once per rotation, before the whole-cell shifts)."""
    config = config or grid.config
    _check(grid, config)
    at_pose = config.model_copy(update={"window_xy": 0.0, "window_deg": 0.0, "min_points": 1})
    search = _lattice(grid, points, pose, at_pose, 0)
    if search is None:
        return 0.0
    return _score(grid.precomputed[0], search.bx[0], search.by[0], 0, 0) / search.points


def _check(grid: CorrelativeGrid, config: CorrelativeConfig) -> None:
    for name in ("resolution", "likelihood_sigma", "levels"):
        if getattr(config, name) != getattr(grid.config, name):
            raise ValueError(f"correlative match: config.{name} = {getattr(config, name)} but the grid "
                             f"was built with {name} = {getattr(grid.config, name)}")


def match(grid: CorrelativeGrid, points: np.ndarray, guess: gtsam.Pose2,
          config: CorrelativeConfig | None = None) -> CorrelativeMatch | None:
    """The pose in the grid's frame that maximises the summed likelihood of the scan, searched
    exactly by branch and bound over the lattice around ``guess``.

    Args:
        grid: the reference's likelihood field and precomputation grids.
        points: (m, 2) scan points in the scan frame (m); non-finite rows are ignored.
        guess: the scan's predicted pose in the grid's frame.
        config: the search window and acceptance (defaults to the grid's config; its resolution,
            likelihood_sigma and levels must be the grid's).

    Returns:
        The optimum, or None when its score is below ``min_score`` or the scan has fewer than
        ``min_points`` points.
    """
    return _match(grid, points, guess, config, exhaustive=False)


def match_exhaustive(grid: CorrelativeGrid, points: np.ndarray, guess: gtsam.Pose2,
                     config: CorrelativeConfig | None = None) -> CorrelativeMatch | None:
    """``match`` by brute force: every pose of the same lattice scored on the fine grid (the
    baseline branch and bound must equal; ``nodes`` is the number of poses)."""
    return _match(grid, points, guess, config, exhaustive=True)


def _match(grid, points, guess, config, exhaustive: bool) -> CorrelativeMatch | None:
    config = config or grid.config
    _check(grid, config)
    extra = config.covariance_cells
    search = _lattice(grid, points, guess, config, extra)
    if search is None:
        return None
    floor = config.min_score * search.points - 1e-9
    if exhaustive:
        k, a, b, total, nodes = _exhaustive(grid.precomputed, search.bx, search.by, search.k_lo,
                                            search.k_hi, search.n_xy, floor)
    else:
        k, a, b, total, nodes = _branch_and_bound(grid.precomputed, search.bx, search.by, search.k_lo,
                                                  search.k_hi, search.n_xy, floor)
    if k < 0:
        return None
    r = grid.resolution
    pose = gtsam.Pose2(guess.x() + (a - search.half_xy) * r, guess.y() + (b - search.half_xy) * r,
                       float(search.thetas[k]))
    covariance = _covariance(grid, search, k, a, b, total, pose.theta(), extra)
    return CorrelativeMatch(pose, total / search.points, covariance, int(nodes), search.step, search.points)


def _covariance(grid: CorrelativeGrid, search: _Search, k: int, a: int, b: int, total: float,
                theta: float, n: int) -> np.ndarray:
    """Olson's covariance: weighted second moment of exp(S - S_max) over the ± n neighbourhood
    (cells, angular steps) of the optimum, plus the lattice's quantisation variance, turned into
    the body-frame tangent space."""
    scores = _neighbourhood(grid.precomputed[0], search.bx, search.by, k, a, b, n)
    weights = np.exp(scores - total)
    offsets = np.arange(-n, n + 1)
    dk, da, db = np.meshgrid(offsets * search.step, offsets * grid.resolution, offsets * grid.resolution,
                             indexing="ij")
    x = np.column_stack([da.ravel(), db.ravel(), dk.ravel()])
    w = weights.ravel() / weights.sum()
    mean = w @ x
    cov = (x - mean).T @ (w[:, None] * (x - mean))
    cov += np.diag([grid.resolution**2 / 12, grid.resolution**2 / 12, search.step**2 / 12])
    c, s = math.cos(theta), math.sin(theta)
    rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])   # world offsets to body frame
    return rot @ cov @ rot.T


@numba.njit(cache=True, nogil=True)
def _score(grid, bx, by, a, b):
    """Σ over points of ``grid`` at each point's cell shifted by (a, b); 0 off the grid."""
    h, w = grid.shape
    total = 0.0
    for i in range(bx.size):
        ix = bx[i] + a
        iy = by[i] + b
        if ix >= 0 and iy >= 0 and ix < w and iy < h:
            total += grid[iy, ix]
    return total


@numba.njit(cache=True, nogil=True)
def _branch_and_bound(grids, bx, by, k_lo, k_hi, n_xy, floor):
    """Depth-first branch and bound (Hess et al., Section V): the top-level nodes (one per
    rotation and 2^(L-1)-cell block) sorted by bound, children visited best first, a node pruned
    when its bound is ≤ the best score so far (which starts at ``floor``).

    Returns (k, a, b, score, nodes scored); k = -1 when nothing beats ``floor``."""
    levels = grids.shape[0]
    top = levels - 1
    width = 1 << top
    blocks = (n_xy + width - 1) // width
    n_top = (k_hi - k_lo) * blocks * blocks
    top_s = np.empty(n_top)
    top_k = np.empty(n_top, np.int64)
    top_a = np.empty(n_top, np.int64)
    top_b = np.empty(n_top, np.int64)
    n = 0
    for k in range(k_lo, k_hi):
        for ia in range(blocks):
            for ib in range(blocks):
                top_k[n] = k
                top_a[n] = ia * width
                top_b[n] = ib * width
                top_s[n] = _score(grids[top], bx[k], by[k], ia * width, ib * width)
                n += 1
    nodes = n_top
    order = np.argsort(top_s, kind="mergesort")
    size = n_top + 4 * levels + 4
    ss = np.empty(size)
    sk = np.empty(size, np.int64)
    sa = np.empty(size, np.int64)
    sb = np.empty(size, np.int64)
    sh = np.empty(size, np.int64)
    sp = 0
    for j in range(n_top):                 # ascending: the best is popped first
        i = order[j]
        ss[sp] = top_s[i]
        sk[sp] = top_k[i]
        sa[sp] = top_a[i]
        sb[sp] = top_b[i]
        sh[sp] = top
        sp += 1
    best, best_k, best_a, best_b = floor, -1, -1, -1
    cs = np.empty(4)
    ca = np.empty(4, np.int64)
    cb = np.empty(4, np.int64)
    while sp > 0:
        sp -= 1
        s, k, a, b, h = ss[sp], sk[sp], sa[sp], sb[sp], sh[sp]
        if s <= best:
            continue
        if h == 0:
            best, best_k, best_a, best_b = s, k, a, b
            continue
        half = 1 << (h - 1)
        nc = 0
        for da in (0, half):
            for db in (0, half):
                if a + da < n_xy and b + db < n_xy:
                    score = _score(grids[h - 1], bx[k], by[k], a + da, b + db)
                    nodes += 1
                    if score > best:       # insertion sort, ascending
                        j = nc
                        while j > 0 and cs[j - 1] > score:
                            cs[j], ca[j], cb[j] = cs[j - 1], ca[j - 1], cb[j - 1]
                            j -= 1
                        cs[j], ca[j], cb[j] = score, a + da, b + db
                        nc += 1
        for j in range(nc):
            ss[sp], sk[sp], sa[sp], sb[sp], sh[sp] = cs[j], k, ca[j], cb[j], h - 1
            sp += 1
    return best_k, best_a, best_b, best, nodes


@numba.njit(cache=True, nogil=True)
def _exhaustive(grids, bx, by, k_lo, k_hi, n_xy, floor):
    """Every pose of the lattice scored on the fine grid, first maximum in (k, a, b) order."""
    best, best_k, best_a, best_b = floor, -1, -1, -1
    for k in range(k_lo, k_hi):
        for a in range(n_xy):
            for b in range(n_xy):
                s = _score(grids[0], bx[k], by[k], a, b)
                if s > best:
                    best, best_k, best_a, best_b = s, k, a, b
    return best_k, best_a, best_b, best, (k_hi - k_lo) * n_xy * n_xy


@numba.njit(cache=True, nogil=True)
def _neighbourhood(grid, bx, by, k0, a0, b0, n):
    """(2n+1, 2n+1, 2n+1) fine-grid scores at rotations k0 ± n and translations (a0, b0) ± n."""
    out = np.empty((2 * n + 1, 2 * n + 1, 2 * n + 1))
    for i in range(2 * n + 1):
        for j in range(2 * n + 1):
            for l in range(2 * n + 1):
                out[i, j, l] = _score(grid, bx[k0 - n + i], by[k0 - n + i], a0 - n + j, b0 - n + l)
    return out
