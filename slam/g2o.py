"""2-D pose graphs in the g2o format: read, write, χ² and Levenberg–Marquardt optimisation.

``VERTEX_SE2 id x y θ`` and ``EDGE_SE2 i j dx dy dθ I11 I12 I13 I22 I23 I33`` (the measurement of
pose j in the frame of pose i and the upper triangle of its information matrix Ω, in (x, y, θ)
order). The g2o cost is χ² = Σ eᵀ Ω e with g2o's error e = t2v(z⁻¹·(x_i⁻¹·x_j)); GTSAM's
``graph.error`` is ½ Σ Log(z⁻¹·x_i⁻¹·x_j)ᵀ Ω Log(·), which agrees with χ²/2 up to the difference
between t2v and the SE(2) logarithm (second order in the residual angle).
"""

from __future__ import annotations

from collections import defaultdict, deque
from dataclasses import dataclass, field
from pathlib import Path

import gtsam
import numpy as np

from slam.atomic import write_text_atomic
from slam.poses import pose_array
from slam.text import read_text


class G2oFormatError(ValueError):
    """A malformed g2o file; the message names the file and line."""


@dataclass
class PoseGraph2D:
    """A 2-D pose graph: poses keyed by integer id and relative-pose edges with information.

    Attributes:
        poses: id -> initial pose (from VERTEX_SE2 lines or composed along a spanning tree).
        edges: (i, j, measurement, Ω (3, 3)) in file order.
        warnings: what the reader found suspicious, each naming the file and line.
    """

    poses: dict[int, gtsam.Pose2] = field(default_factory=dict)
    edges: list[tuple[int, int, gtsam.Pose2, np.ndarray]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def factor_graph(self) -> gtsam.NonlinearFactorGraph:
        """The between factors (Gaussian noise from Ω), without a prior: the gauge stays free."""
        graph = gtsam.NonlinearFactorGraph()
        for i, j, z, info in self.edges:
            graph.add(gtsam.BetweenFactorPose2(i, j, z, gtsam.noiseModel.Gaussian.Information(info)))
        return graph

    def values(self) -> gtsam.Values:
        """The initial poses as GTSAM values."""
        return self.values_of(self.poses)

    @staticmethod
    def values_of(poses: dict[int, gtsam.Pose2]) -> gtsam.Values:
        values = gtsam.Values()
        for key, pose in poses.items():
            values.insert(key, pose)
        return values


def read_g2o(path: str | Path) -> PoseGraph2D:
    """Read VERTEX_SE2/EDGE_SE2 lines (other tags are skipped); missing vertices are initialised
    by composing edges along a breadth-first spanning tree from the lowest id. In a file that
    declares vertices, an edge to a vertex no VERTEX_SE2 line declares is a warning
    (``PoseGraph2D.warnings``, naming the edge's line).

    Raises:
        G2oFormatError: the file cannot be read, a line is malformed (the file and line named),
            there are no edges, or the graph is not connected.
    """
    path = Path(path)
    graph = PoseGraph2D()
    text = read_text(path, G2oFormatError)
    first_use: dict[int, int] = {}                  # vertex id -> first edge line naming it
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        tag = fields[0]
        try:
            if tag == "VERTEX_SE2":
                if len(fields) < 5:
                    raise ValueError(f"VERTEX_SE2 line has {len(fields)} fields, expected 5")
                v = _finite(fields[2:5], "VERTEX_SE2")
                graph.poses[_vertex_id(fields[1])] = gtsam.Pose2(*v)
            elif tag == "EDGE_SE2":
                if len(fields) != 12:
                    raise ValueError(f"EDGE_SE2 line has {len(fields)} fields, expected 12")
                i, j = _vertex_id(fields[1]), _vertex_id(fields[2])
                if i == j:
                    raise ValueError(f"EDGE_SE2 {i}->{j} joins a vertex to itself")
                v = _finite(fields[3:12], "EDGE_SE2")
                a, b, c, d, e, g = v[3:]
                info = np.array([[a, b, c], [b, d, e], [c, e, g]])
                eigenvalues = np.linalg.eigvalsh(info)
                if not np.all(np.isfinite(eigenvalues)) or np.any(eigenvalues <= 0):
                    raise ValueError(f"EDGE_SE2 {i}->{j} information matrix is not positive definite")
                graph.edges.append((i, j, gtsam.Pose2(*v[:3]), info))
                first_use.setdefault(i, number)
                first_use.setdefault(j, number)
        except ValueError as err:
            raise G2oFormatError(f"{path}:{number}: {err}") from None
    if not graph.edges:
        raise G2oFormatError(f"{path}: no EDGE_SE2 lines: not a 2-D g2o pose graph")
    undeclared = sorted(first_use.keys() - graph.poses.keys(), key=first_use.get)
    if graph.poses and undeclared:
        k = undeclared[0]
        more = f" (and {len(undeclared) - 1} more)" if len(undeclared) > 1 else ""
        graph.warnings.append(f"{path}:{first_use[k]}: an edge refers to vertex {k}, which no VERTEX_SE2 line "
                              f"declares{more}; its pose is composed along the edges")
    _initialise_missing(graph, path)
    return graph


def _vertex_id(text: str) -> int:
    """A vertex id: an integer GTSAM can key (0 <= id < 2**63)."""
    try:
        key = int(text)
    except ValueError:
        raise ValueError(f"vertex id {text!r} is not an integer") from None
    if not 0 <= key < 2 ** 63:
        raise ValueError(f"vertex id {key} is out of range (0 to 2**63 - 1)")
    return key


def _finite(fields: list[str], tag: str) -> np.ndarray:
    """The numbers of a line; ValueError for a non-numeric or non-finite one."""
    try:
        values = np.array([float(f) for f in fields])
    except ValueError:
        raise ValueError(f"{tag} line has a non-numeric field") from None
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{tag} line has a non-finite value")
    return values


def _initialise_missing(graph: PoseGraph2D, path: Path) -> None:
    nodes = {k for i, j, _, _ in graph.edges for k in (i, j)}
    if nodes <= graph.poses.keys():
        return
    adjacency = defaultdict(list)
    for i, j, z, _ in graph.edges:
        adjacency[i].append((j, z))
        adjacency[j].append((i, z.inverse()))
    known = dict(graph.poses)
    roots = sorted(known) or [min(nodes)]
    known.setdefault(roots[0], gtsam.Pose2())
    queue = deque(roots)
    while queue:
        i = queue.popleft()
        for j, z in adjacency[i]:
            if j not in known:
                known[j] = known[i].compose(z)
                queue.append(j)
    missing = nodes - known.keys()
    if missing:
        raise G2oFormatError(f"{path}: graph is not connected: {len(missing)} poses unreachable "
                             f"from pose {roots[0]} (e.g. {min(missing)})")
    graph.poses = dict(sorted(known.items()))


def write_g2o(path: str | Path, poses: dict[int, gtsam.Pose2],
              edges: list[tuple[int, int, gtsam.Pose2, np.ndarray]]) -> None:
    """Write VERTEX_SE2 and EDGE_SE2 lines, atomically."""
    rows = [f"VERTEX_SE2 {k} {p.x():.9g} {p.y():.9g} {p.theta():.9g}" for k, p in poses.items()]
    for i, j, z, info in edges:
        upper = info[np.triu_indices(3)]
        rows.append(f"EDGE_SE2 {i} {j} {z.x():.9g} {z.y():.9g} {z.theta():.9g} "
                    + " ".join(f"{v:.9g}" for v in upper))
    write_text_atomic(path, "".join(r + "\n" for r in rows))


def chi2(graph: PoseGraph2D, poses: dict[int, gtsam.Pose2] | gtsam.Values, rotated: bool = True) -> float:
    """g2o's χ² = Σ eᵀ Ω e, e = t2v(z⁻¹·(x_i⁻¹·x_j)) = (R_zᵀ(R_iᵀ(t_j − t_i) − t_z), wrap(θ_j − θ_i − θ_z)).

    The translation residual is rotated into the measurement's frame, as in g2o's EdgeSE2: with
    anisotropic Ω this matters (without the rotation the minimum of Carlone's INTEL moves).
    ``rotated=False`` leaves it in frame i (the definition under which the data's reference
    minima were computed).
    """
    if isinstance(poses, gtsam.Values):
        poses = {k: poses.atPose2(k) for k in graph.poses}
    index = {k: n for n, k in enumerate(poses)}
    xyt = pose_array(poses.values())
    i = np.array([index[e[0]] for e in graph.edges])
    j = np.array([index[e[1]] for e in graph.edges])
    z = pose_array(e[2] for e in graph.edges)
    info = np.array([e[3] for e in graph.edges])
    c, s = np.cos(xyt[i, 2]), np.sin(xyt[i, 2])
    dx, dy = xyt[j, 0] - xyt[i, 0], xyt[j, 1] - xyt[i, 1]
    ex, ey = c * dx + s * dy - z[:, 0], -s * dx + c * dy - z[:, 1]
    cz, sz = (np.cos(z[:, 2]), np.sin(z[:, 2])) if rotated else (1.0, 0.0)
    err = np.column_stack([cz * ex + sz * ey, -sz * ex + cz * ey,
                           np.angle(np.exp(1j * (xyt[j, 2] - xyt[i, 2] - z[:, 2])))])
    return float(np.einsum("ni,nij,nj->", err, info, err))


def optimize(graph: PoseGraph2D, max_iterations: int = 3000, relative_tolerance: float = 1e-12,
             method: str = "dogleg") -> tuple[gtsam.Values, int]:
    """GTSAM's Powell dog-leg (``method="dogleg"``) or Levenberg–Marquardt (``"lm"``) from the
    graph's initial poses, the first pose held fixed.

    Both factorise the Jacobian by QR rather than JᵀJ by Cholesky, which stays accurate on the
    ill-conditioned information matrices of real benchmark graphs (Carlone's INTEL: Cholesky LM
    stops at once; QR LM needs ~1300 iterations, dog-leg ~20). Returns the values and iterations.
    """
    factors = graph.factor_graph()
    first = next(iter(graph.poses))
    factors.add(gtsam.PriorFactorPose2(first, graph.poses[first],
                                       gtsam.noiseModel.Constrained.All(3)))
    if method == "dogleg":
        params = gtsam.DoglegParams()
    elif method == "lm":
        params = gtsam.LevenbergMarquardtParams.CeresDefaults()
    else:
        raise ValueError(f"unknown method {method!r}: dogleg or lm")
    params.setMaxIterations(max_iterations)
    params.setRelativeErrorTol(relative_tolerance)
    params.setAbsoluteErrorTol(0.0)
    params.setLinearSolverType("MULTIFRONTAL_QR")
    if method == "dogleg":
        optimizer = gtsam.DoglegOptimizer(factors, graph.values(), params)
    else:
        optimizer = gtsam.LevenbergMarquardtOptimizer(factors, graph.values(), params)
    result = optimizer.optimize()
    return result, optimizer.iterations()


def optimize_g2o(graph: PoseGraph2D, method: str = "dogleg", rotated: bool = True
                 ) -> tuple[dict[int, gtsam.Pose2], int]:
    """GTSAM's optimum (``optimize``) polished by Levenberg–Marquardt on g2o's exact χ²
    (``refine_g2o``); returns the poses and the total number of iterations."""
    values, iterations = optimize(graph, method=method)
    poses, more = refine_g2o(graph, {k: values.atPose2(k) for k in graph.poses}, rotated=rotated)
    return poses, iterations + more


def _residuals(xyt: np.ndarray, i: np.ndarray, j: np.ndarray, z: np.ndarray, upper: np.ndarray,
               rotated: bool = True):
    """Whitened g2o residuals (3m,) and their sparse Jacobian (3m, 3n) for (n, 3) poses."""
    from scipy.sparse import csr_matrix

    c, s = np.cos(xyt[i, 2]), np.sin(xyt[i, 2])
    dx, dy = xyt[j, 0] - xyt[i, 0], xyt[j, 1] - xyt[i, 1]
    ex, ey = c * dx + s * dy - z[:, 0], -s * dx + c * dy - z[:, 1]
    # d(R_iᵀ(t_j − t_i))/dθ_i
    gx, gy = -s * dx + c * dy, -c * dx - s * dy
    m = len(i)
    a = np.zeros((m, 3, 6))     # de/d(x_i, y_i, θ_i, x_j, y_j, θ_j), before rotation by R_zᵀ
    a[:, 0, 0], a[:, 0, 1], a[:, 1, 0], a[:, 1, 1] = -c, -s, s, -c
    a[:, 0, 3], a[:, 0, 4], a[:, 1, 3], a[:, 1, 4] = c, s, -s, c
    a[:, 0, 2], a[:, 1, 2] = gx, gy
    a[:, 2, 2], a[:, 2, 5] = -1.0, 1.0
    e = np.column_stack([ex, ey, np.angle(np.exp(1j * (xyt[j, 2] - xyt[i, 2] - z[:, 2])))])
    if rotated:
        cz, sz = np.cos(z[:, 2]), np.sin(z[:, 2])
        rz = np.zeros((m, 3, 3))
        rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = cz, sz, -sz, cz, 1.0
        e = np.einsum("mab,mb->ma", rz, e)
        a = np.einsum("mab,mbc->mac", rz, a)
    r = np.einsum("mab,mb->ma", upper, e).ravel()
    jac = np.einsum("mab,mbc->mac", upper, a)
    rows = np.repeat(np.arange(3 * m).reshape(m, 3), 6, axis=1).ravel()
    cols = np.concatenate([3 * i[:, None] + np.arange(3), 3 * j[:, None] + np.arange(3)], axis=1)
    cols = np.repeat(cols[:, None, :], 3, axis=1).ravel()
    return r, csr_matrix((jac.ravel(), (rows, cols)), shape=(3 * m, 3 * len(xyt)))


def refine_g2o(graph: PoseGraph2D, poses: dict[int, gtsam.Pose2], max_iterations: int = 200,
               rotated: bool = True) -> tuple[dict[int, gtsam.Pose2], int]:
    """Levenberg–Marquardt on g2o's exact χ² (additive (x, y, θ) updates as g2o's VertexSE2), the
    first pose fixed, from ``poses``: polishes GTSAM's optimum, whose SE(2)-logarithm error
    differs from g2o's t2v error where Ω is extreme. ``rotated=False`` leaves the translation
    residual in frame i (the definition under which the data's reference minima were computed)."""
    from scipy.sparse import diags
    from scipy.sparse.linalg import spsolve

    keys = list(poses)
    index = {k: n for n, k in enumerate(keys)}
    xyt = pose_array(poses.values())
    i = np.array([index[e[0]] for e in graph.edges])
    j = np.array([index[e[1]] for e in graph.edges])
    z = pose_array(e[2] for e in graph.edges)
    upper = np.linalg.cholesky(np.array([e[3] for e in graph.edges])).transpose(0, 2, 1)
    free = np.arange(3, 3 * len(keys))
    r, jac = _residuals(xyt, i, j, z, upper, rotated)
    cost, damping, iterations = r @ r, 1e-6, 0
    for iterations in range(1, max_iterations + 1):
        jf = jac[:, free]
        h = (jf.T @ jf).tocsc()
        g = jf.T @ r
        improved = False
        while damping < 1e12:
            step = spsolve(h + diags(damping * h.diagonal() + 1e-12), -g)
            trial = xyt.copy()
            trial.ravel()[free] += step
            r_new, jac_new = _residuals(trial, i, j, z, upper, rotated)
            if r_new @ r_new < cost:
                improved = True
                break
            damping *= 10
        if not improved:
            break
        relative = (cost - r_new @ r_new) / cost
        xyt, r, jac, cost = trial, r_new, jac_new, r_new @ r_new
        damping = max(damping / 10, 1e-12)
        if relative < 1e-12:
            break
    return {k: gtsam.Pose2(*row) for k, row in zip(keys, xyt)}, iterations
