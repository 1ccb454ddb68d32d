"""Held-out evaluation protocols of the GP-mapping literature on real logs.

Each scan's labelled points are hits (occupied) and free points along the beams; a fraction
is held out from training and the map is scored on them. ``points`` holds out individual
labelled points; ``beams`` holds out whole beams (their hit and all their free points), which
is harsher: no neighbour on the same beam was trained on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mapping.training import BeamSamples


@dataclass(frozen=True)
class Split:
    """One scan's training part and held-out labelled points (test_xy (k, 2), test_occ (k,))."""

    train: BeamSamples
    test_xy: np.ndarray
    test_occ: np.ndarray
    held_beams: np.ndarray  # (n_beams,) bool: beams whose hit is held out (or the whole beam)


def split(samples: BeamSamples, n_beams: int, fraction: float, protocol: str,
          rng: np.random.Generator) -> Split:
    """Hold out ``fraction`` of the labelled points (``protocol="points"``) or of the beams
    (``"beams"``) of one scan, drawing from ``rng``."""
    if not 0 <= fraction < 1:
        raise ValueError(f"hold-out fraction must be in [0, 1), got {fraction}")
    if protocol == "points":
        held_hit = rng.random(len(samples.hits)) < fraction
        held_free = rng.random(len(samples.free)) < fraction
        held_beams = np.zeros(n_beams, bool)
        held_beams[samples.hit_beam[held_hit]] = True
    elif protocol == "beams":
        held_beams = rng.random(n_beams) < fraction
        held_hit = held_beams[samples.hit_beam]
        held_free = held_beams[samples.free_beam]
    else:
        raise ValueError(f"unknown hold-out protocol '{protocol}' (have: points, beams)")
    test_xy = np.concatenate([samples.hits[held_hit], samples.free[held_free]])
    test_occ = np.concatenate([np.ones(held_hit.sum(), bool), np.zeros(held_free.sum(), bool)])
    return Split(samples.select(~held_hit, ~held_free), test_xy, test_occ, held_beams)
