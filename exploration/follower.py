"""Path following for a unicycle within its speed and turn-rate limits (pure pursuit)."""

from __future__ import annotations

import math
from collections.abc import Callable

import gtsam
import numpy as np
from pydantic import BaseModel, ConfigDict, Field


class FollowerConfig(BaseModel):
    """Pure-pursuit gains; the speed and turn-rate limits are the robot's."""

    model_config = ConfigDict(extra="forbid")

    lookahead: float = Field(0.4, gt=0, description="distance to the carrot point on the path, m")
    tolerance: float = Field(0.15, gt=0, description="the goal counts as reached within this, m")
    turn_in_place_deg: float = Field(45.0, gt=0, le=180, description="turn on the spot when the "
                                     "carrot is more than this off the heading, degrees")
    heading_gain: float = Field(2.0, gt=0, description="turn rate per radian of heading error, 1/s")
    max_shift: float = Field(0.1, ge=0, description="meters a carrot the robot cannot drive "
                             "straight to may be moved across the path to one it can (the "
                             "path through a door is as far off its middle as the pose and "
                             "the map are)")


class PathFollower:
    """Pure pursuit on a polyline path: steer to a point ``lookahead`` meters ahead on the path,
    or nearer where the robot could not drive straight to that point (a corner of the path
    through a narrow door: steering at a carrot past it cuts the corner into the door's jamb).

    The robot turns on the spot when the carrot is more than ``turn_in_place_deg`` off its
    heading, and slows down when turning hard, so it never cuts corners by much.

    Args:
        max_speed: m/s.
        max_turn_rate: rad/s.
        config: lookahead, goal tolerance, turn-in-place angle and heading gain.
    """

    def __init__(self, max_speed: float, max_turn_rate: float, config: FollowerConfig | None = None):
        if not (max_speed > 0 and max_turn_rate > 0):
            raise ValueError("speed and turn rate must be positive")
        self.max_speed = max_speed
        self.max_turn_rate = max_turn_rate
        self.config = config or FollowerConfig()

    def command(self, pose: gtsam.Pose2, path: np.ndarray,
                clear: Callable[[np.ndarray], bool] | None = None) -> tuple[float, float, bool]:
        """(v, w, reached) for the robot at ``pose`` following ``path`` (k, 2), in m/s, rad/s.
        ``clear(p)`` says whether the robot may drive straight to the point ``p`` (2,) in its
        own frame (m): the carrot is the first of ``_clear_carrots`` (the carrot itself when it
        is clear), else it stays (in a passage barely wider than the robot no straight drive may
        keep the guard's clearance, and a near carrot would only turn the robot on the spot);
        None: every point is."""
        path = np.asarray(path, dtype=float).reshape(-1, 2)
        here = np.array([pose.x(), pose.y()])
        if np.linalg.norm(path[-1] - here) < self.config.tolerance:
            return 0.0, 0.0, True
        local = np.asarray(pose.transformTo(gtsam.Point2(*self._carrot(here, path, self.config.lookahead))))
        if clear is not None:
            local = next(self._clear_carrots(pose, here, path, clear), local)
        bearing = math.atan2(local[1], local[0])
        w = float(np.clip(self.config.heading_gain * bearing, -self.max_turn_rate, self.max_turn_rate))
        if abs(bearing) > math.radians(self.config.turn_in_place_deg):
            return 0.0, w, False
        distance = float(np.linalg.norm(path[-1] - here))
        v = min(self.max_speed, distance) * math.cos(bearing)
        return v, w, False

    def _clear_carrots(self, pose: gtsam.Pose2, here: np.ndarray, path: np.ndarray,
                       clear: Callable[[np.ndarray], bool]):
        """The carrots, in the robot's frame, that ``clear`` accepts: at a lookahead, a half, a
        quarter and an eighth of it on the path, farthest first, each where it is or moved
        sideways (across the line to it) by up to ``max_shift``, least first (the live scan
        shows the middle of a door the path passes a few centimetres off)."""
        shifts = np.linspace(0.0, self.config.max_shift, 6)
        shifts = np.concatenate([[0.0], np.column_stack([shifts[1:], -shifts[1:]]).ravel()])
        for lookahead in self.config.lookahead / np.array([1.0, 2.0, 4.0, 8.0]):
            carrot = self._carrot(here, path, lookahead)
            along = carrot - here
            norm = float(np.linalg.norm(along))
            if norm == 0.0:
                continue
            across = np.array([-along[1], along[0]]) / norm
            for shift in shifts:
                local = np.asarray(pose.transformTo(gtsam.Point2(*(carrot + shift * across))))
                if clear(local):
                    yield local

    @staticmethod
    def remaining(pose: gtsam.Pose2, path: np.ndarray) -> float:
        """Meters left to go: to the closest point of ``path`` (k, 2), then along it to its end.
        Unlike the straight-line distance to the goal, it shrinks on a path that detours."""
        here = np.array([pose.x(), pose.y()])
        rest = rest_of_path(here, np.asarray(path, dtype=float).reshape(-1, 2))
        return float(np.linalg.norm(rest[0] - here) + np.linalg.norm(np.diff(rest, axis=0), axis=1).sum())

    @staticmethod
    def _carrot(here: np.ndarray, path: np.ndarray, lookahead: float) -> np.ndarray:
        """The first point on the path, after the point closest to the robot, ``lookahead`` away."""
        if len(path) == 1:
            return path[0]
        remaining = rest_of_path(here, path)
        for p, q in zip(remaining[:-1], remaining[1:]):
            # the point on segment pq at distance lookahead from here, if any
            d = q - p
            f = p - here
            qa, qb, qc = d @ d, 2 * f @ d, f @ f - lookahead**2
            disc = qb * qb - 4 * qa * qc
            if qa > 0 and disc >= 0:
                s = (-qb + math.sqrt(disc)) / (2 * qa)
                if 0.0 <= s <= 1.0:
                    return p + s * d
        return path[-1]


def rest_of_path(here: np.ndarray, path: np.ndarray) -> np.ndarray:
    """The path (k, 2) from its point closest to ``here`` (2,) on: that point, then the vertices
    after it."""
    if len(path) == 1:
        return path
    a, b = path[:-1], path[1:]
    ab = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12)
    t = np.clip(np.einsum("ij,ij->i", here - a, ab) / length2, 0.0, 1.0)
    nearest = a + t[:, None] * ab
    k = int(np.argmin(np.linalg.norm(nearest - here, axis=1)))
    return np.vstack([nearest[k], path[k + 1:]])
