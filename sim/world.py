"""A world: the true occupancy grid with its metric frame."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage


@dataclass(frozen=True)
class World:
    """A true occupancy grid in a metric frame.

    Cell ``occupied[iy, ix]`` covers x in ``[x0 + ix*rx, x0 + (ix+1)*rx)`` and y in
    ``[y0 + iy*ry, y0 + (iy+1)*ry)``: row 0 is at the bottom, x to the right, y up. Cells may
    be non-square (Stage stretches bitmaps). Everything outside the grid counts as occupied.

    Attributes:
        occupied: (h, w) bool grid.
        resolution: (rx, ry) cell size in meters.
        origin: (x0, y0) world coordinates of the lower-left corner of cell (0, 0), meters.
        name: where the world came from.
    """

    occupied: np.ndarray
    resolution: tuple[float, float]
    origin: tuple[float, float] = (0.0, 0.0)
    name: str = "world"
    _clearance: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self):
        grid = np.ascontiguousarray(self.occupied, dtype=bool)
        if grid.ndim != 2 or min(grid.shape) < 1:
            raise ValueError(f"{self.name}: occupancy grid must be 2-D and non-empty, got {grid.shape}")
        rx, ry = (float(r) for r in self.resolution)
        if not (rx > 0 and ry > 0 and np.isfinite(rx) and np.isfinite(ry)):
            raise ValueError(f"{self.name}: resolution must be positive, got {self.resolution}")
        object.__setattr__(self, "occupied", grid)
        object.__setattr__(self, "resolution", (rx, ry))
        object.__setattr__(self, "origin", (float(self.origin[0]), float(self.origin[1])))

    @property
    def shape(self) -> tuple[int, int]:
        """(h, w) in cells."""
        return self.occupied.shape

    @property
    def size(self) -> tuple[float, float]:
        """(width, height) in meters."""
        return self.shape[1] * self.resolution[0], self.shape[0] * self.resolution[1]

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) in meters, as matplotlib's ``imshow(origin="lower")`` wants."""
        (x0, y0), (w, h) = self.origin, self.size
        return x0, x0 + w, y0, y0 + h

    def cell_of(self, xy: np.ndarray) -> np.ndarray:
        """(..., 2) world points -> (..., 2) integer cells (ix, iy); may lie outside the grid."""
        xy = np.asarray(xy, dtype=float)
        return np.floor((xy - self.origin) / self.resolution).astype(int)

    def center_of(self, cells: np.ndarray) -> np.ndarray:
        """(..., 2) integer cells (ix, iy) -> (..., 2) world coordinates of their centres."""
        return self.origin + (np.asarray(cells) + 0.5) * self.resolution

    def contains(self, cells: np.ndarray) -> np.ndarray:
        """(..., 2) cells -> (...,) bool, True where the cell lies on the grid."""
        cells = np.asarray(cells)
        h, w = self.shape
        return (cells[..., 0] >= 0) & (cells[..., 0] < w) & (cells[..., 1] >= 0) & (cells[..., 1] < h)

    def is_occupied(self, xy: np.ndarray) -> np.ndarray:
        """(..., 2) world points -> (...,) bool; points off the grid are occupied."""
        cells = self.cell_of(xy)
        inside = self.contains(cells)
        out = np.ones(cells.shape[:-1], dtype=bool)
        out[inside] = self.occupied[cells[inside][:, 1], cells[inside][:, 0]]
        return out

    def collides(self, xy, radius: float) -> bool:
        """True if a disc of ``radius`` meters centred at ``xy`` overlaps an occupied cell.

        Exact on the grid: the disc is tested against every cell rectangle it could touch;
        cells off the grid are occupied.
        """
        x, y = float(xy[0]), float(xy[1])
        (x0, y0), (rx, ry) = self.origin, self.resolution
        cx, cy = int(np.floor((x - x0) / rx)), int(np.floor((y - y0) / ry))
        h, w = self.shape
        if 0 <= cx < w and 0 <= cy < h and self._centre_distance()[cy, cx] - math.hypot(rx, ry) >= radius:
            return False      # every occupied cell is farther than that from any point of this cell
        ix = np.arange(int(np.floor((x - radius - x0) / rx)), int(np.floor((x + radius - x0) / rx)) + 1)
        iy = np.arange(int(np.floor((y - radius - y0) / ry)), int(np.floor((y + radius - y0) / ry)) + 1)
        gx, gy = np.meshgrid(ix, iy)
        cells = np.stack([gx, gy], axis=-1).reshape(-1, 2)
        inside = self.contains(cells)
        blocked = np.ones(len(cells), dtype=bool)
        blocked[inside] = self.occupied[cells[inside, 1], cells[inside, 0]]
        cells = cells[blocked]
        lo = self.origin + cells * self.resolution
        gap = np.maximum(np.maximum(lo - (x, y), 0.0), (x, y) - (lo + self.resolution))
        return bool(np.any(np.einsum("ij,ij->i", gap, gap) < radius * radius))

    def _centre_distance(self) -> np.ndarray:
        """(h, w) meters from each cell centre to the nearest occupied cell's centre (the grid
        border counts as a wall): a point of a cell lies within half a cell's diagonal of its
        centre, and so does every point of an occupied cell of its own."""
        if "centres" not in self._clearance:
            padded = np.pad(~self.occupied, 1, constant_values=False)
            rx, ry = self.resolution
            self._clearance["centres"] = ndimage.distance_transform_edt(padded, sampling=(ry, rx))[1:-1, 1:-1]
        return self._clearance["centres"]

    def clearance(self) -> np.ndarray:
        """(h, w) distance in meters from each cell centre to the nearest occupied cell's edge.

        The grid border counts as a wall. Occupied cells have clearance 0.
        """
        if "edt" not in self._clearance:
            # EDT measures centre to centre: the wall's near edge is half a cell closer.
            half = 0.5 * min(self.resolution)
            self._clearance["edt"] = np.maximum(self._centre_distance() - half, 0.0) * ~self.occupied
        return self._clearance["edt"]

    def clearance_at(self, xy: np.ndarray) -> np.ndarray:
        """(..., 2) world points -> (...,) clearance in meters (0 off the grid)."""
        cells = self.cell_of(xy)
        inside = self.contains(cells)
        out = np.zeros(cells.shape[:-1])
        out[inside] = self.clearance()[cells[inside][:, 1], cells[inside][:, 0]]
        return out

    def reachable(self, start_xy, radius: float, margin: float = 0.0) -> np.ndarray:
        """(h, w) bool: cells a disc robot of ``radius`` meters can reach from ``start_xy``
        through no gap narrower than its diameter plus ``margin`` on each side.

        A flood fill (4-connected) over the cells whose clearance is at least ``radius +
        margin``, from the start's cell, then the cells of clearance at least ``radius`` in
        the same free space within ``margin`` (and a cell) of them: the robot's centre goes
        there too, beside a wall, but a passage that leaves it less than ``margin`` to spare
        is not one it takes (a planner keeps that margin against range noise).

        Raises:
            ValueError: if the start itself is not free for the robot.
        """
        clearance = self.clearance()
        free = clearance >= radius
        cell = self.cell_of(np.asarray(start_xy, dtype=float))
        if not self.contains(cell) or not free[cell[1], cell[0]]:
            raise ValueError(
                f"{self.name}: start {tuple(np.round(start_xy, 3))} is not free for a robot of "
                f"radius {radius} m"
            )
        labels, _ = ndimage.label(free)
        region = labels == labels[cell[1], cell[0]]
        if margin <= 0:
            return region
        wide, _ = ndimage.label(clearance >= radius + margin)
        core = wide == wide[cell[1], cell[0]] if wide[cell[1], cell[0]] else np.zeros_like(region)
        core[cell[1], cell[0]] = True
        rx, ry = self.resolution
        near = ndimage.distance_transform_edt(~core, sampling=(ry, rx)) <= margin + max(rx, ry)
        return region & near
