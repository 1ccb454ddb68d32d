"""The pose-graph back end on the standard 2-D graphs: χ² reached and time, against GTSAM's
default Levenberg–Marquardt (Cholesky, default tolerances) in the same run.

    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python benchmarks/bench_posegraph.py

χ² is g2o's (EdgeSE2: e = t2v(z⁻¹ x_i⁻¹ x_j)); "2·GTSAM" is twice GTSAM's graph error, which
uses the SE(2) logarithm instead of t2v. SOURCES.md lists minima computed with the translation
residual left in frame i (not rotated by z⁻¹): they coincide with g2o's only for isotropic
information matrices (M3500).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import gtsam  # noqa: E402

from sim.data import shared_data_dir  # noqa: E402
from slam.g2o import chi2, optimize, optimize_g2o, read_g2o  # noqa: E402

REFERENCE = {"sesync_CSAIL.g2o": 61.142973, "input_INTEL_g2o.g2o": 214.170856,
             "input_M3500_g2o.g2o": 137.912951}


def default_lm(graph):
    factors = graph.factor_graph()
    first = next(iter(graph.poses))
    factors.add(gtsam.PriorFactorPose2(first, graph.poses[first], gtsam.noiseModel.Constrained.All(3)))
    optimizer = gtsam.LevenbergMarquardtOptimizer(factors, graph.values(), gtsam.LevenbergMarquardtParams())
    return optimizer.optimize(), optimizer.iterations()


def main() -> None:
    data = shared_data_dir()
    if data is None:
        sys.exit("shared data not found: set GPEXPLORE_DATA")
    for name, reference in REFERENCE.items():
        graph = read_g2o(data / "posegraphs" / name)
        factors = graph.factor_graph()
        print(f"{name}: {len(graph.poses)} poses, {len(graph.edges)} edges, start χ² {chi2(graph, graph.poses):.6g}")
        tic = time.perf_counter()
        values, iterations = default_lm(graph)
        base = time.perf_counter() - tic
        print(f"  gtsam default LM       χ² {chi2(graph, values):14.6f}  2·GTSAM {2 * factors.error(values):14.6f}"
              f"  {iterations:5d} it  {base:6.2f} s")
        for method in ("lm", "dogleg"):
            tic = time.perf_counter()
            values, iterations = optimize(graph, method=method)
            wall = time.perf_counter() - tic
            print(f"  gtsam {method:<6} QR        χ² {chi2(graph, values):14.6f}  2·GTSAM "
                  f"{2 * factors.error(values):14.6f}  {iterations:5d} it  {wall:6.2f} s")
        tic = time.perf_counter()
        poses, iterations = optimize_g2o(graph)
        wall = time.perf_counter() - tic
        print(f"  posegraph (+exact LM)  χ² {chi2(graph, poses):14.6f}  {iterations:5d} it  {wall:6.2f} s "
              f"({wall / base:.1f}x default LM's time)")
        poses, _ = optimize_g2o(graph, rotated=False)
        found = chi2(graph, poses, rotated=False)
        print(f"  frame-i residual minimum {found:.6f} vs SOURCES.md {reference} "
              f"(relative difference {abs(found - reference) / reference:.1e})")

if __name__ == "__main__":
    main()
