"""What every recorded laser log is to the rest of the stack: its records in time order."""

from __future__ import annotations


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
    def duration(self) -> float:
        """Seconds between the first and last scan."""
        return self.records[-1].scan.timestamp - self.records[0].scan.timestamp
