"""Costmap for planning: where the robot's centre may go, derived from occupancy probabilities."""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree
from pydantic import BaseModel, ConfigDict, Field, model_validator


class CostmapConfig(BaseModel):
    """Thresholds that split a probability map into free, occupied and unknown cells."""

    model_config = ConfigDict(extra="forbid")

    free_below: float = Field(0.35, gt=0, lt=1, description="Λ below this is free")
    occupied_above: float = Field(0.65, gt=0, lt=1, description="Λ above this is occupied")
    margin: float = Field(0.02, ge=0, description="meters of clearance added to the robot "
                          "radius, beyond the hits (2 sigma of the range noise): a 0.25 m robot "
                          "fits through doors wider than 0.54 m; the navigator's guard keeps it "
                          "off what the current scan shows")
    unknown_clearance: float = Field(
        0.1, ge=0, description="meters the robot's centre keeps from unknown cells; occupied "
        "cells are kept at radius + margin. The COM leaves a band near walls unknown, so "
        "inflating unknown space by the full radius would close doors the robot fits through")

    near_wall_cost: float = Field(
        0.0, ge=0, description="extra cost per meter of path at radius + margin from an occupied "
        "cell, falling linearly to 0 at preferred_clearance, so paths keep off walls where there "
        "is room")
    preferred_clearance: float = Field(
        0.6, gt=0, description="meters from an occupied cell beyond which a path costs its length")

    @model_validator(mode="after")
    def _ordered(self):
        if not self.free_below <= self.occupied_above:
            raise ValueError(f"free_below {self.free_below} must not exceed occupied_above "
                             f"{self.occupied_above}")
        return self


def classify(prob: np.ndarray, config: CostmapConfig):
    """(free, occupied) (h, w) bool masks; cells in neither are unknown."""
    occupied = prob > config.occupied_above
    free = (prob < config.free_below) & ~occupied
    return free, occupied


def passable(prob: np.ndarray, resolution: float, radius: float, config: CostmapConfig,
             hits: np.ndarray | None = None, origin=(0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Where the robot's centre may go, and what a meter of path costs there.

    Args:
        prob: (h, w) occupancy probability; cell (0, 0)'s centre at ``origin`` (2,), meters.
        hits: (k, 2) the measured laser endpoints (m) the map was built from. Clearance is then
            measured to the points themselves; else to the occupied cells' edges, half a cell
            nearer than their centres (what made a cell occupied may lie anywhere in it), which
            can close a 0.75 m door to a 0.25 m robot.

    Returns:
        ok: (h, w) bool, known-free cells more than ``radius + margin`` meters from any
            obstacle and more than ``unknown_clearance`` from any unknown cell (off the map
            counts as unknown).
        cost: (h, w) ``wall_cost`` of each cell, for ``paths.distance_field``.
    """
    free, occupied = classify(prob, config)
    if hits is None:
        to_occupied = _distance_to(occupied, resolution) - resolution / 2
    else:
        to_occupied = np.zeros(prob.shape)
        iy, ix = np.nonzero(free)
        if len(hits):
            centres = np.asarray(origin, float) + resolution * np.column_stack([ix, iy])
            to_occupied[iy, ix] = cKDTree(hits).query(
                centres, distance_upper_bound=max(config.preferred_clearance, radius + config.margin))[0]
        else:
            to_occupied[iy, ix] = np.inf
    ok = (free & (to_occupied > radius + config.margin)
          & (_distance_to(~free & ~occupied, resolution) > config.unknown_clearance))
    return ok, wall_cost(to_occupied, radius, config)


def wall_cost(to_occupied: np.ndarray, radius: float, config: CostmapConfig) -> np.ndarray:
    """(h, w) cost per meter: 1 + ``near_wall_cost`` at ``radius + margin`` meters from an
    occupied cell, falling linearly to 1 at ``preferred_clearance``."""
    closest = radius + config.margin
    span = max(config.preferred_clearance - closest, 1e-9)
    return 1.0 + config.near_wall_cost * np.clip((config.preferred_clearance - to_occupied) / span, 0, 1)


def _distance_to(mask: np.ndarray, resolution: float) -> np.ndarray:
    """(h, w) meters from each cell centre to the nearest cell of ``mask`` (off the map counts)."""
    return ndimage.distance_transform_edt(np.pad(~mask, 1, constant_values=False),
                                          sampling=resolution)[1:-1, 1:-1]
