"""What every recorded laser log is to the rest of the stack: its records in time order."""

from __future__ import annotations

import numpy as np


class LaserLog:
    """A sequence of records, each with ``.scan`` (a LaserScan) and ``.pose`` (the odometry at
    it); subclasses read a file format and fill ``records``."""

    records: list

    def __len__(self) -> int:
        return len(self.records)

    def __getitem__(self, i: int):
        return self.records[i]

    def __iter__(self):
        return iter(self.records)

    @property
    def duration(self) -> float | None:
        """Seconds between the first and last scan; None when the stamps are broken (some logs'
        are all 0, all equal, or take a handful of values): fewer than 90 % of consecutive
        scans have increasing stamps."""
        stamps = np.array([r.scan.timestamp for r in self.records])
        if len(stamps) < 2 or np.mean(np.diff(stamps) > 0) < 0.9:
            return None
        return float(stamps[-1] - stamps[0])
