"""Training points of a keyframe (Section IV-A): hits for the obstacle GP, points sampled along
each beam for the free GP, in the world frame."""

from __future__ import annotations

from dataclasses import dataclass

import gtsam
import numpy as np

from mapping.config import TrainingConfig
from slam.scan import LaserScan


@dataclass(frozen=True)
class BeamSamples:
    """Labelled points of one scan in the world frame.

    Attributes:
        origin: (2,) sensor position, meters.
        hits: (k, 2) obstacle points; ``hit_beam`` (k,) the beam index of each.
        free: (m, 2) free points along beams (before each hit, up to max range for beams with
            no return); ``free_beam`` (m,) the beam index of each.
    """

    origin: np.ndarray
    hits: np.ndarray
    hit_beam: np.ndarray
    free: np.ndarray
    free_beam: np.ndarray

    def select(self, keep_hits: np.ndarray, keep_free: np.ndarray) -> "BeamSamples":
        """A copy with only the hits and free points flagged True."""
        return BeamSamples(self.origin, self.hits[keep_hits], self.hit_beam[keep_hits],
                           self.free[keep_free], self.free_beam[keep_free])


def beam_samples(pose: gtsam.Pose2, scan: LaserScan, config: TrainingConfig) -> BeamSamples:
    """Hits and free points of ``scan`` taken at sensor ``pose`` (world frame), vectorised.

    Beams with NaN, negative or zero ranges carry no information and give nothing. Hits
    beyond ``config.max_range`` are treated as beams with no return. Free points lie every
    ``free_step`` meters from the sensor up to ``free_margin`` before the hit (or the range
    limit), never past it; with ``free_end`` also at that last free point.
    """
    c = config
    limit = min(c.max_range, scan.max_range)
    hit = scan.hit & (scan.ranges < c.max_range)
    no_return = scan.no_return | (scan.hit & ~hit)
    beams = np.flatnonzero(hit | no_return)
    r = scan.ranges[beams]
    end = np.where(hit[beams], r - c.free_margin, limit)
    beams, end = beams[end > 0], end[end > 0]

    theta = pose.theta() + scan.angles
    direction = np.column_stack([np.cos(theta), np.sin(theta)])
    origin = np.array([pose.x(), pose.y()])

    hb = np.flatnonzero(hit)
    hits = origin + scan.ranges[hb, None] * direction[hb]

    # free points: j·step for j = 1..floor(end/step), and end itself if free_end
    if c.free_end:
        count = np.ceil(end / c.free_step).astype(int)
    else:
        count = np.floor(end / c.free_step).astype(int)
        beams, end, count = beams[count > 0], end[count > 0], count[count > 0]
    free_beam = np.repeat(beams, count)
    first = np.repeat(np.cumsum(count) - count, count)
    j = np.arange(free_beam.size) - first + 1
    dist = np.minimum(j * c.free_step, np.repeat(end, count))
    free = origin + dist[:, None] * direction[free_beam]
    return BeamSamples(origin, hits, hb, free, free_beam)


def voxel_thin(points: np.ndarray, voxel: float) -> np.ndarray:
    """Indices of one point per ``voxel``-sized square cell (the first in input order), sorted."""
    if len(points) == 0:
        return np.zeros(0, dtype=int)
    key = np.floor(points / voxel).astype(np.int64)
    key = (key[:, 0] << 32) ^ (key[:, 1] & 0xFFFFFFFF)
    _, first = np.unique(key, return_index=True)
    return np.sort(first)
