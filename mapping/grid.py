"""The frame of a growing map grid: integer cells aligned to multiples of the resolution."""

from __future__ import annotations

import math

import numba
import numpy as np

#: The grid grows by at least this many cells on a side, so that growth is rare.
GROW = 64


def cell_key(cells: np.ndarray) -> np.ndarray:
    """(k, 2) integer cells (cx, cy) -> (k,) int64 keys that order them row by row."""
    cells = np.asarray(cells, np.int64)
    return (cells[:, 1] << 32) + (cells[:, 0] + (1 << 31))


def unique_keys(cells: np.ndarray) -> np.ndarray:
    """(k, 2) integer cells -> the sorted ``cell_key``s of the distinct ones, ``np.unique``'s
    answer. Cells in a box at most a few times their number are marked on a bitmap of the box
    and read back row by row, in key order: no sort (a scan's ray samples, thousands per
    ray, took a third of the log-odds grid's tracing to sort)."""
    cells = np.asarray(cells, np.int64).reshape(-1, 2)
    if not len(cells):
        return np.zeros(0, np.int64)
    lo, hi = box(cells)
    w, h = hi - lo + 1
    if w * h > 8 * len(cells) + 4096:
        return np.unique(cell_key(cells))
    marked = np.zeros(h * w, bool)
    marked[(cells[:, 1] - lo[1]) * w + (cells[:, 0] - lo[0])] = True
    flat = np.flatnonzero(marked)
    return cell_key(np.column_stack([flat % w, flat // w]) + lo)


def box(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) (2,) each: the least and greatest x and y of (k, 2) integer cells, column by
    column (``min(axis=0)`` over rows of two took 30 times as long)."""
    x, y = cells[:, 0], cells[:, 1]
    return np.array([x.min(), y.min()]), np.array([x.max(), y.max()])


def key_cells(keys: np.ndarray) -> np.ndarray:
    """``cell_key``'s inverse: (k,) keys -> (k, 2) cells (cx, cy)."""
    keys = np.asarray(keys, np.int64)
    return np.column_stack([(keys & 0xFFFFFFFF) - (1 << 31), keys >> 32])


class GridFrame:
    """Cells ``c = floor(x / resolution)`` in global integer coordinates; the stored window
    covers columns ``ix0 .. ix0 + w - 1`` and rows ``iy0 .. iy0 + h - 1`` (row 0 at the bottom).

    Args:
        resolution: cell size in meters.
    """

    def __init__(self, resolution: float):
        if not (np.isfinite(resolution) and resolution > 0):
            raise ValueError(f"grid resolution must be positive, got {resolution}")
        self.resolution = float(resolution)
        self.ix0 = self.iy0 = 0
        self.shape = (0, 0)  # (h, w)

    @property
    def empty(self) -> bool:
        return self.shape[0] == 0

    @property
    def origin(self) -> np.ndarray:
        """(2,) world coordinates of the centre of stored cell (0, 0), meters."""
        return (np.array([self.ix0, self.iy0]) + 0.5) * self.resolution

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the stored cells' outer edges, meters."""
        h, w = self.shape
        r = self.resolution
        return self.ix0 * r, (self.ix0 + w) * r, self.iy0 * r, (self.iy0 + h) * r

    def cells(self, xy: np.ndarray) -> np.ndarray:
        """(..., 2) points -> (..., 2) global integer cells (cx, cy)."""
        return np.floor(np.asarray(xy, float) / self.resolution).astype(np.int64)

    def centres(self, cells: np.ndarray) -> np.ndarray:
        """(..., 2) global cells -> (..., 2) cell centres, meters."""
        return (np.asarray(cells) + 0.5) * self.resolution

    def flat(self, cells: np.ndarray) -> np.ndarray:
        """(k, 2) global cells inside the stored window -> (k,) flat indices into (h, w)."""
        return (cells[:, 1] - self.iy0) * self.shape[1] + (cells[:, 0] - self.ix0)

    def inside(self, cells: np.ndarray) -> np.ndarray:
        """(..., 2) global cells -> (...,) bool, True where stored."""
        h, w = self.shape
        cx, cy = cells[..., 0] - self.ix0, cells[..., 1] - self.iy0
        return (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)

    def ensure(self, lo: np.ndarray, hi: np.ndarray):
        """Grow to hold global cells ``lo`` .. ``hi`` (inclusive, (2,) each).

        Returns:
            None when nothing changed, else ((rows, cols) before, (rows, cols) after) padding.
        """
        lo, hi = np.asarray(lo, np.int64), np.asarray(hi, np.int64)
        if self.empty:
            self.ix0, self.iy0 = int(lo[0]) - GROW // 2, int(lo[1]) - GROW // 2
            w, h = int(hi[0] - lo[0]) + 1 + GROW, int(hi[1] - lo[1]) + 1 + GROW
            old = self.shape
            self.shape = (h, w)
            return (0, 0), (h - old[0], w - old[1])
        h, w = self.shape
        left = max(0, self.ix0 - int(lo[0]))
        right = max(0, int(hi[0]) - (self.ix0 + w - 1))
        bottom = max(0, self.iy0 - int(lo[1]))
        top = max(0, int(hi[1]) - (self.iy0 + h - 1))
        if not (left or right or bottom or top):
            return None
        left, right = (left and left + GROW), (right and right + GROW)
        bottom, top = (bottom and bottom + GROW), (top and top + GROW)
        self.ix0 -= left
        self.iy0 -= bottom
        self.shape = (h + bottom + top, w + left + right)
        return (bottom, left), (top, right)

    def sample(self, grid: np.ndarray, xy: np.ndarray, outside: float = 0.5,
               bilinear: bool = False) -> np.ndarray:
        """Values of ``grid`` (h, w) at points ``xy`` (..., 2): the value of the cell holding
        each point, or with ``bilinear`` the bilinear interpolation between cell centres (a
        continuous map's reading); ``outside`` off the stored window."""
        if bilinear:
            return self._bilinear(grid, xy, outside)
        cells = self.cells(xy)
        ok = self.inside(cells)
        out = np.full(cells.shape[:-1], outside, dtype=float)
        c = cells[ok]
        out[ok] = grid[c[:, 1] - self.iy0, c[:, 0] - self.ix0]
        return out

    def resampled(self, grid: np.ndarray, frame: GridFrame, outside: float = 0.5) -> np.ndarray:
        """(h, w) of ``frame``'s stored window: ``grid`` (this frame's) at the centre of each of
        its cells, ``outside`` off this window (``sample`` at the cell centres). Frames of the
        same resolution share their cells, so this is then a copy of the overlap."""
        h, w = frame.shape
        if frame.resolution != self.resolution:
            yy, xx = np.mgrid[0:h, 0:w]
            return self.sample(grid, frame.origin + frame.resolution * np.stack([xx, yy], axis=-1), outside)
        out = np.full((h, w), outside, dtype=float)
        dx, dy = frame.ix0 - self.ix0, frame.iy0 - self.iy0
        x0, x1 = max(0, -dx), min(w, self.shape[1] - dx)
        y0, y1 = max(0, -dy), min(h, self.shape[0] - dy)
        if x0 < x1 and y0 < y1:
            out[y0:y1, x0:x1] = grid[y0 + dy:y1 + dy, x0 + dx:x1 + dx]
        return out

    def _bilinear(self, grid: np.ndarray, xy: np.ndarray, outside: float) -> np.ndarray:
        u = np.asarray(xy, float) / self.resolution - 0.5          # continuous cell coordinates
        c0 = np.floor(u).astype(np.int64)
        f = u - c0
        out = np.zeros(u.shape[:-1])
        for dx in (0, 1):
            for dy in (0, 1):
                c = c0 + (dx, dy)
                w = (f[..., 0] if dx else 1 - f[..., 0]) * (f[..., 1] if dy else 1 - f[..., 1])
                out += w * self.sample(grid, c * self.resolution + 0.5 * self.resolution, outside)
        return out


class FixedPoints:
    """Points (k, 2) read on a growing grid again and again (an evaluator's true free space,
    read every few steps): ``GridFrame.sample``'s answer, with each point's index in the
    stored window found once per window (and rigid move), not at every read (on office_g, 1.1
    million points at 25-step intervals took a twentieth of a run's time)."""

    def __init__(self, xy: np.ndarray):
        self.xy = np.asarray(xy, float).reshape(-1, 2)
        self._window: tuple | None = None
        self._flat = np.empty(len(self.xy), np.int64)   # each point's flat index, -1 off the window

    def sample(self, frame: GridFrame, grid: np.ndarray, outside: float = 0.5,
               moved: tuple[float, np.ndarray] = (0.0, np.zeros(2))) -> np.ndarray:
        """(k,) the values of ``grid`` (``frame``'s stored window) at the points, ``outside``
        off it; with ``moved`` (angle (rad), shift (2,) m), at the points rotated by the angle
        about the origin and then shifted (the points' frame read in the grid's)."""
        angle, shift = float(moved[0]), np.asarray(moved[1], float)
        window = (frame.resolution, frame.ix0, frame.iy0, frame.shape, angle, tuple(shift))
        if window != self._window:
            # one pass (a curve's sample moves 1.1 million points on office_g: 0.1 s in numpy)
            _moved_flat(self.xy, math.cos(angle), math.sin(angle), float(shift[0]), float(shift[1]),
                        frame.resolution, frame.ix0, frame.iy0, frame.shape[0], frame.shape[1], self._flat)
            self._window = window
        values = np.asarray(grid, float).reshape(-1)
        out = values[np.maximum(self._flat, 0)] if len(values) else np.empty(len(self.xy))
        out[self._flat < 0] = outside
        return out


@numba.njit(cache=True)
def _moved_flat(xy, c, s, tx, ty, resolution, ix0, iy0, h, w, out):
    """``out[k]``: the flat index in the (h, w) window from global cell (``ix0``, ``iy0``) of
    the cell holding point ``xy[k]`` rotated (cos ``c``, sin ``s``) and shifted (``tx``,
    ``ty``), or -1 off the window (``GridFrame.cells``, ``inside`` and ``flat`` in one pass)."""
    for k in range(xy.shape[0]):
        x, y = xy[k, 0], xy[k, 1]
        cx = int(math.floor((c * x - s * y + tx) / resolution)) - ix0
        cy = int(math.floor((s * x + c * y + ty) / resolution)) - iy0
        out[k] = cy * w + cx if 0 <= cx < w and 0 <= cy < h else -1
