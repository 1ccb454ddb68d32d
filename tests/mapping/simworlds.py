"""Small simulated worlds for the mapping tests (imported by the tests and by conftest)."""

import gtsam
import numpy as np

from sim.lidar import Lidar
from sim.world import World
from sim.worlds import BUILTIN_WORLDS


def corridor_world() -> World:
    """14 m x 4 m: a 2 m wide corridor along x (y in [1, 3]) between 1 m thick walls."""
    res = 0.05
    occ = np.ones((80, 280), bool)
    occ[20:60, 20:260] = False
    return World(occ, (res, res), name="corridor")


def room_world() -> World:
    """10 m x 8 m room (walls 0.5 m) with a 2 m x 1.5 m box in the middle (the built-in
    ``room``)."""
    return BUILTIN_WORLDS["room"]().world


def scans_at(world: World, poses: list[gtsam.Pose2], seed: int = 0):
    lidar = Lidar(seed=seed)
    return [lidar.scan(world, p, float(i)) for i, p in enumerate(poses)]


def corridor_pass() -> tuple[list[gtsam.Pose2], list[gtsam.Pose2]]:
    """Sensor poses every 0.5 m down the corridor's middle, looking along it, and the same
    with the last three off by (0.3 m, 0.1 m, 0.05 rad), as before a loop closure moves them."""
    poses = [gtsam.Pose2(x, 2.0, 0.0) for x in np.arange(1.5, 12.6, 0.5)]
    return poses, poses[:-3] + [gtsam.Pose2(0.3, 0.1, 0.05).compose(p) for p in poses[-3:]]


def room_tour() -> list[gtsam.Pose2]:
    """16 sensor poses on a loop around the box, looking along the loop and outward."""
    poses = []
    for k in range(16):
        a = 2 * np.pi * k / 16
        x, y = 5 + 3.4 * np.cos(a), 4 + 2.6 * np.sin(a)
        poses.append(gtsam.Pose2(x, y, a + np.pi / 2 + (0.6 if k % 2 else -0.6)))
    return poses


