"""Correlative scan matching on Intel scan pairs with 1.5 m / 20° initial errors: success, time per
match and nodes visited by branch and bound, against the brute-force search of the same lattice and
against KISS-ICP + point-to-line registration from the same guesses, same run.

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_correlative.py [--stride 3]

Pairs are consecutive scans (i - 1, i) of intel-corrected.log.gz (0.7 m and 22° apart, median); the
truth is GMapping's corrected poses (good to a couple of cm). The reference is scan i - 1 alone, in
its frame; the guess is the truth moved 1.5 m in a random direction and turned ±20°. Success is
within 5 cm and 1° of the truth; since the truth itself is only that good, the ceiling is printed:
point-to-line registration started *at* the truth, within 5 cm / 1° of it.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import gtsam
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sim.data import benchmark_data_dir  # noqa: E402
from slam.carmen import CarmenLog  # noqa: E402
from slam.config import RegistrationConfig  # noqa: E402
from slam.config import CorrelativeConfig  # noqa: E402
from slam.correlative import CorrelativeGrid, match, match_exhaustive  # noqa: E402
from slam.registration import Registration, Submap, scan_normals, transform  # noqa: E402


def error(truth: gtsam.Pose2, pose: gtsam.Pose2) -> tuple[float, float]:
    """(m, deg) between two poses."""
    e = truth.between(pose)
    return math.hypot(e.x(), e.y()), abs(math.degrees(e.theta()))


def rate(errors: np.ndarray, meters: float = 0.05, degrees: float = 1.0) -> str:
    ok = (errors[:, 0] < meters) & (errors[:, 1] < degrees)
    gross = (errors[:, 0] > 0.2) | (errors[:, 1] > 3.0)
    return f"{100 * ok.mean():5.1f} % within 5 cm / 1°, {100 * gross.mean():4.1f} % off by > 20 cm or 3°"


def ms(times) -> str:
    t = 1e3 * np.asarray(times)
    return f"median {np.median(t):7.2f} ms, p95 {np.percentile(t, 95):7.2f} ms"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stride", type=int, default=3, help="every stride-th scan pair")
    parser.add_argument("--brute", type=int, default=6, help="pairs also searched by brute force")
    parser.add_argument("--reference-scans", type=int, default=1,
                        help="scans i-1, i-2, ... in the reference (a small submap in the frame of i-1)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    data = benchmark_data_dir()
    log = CarmenLog(data / "logs" / "intel-corrected.log.gz")
    config = CorrelativeConfig()
    rconfig = RegistrationConfig()
    registration = Registration(rconfig)
    converged = Registration(rconfig.model_copy(update={"refine_iterations": 30}))
    rng = np.random.default_rng(args.seed)
    xy = np.array([[r.pose.x(), r.pose.y()] for r in log])

    warm = CorrelativeGrid(log[0].scan.points(), config)                  # numba compile / cache load
    match(warm, log[1].scan.points(), gtsam.Pose2(), config)
    match_exhaustive(warm, log[1].scan.points(), gtsam.Pose2(), config.model_copy(update={"window_xy": 0.1}))

    k = args.reference_scans
    pairs = [i for i in range(k, len(log), args.stride) if len(log[i].scan.points()) >= config.min_points]
    build, times, nodes, steps, scores = [], [], [], [], []
    lattice, refined, icp, ceiling, basin = [], [], [], [], []
    unrelated, brute = [], []
    for n, i in enumerate(pairs):
        reference, scan = log[i - 1], log[i]
        ref_points = np.concatenate([transform(reference.pose.between(log[i - j].pose), log[i - j].scan.points())
                                     for j in range(1, k + 1)])
        points = scan.scan.points()
        truth = reference.pose.between(scan.pose)
        phi, turn = rng.uniform(0, 2 * math.pi), rng.choice([-1.0, 1.0]) * math.radians(20.0)
        guess = gtsam.Pose2(truth.x() + 1.5 * math.cos(phi), truth.y() + 1.5 * math.sin(phi), truth.theta() + turn)

        tic = time.perf_counter()
        grid = CorrelativeGrid(ref_points, config)
        build.append(time.perf_counter() - tic)
        tic = time.perf_counter()
        result = match(grid, points, guess, config.model_copy(update={"min_score": 0.0}))
        times.append(time.perf_counter() - tic)
        nodes.append(result.nodes)
        steps.append(result.angular_step)
        scores.append(result.score)
        lattice.append(error(truth, result.pose))

        submap = Submap.from_scans([gtsam.Pose2()], [ref_points], [scan_normals(ref_points, rconfig)],
                                   rconfig)
        from_match = registration.refine(points, submap, result.pose).pose
        from_truth = registration.refine(points, submap, truth).pose
        refined.append(error(truth, from_match))
        icp.append(error(truth, registration.register(points, submap, guess).pose))
        ceiling.append(error(truth, from_truth))
        basin.append(error(converged.refine(points, submap, truth).pose,
                           converged.refine(points, submap, result.pose).pose))

        far = np.flatnonzero(np.hypot(*(xy - xy[i]).T) > 8.0)           # a scan of another place
        other = log[int(rng.choice(far))].scan.points()
        unrelated.append(match(grid, other, guess, config.model_copy(update={"min_score": 0.0})).score)

        if n < args.brute:
            tic = time.perf_counter()
            exhaustive = match_exhaustive(grid, points, guess, config.model_copy(update={"min_score": 0.0}))
            brute.append((time.perf_counter() - tic, exhaustive.nodes, times[-1], nodes[-1],
                          exhaustive.pose.equals(result.pose, 1e-12) and abs(exhaustive.score - result.score) < 1e-9))

    lattice, refined, icp, ceiling, basin = map(np.array, (lattice, refined, icp, ceiling, basin))
    same_basin = np.mean((basin[:, 0] < 0.01) & (basin[:, 1] < 0.1))
    print(f"intel-corrected.log.gz: {len(pairs)} scan pairs (stride {args.stride}), reference {k} scan(s), "
          f"initial error 1.5 m / 20°, "
          f"window ±{config.window_xy} m / ±{config.window_deg}°, {config.resolution} m cells, "
          f"σ {config.likelihood_sigma} m, {config.levels} levels")
    print(f"angular step: median {math.degrees(np.median(steps)):.3f}°, "
          f"{np.median([2 * math.ceil(math.radians(config.window_deg) / s) + 1 for s in steps]):.0f} rotations")
    print(f"correlative (lattice pose):        {rate(lattice)}")
    print(f"correlative + point-to-line:       {rate(refined)}")
    print(f"baseline KISS-ICP + point-to-line: {rate(icp)}")
    print(f"ceiling, point-to-line from truth: {rate(ceiling)}")
    print(f"same basin as the truth (point-to-line run to convergence from the match ends within 1 cm / 0.1° "
          f"of the same from the truth; GMapping's error plays no part): {100 * same_basin:.1f} %")
    print(f"lattice error: median {1e2 * np.median(lattice[:, 0]):.1f} cm, {np.median(lattice[:, 1]):.2f}°; "
          f"p90 {1e2 * np.percentile(lattice[:, 0], 90):.1f} cm, {np.percentile(lattice[:, 1], 90):.2f}°")
    print(f"score: true pairs median {np.median(scores):.2f}, unrelated scans (> 8 m away) median "
          f"{np.median(unrelated):.2f}; accepted true / unrelated at min_score " + ", ".join(
              f"{t:.2f}: {100 * np.mean(np.array(scores) >= t):.1f} / {100 * np.mean(np.array(unrelated) >= t):.1f} %"
              for t in (0.45, 0.5, 0.55, 0.6, 0.65)) + f" (default {config.min_score})")
    print(f"branch and bound: {ms(times)}; nodes median {np.median(nodes):.0f}, p95 {np.percentile(nodes, 95):.0f}")
    if brute:
        b = np.array(brute)
        print(f"brute force on {len(b)} pairs: {ms(b[:, 0])}; {np.median(b[:, 1]):.0f} poses; "
              f"same pose and score as branch and bound: {int(b[:, 4].sum())}/{len(b)}")
        print(f"  time ratio brute force / branch and bound: {np.median(b[:, 0] / b[:, 2]):.0f}x (median), "
              f"poses / nodes {np.median(b[:, 1] / b[:, 3]):.0f}x")
    print(f"grid build, reference of {k} scan(s): {ms(build)}")
    for count in (10, 30):
        pts = np.concatenate([transform(log[0].pose.between(log[k].pose), log[k].scan.points()) for k in range(count)])
        tic = time.perf_counter()
        grid = CorrelativeGrid(pts, config)
        print(f"grid build, {count}-scan submap: {1e3 * (time.perf_counter() - tic):7.2f} ms, "
              f"{grid.shape[0]} x {grid.shape[1]} cells, {grid.precomputed.nbytes / 1e6:.1f} MB")

    sweep = pairs[::4]
    print(f"levels (every 4th pair, {len(sweep)}): ", end="")
    for levels in range(3, 9):
        c = config.model_copy(update={"levels": levels, "min_score": 0.0})
        t, v = [], []
        for i in sweep:
            reference, scan = log[i - 1], log[i]
            grid = CorrelativeGrid(reference.scan.points(), c)
            truth = reference.pose.between(scan.pose)
            guess = gtsam.Pose2(truth.x() + 1.5, truth.y(), truth.theta() + math.radians(20.0))
            tic = time.perf_counter()
            v.append(match(grid, scan.scan.points(), guess, c).nodes)
            t.append(time.perf_counter() - tic)
        print(f"{levels}: {np.median(v):.0f} nodes {1e3 * np.median(t):.1f} ms", end="; " if levels < 8 else "\n")


if __name__ == "__main__":
    main()
