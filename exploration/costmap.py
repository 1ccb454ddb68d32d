"""Costmap for planning: where the robot's centre may go, derived from occupancy probabilities."""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from pydantic import BaseModel, ConfigDict, Field, model_validator


class CostmapConfig(BaseModel):
    """Thresholds that split a probability map into free, occupied and unknown cells."""

    model_config = ConfigDict(extra="forbid")

    free_below: float = Field(0.35, gt=0, lt=1, description="Λ below this is free")
    occupied_above: float = Field(0.65, gt=0, lt=1, description="Λ above this is occupied")
    obstacle_above: float = Field(
        0.6, gt=0, lt=1, description="Λo above this is occupied too: walls are weak in the fused Λ"
    )
    margin: float = Field(0.05, ge=0, description="meters of clearance added to the robot radius")
    unknown_clearance: float = Field(
        0.1, ge=0, description="meters the robot's centre keeps from unknown cells; occupied "
        "cells are kept at radius + margin. The COM leaves a band near walls unknown, so "
        "inflating unknown space by the full radius would close doors the robot fits through")

    @model_validator(mode="after")
    def _ordered(self):
        if not self.free_below <= self.occupied_above:
            raise ValueError(f"free_below {self.free_below} must not exceed occupied_above "
                             f"{self.occupied_above}")
        return self


def classify(prob: np.ndarray, config: CostmapConfig, prob_occ: np.ndarray | None = None):
    """(free, occupied) (h, w) bool masks; cells in neither are unknown."""
    occupied = prob > config.occupied_above
    if prob_occ is not None:
        occupied |= prob_occ > config.obstacle_above
    free = (prob < config.free_below) & ~occupied
    return free, occupied


def passable(prob: np.ndarray, resolution: float, radius: float, config: CostmapConfig,
             prob_occ: np.ndarray | None = None) -> np.ndarray:
    """(h, w) bool: known-free cells more than ``radius + margin`` meters from any occupied cell
    and more than ``unknown_clearance`` from any unknown one (off the map counts as unknown)."""
    free, occupied = classify(prob, config, prob_occ)

    def distance_to(mask):
        return ndimage.distance_transform_edt(np.pad(~mask, 1, constant_values=False),
                                              sampling=resolution)[1:-1, 1:-1]

    return (free & (distance_to(occupied) > radius + config.margin)
            & (distance_to(~free & ~occupied) > config.unknown_clearance))
