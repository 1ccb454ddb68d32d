"""Scans per second of the compiled ray caster against a naive per-beam Python loop, same run.

    python benchmarks/bench_lidar.py [--beams 360] [--max-range 8]

Setup from the foundation issue: a 20 m x 20 m world (the built-in cave) on a 0.05 m grid,
360 beams over 360 degrees, 8 m max range, from random free poses.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from sim.raycast import cast_rays
from sim.world import World
from sim.worlds import cave


def naive_scan(world: World, xy, angles, max_range: float) -> np.ndarray:
    """The same cell traversal, one beam at a time in plain Python."""
    (x0, y0), (rx, ry) = world.origin, world.resolution
    h, w = world.shape
    out = np.empty(len(angles))
    for k, a in enumerate(angles):
        dx, dy = math.cos(a), math.sin(a)
        gx, gy = (xy[0] - x0) / rx, (xy[1] - y0) / ry
        ix, iy = math.floor(gx), math.floor(gy)
        sx, sy = (1 if dx > 0 else -1), (1 if dy > 0 else -1)
        tx = ((ix + (dx > 0)) - gx) * rx / dx if dx else math.inf
        ty = ((iy + (dy > 0)) - gy) * ry / dy if dy else math.inf
        ddx = rx / abs(dx) if dx else math.inf
        ddy = ry / abs(dy) if dy else math.inf
        t, hit = 0.0, math.inf
        while t < max_range:
            if not (0 <= ix < w and 0 <= iy < h) or world.occupied[iy, ix]:
                hit = t
                break
            if tx < ty:
                t, tx, ix = tx, tx + ddx, ix + sx
            else:
                t, ty, iy = ty, ty + ddy, iy + sy
        out[k] = hit if hit < max_range else math.inf
    return out


def rate(fn, poses, angles, max_range, seconds=1.0):
    n, tic = 0, time.perf_counter()
    while time.perf_counter() - tic < seconds:
        fn(poses[n % len(poses)], angles + poses[n % len(poses)][2], max_range)
        n += 1
    return n / (time.perf_counter() - tic)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--beams", type=int, default=360)
    parser.add_argument("--max-range", type=float, default=8.0)
    args = parser.parse_args()
    world = cave().world
    rng = np.random.default_rng(0)
    xy = rng.uniform(1, 19, (4000, 2))
    xy = xy[world.clearance_at(xy) > 0.3][:200]
    poses = np.column_stack([xy, rng.uniform(-np.pi, np.pi, len(xy))])
    angles = np.linspace(-np.pi, np.pi, args.beams, endpoint=False)
    for pose in poses:  # same answers
        np.testing.assert_allclose(cast_rays(world, pose[:2], angles, args.max_range),
                                   naive_scan(world, pose[:2], angles, args.max_range), atol=1e-9)
    fast = rate(lambda p, a, r: cast_rays(world, p[:2], a, r), poses, angles, args.max_range)
    slow = rate(lambda p, a, r: naive_scan(world, p[:2], a, r), poses, angles, args.max_range)
    print(f"world {world.name} {world.size[0]:.0f} x {world.size[1]:.0f} m, "
          f"{world.resolution[0]} m cells, {args.beams} beams, {args.max_range} m range")
    print(f"compiled ray caster: {fast:10.0f} scans/s  ({1e3 / fast:.3f} ms per scan)")
    print(f"naive Python loop:   {slow:10.1f} scans/s  ({1e3 / slow:.1f} ms per scan)")
    print(f"ratio: {fast / slow:.0f}x")


if __name__ == "__main__":
    main()
