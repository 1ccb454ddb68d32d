"""A planar laser scan: the unit of data every part of the stack consumes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LaserScan:
    """One sweep of a planar range finder, in the sensor frame.

    Attributes:
        ranges: (n,) ranges in meters. A beam with no return is NaN, +inf, or any value
            >= ``max_range`` (what real sensors and CARMEN logs report).
        angles: (n,) beam angles in radians, counter-clockwise, 0 straight ahead.
        max_range: the sensor's maximum range in meters.
        timestamp: seconds.
    """

    ranges: np.ndarray
    angles: np.ndarray
    max_range: float
    timestamp: float = 0.0

    def __post_init__(self):
        ranges = np.asarray(self.ranges, dtype=float)
        angles = np.asarray(self.angles, dtype=float)
        if ranges.ndim != 1 or ranges.shape != angles.shape:
            raise ValueError(
                f"scan has {ranges.shape} ranges but {angles.shape} angles; both must be (n,)"
            )
        if not self.max_range > 0:
            raise ValueError(f"scan max_range must be positive, got {self.max_range}")
        object.__setattr__(self, "ranges", ranges)
        object.__setattr__(self, "angles", angles)

    def __len__(self) -> int:
        return self.ranges.size

    @property
    def hit(self) -> np.ndarray:
        """(n,) bool: beams that returned from an obstacle (finite, positive, below max range)."""
        with np.errstate(invalid="ignore"):
            return np.isfinite(self.ranges) & (self.ranges > 0) & (self.ranges < self.max_range)

    @property
    def no_return(self) -> np.ndarray:
        """(n,) bool: beams that saw nothing within max range (free up to max range)."""
        with np.errstate(invalid="ignore"):
            return ~self.hit & ((self.ranges >= self.max_range) | np.isposinf(self.ranges))

    def points(self) -> np.ndarray:
        """(m, 2) hit points in the sensor frame, in meters."""
        r, a = self.ranges[self.hit], self.angles[self.hit]
        return np.column_stack([r * np.cos(a), r * np.sin(a)])


def fov_angles(n: int, fov: float, *, include_end: bool) -> np.ndarray:
    """(n,) beam angles spanning ``fov`` radians centred on 0, counter-clockwise.

    ``include_end`` places the last beam exactly at +fov/2 (step fov/(n-1)); otherwise the
    step is fov/n and the last beam stops one step short.
    """
    if n < 1:
        raise ValueError(f"a scan needs at least one beam, got {n}")
    step = fov / (n - 1) if include_end and n > 1 else fov / n
    return -fov / 2 + step * np.arange(n)
