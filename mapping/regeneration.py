"""What a regeneration (Section VII) must relearn: the keyframes that moved, and the tiles of a
map grid their evidence reached before and after.

A map fuses keyframes one after another into sums per cell, and each keyframe touches only a
window round its sensor. After a loop closure most of a long run's keyframes keep their place,
so relearning every one of them (office_g: 3 000 keyframes, 15-20 s a regeneration) mostly
recomputes what is already there. A map that keeps, for each keyframe, the pose it was fused
at and the tiles its evidence touched can instead clear the tiles the moved keyframes touch,
at their old and their new poses, and fuse into those tiles alone, in the original order,
every keyframe that touches them: the sums then equal those of relearning from scratch.
"""

from __future__ import annotations

from collections.abc import Iterable

import gtsam
import numpy as np

from mapping.grid import GridFrame, cell_key, key_cells


def moved(before: gtsam.Pose2 | None, pose: gtsam.Pose2, reach: float, tolerance: float) -> bool:
    """Did a keyframe fused at ``before`` (None: at no known pose) move at ``pose`` so that one
    of its points, up to ``reach`` meters from the sensor, moved by ``tolerance`` meters or
    more? With ``tolerance`` 0, any change of the pose counts."""
    if before is None:
        return True
    was, now = (np.array([p.x(), p.y(), p.theta()]) for p in (before, pose))
    if tolerance == 0:
        return not np.array_equal(was, now)
    turn = abs((now[2] - was[2] + np.pi) % (2 * np.pi) - np.pi)
    return float(np.hypot(*(now[:2] - was[:2]))) + turn * reach >= tolerance


def tiles_of(keys: np.ndarray, tile: int) -> np.ndarray:
    """(k,) the ``cell_key``s of the ``tile`` x ``tile`` tiles holding the cells of (k,)
    ``cell_key``s ``keys``."""
    return cell_key(np.floor_divide(key_cells(keys), tile))


def touches(keys: np.ndarray, dirty: np.ndarray) -> np.ndarray:
    """(k,) bool: which of the tile ``keys`` are among the sorted ``dirty`` keys."""
    if not len(dirty):
        return np.zeros(len(keys), bool)
    at = np.searchsorted(dirty, keys)
    return (at < len(dirty)) & (dirty[np.minimum(at, len(dirty) - 1)] == keys)


def tile_mask(frame: GridFrame, dirty: np.ndarray, tile: int) -> np.ndarray:
    """(h, w) bool over ``frame``'s stored cells: those in the tiles of ``dirty`` keys."""
    h, w = frame.shape
    tx, ty = key_cells(dirty).T
    t0x, t0y = frame.ix0 // tile, frame.iy0 // tile
    th, tw = (frame.iy0 + h - 1) // tile - t0y + 1, (frame.ix0 + w - 1) // tile - t0x + 1
    tiles = np.zeros((th, tw), bool)
    ok = (tx >= t0x) & (tx < t0x + tw) & (ty >= t0y) & (ty < t0y + th)
    tiles[ty[ok] - t0y, tx[ok] - t0x] = True
    rows = (np.arange(h) + frame.iy0) // tile - t0y
    cols = (np.arange(w) + frame.ix0) // tile - t0x
    return tiles[np.ix_(rows, cols)]


def replayed_frame(resolution: float, bounds: Iterable[tuple[np.ndarray, np.ndarray] | None]) -> GridFrame:
    """The frame a map grows to when keyframes reaching global cells ``bounds`` (lo, hi) (None:
    none) are fused into it one after another from empty."""
    frame = GridFrame(resolution)
    for bound in bounds:
        if bound is not None:
            frame.ensure(*bound)
    return frame


def reframed(grid: np.ndarray, old: GridFrame, new: GridFrame) -> np.ndarray:
    """``grid`` (``old``'s cells) on ``new``'s cells: the overlap copied, 0 elsewhere."""
    return old.resampled(grid, new, outside=0.0)
