"""Loop closures: verification in twin rooms (a false loop rejected, a true one recovered, a
biased one caught by the reverse registration), a loop slid along the built-in office's corridor
(the scan observes no surface across it), a scan that fits two places along a corridor of
doorways, the Mahalanobis gate and pending loops of Pose SLAM, the Cauchy-robust loop factor,
and pairwise consistency of two loops.

Scans are cast exactly (no range noise) from true poses into axis-aligned walls; the pose graph
holds the *believed* poses, whose links are exact except where a drift is put in on purpose. A
correct registration therefore lands on the truth to about its convergence step (1e-4 m, rad),
while every wrong answer here (the graph's prediction, the twin room) is ≥ 0.17 m or ≥ 6° off.
"""

import math
import warnings
from dataclasses import replace

import gtsam
import numpy as np
import pytest

from slam.back_end import PoseGraph
from slam.config import CorrelativeConfig, LoopClosureConfig, RegistrationConfig, SlamConfig
from slam.localiser import Localisation
from slam.loop_closure import Candidate, LoopClosureDetector
from slam.pose_slam import PoseSlam
from slam.registration import scan_normals
from sim.tour import demo_tour
from sim.worlds import BUILTIN_WORLDS
from wall_scans import cast

TOL_XY, TOL_THETA = 2e-3, math.radians(0.02)     # m, rad: exact scans leave only the 1e-4 steps
LINK_SIGMA = np.array([0.02, 0.02, 0.005])        # m, m, rad: one keyframe link of the graph


def box(x0, y0, x1, y1):
    return [(0, x0, y0, y1), (0, x1, y0, y1), (1, y0, x0, x1), (1, y1, x0, x1)]


def room(x0: float):
    """A 6 m × 5 m room at x0: a 2.4 m door in its east wall, a pillar and a shelf."""
    return ([(0, x0, 0, 5), (0, x0 + 6, 0, 0.3), (0, x0 + 6, 2.7, 5), (1, 0, x0, x0 + 6), (1, 5, x0, x0 + 6)]
            + box(x0 + 2.5, 2.4, x0 + 3.0, 3.0) + [(1, 3.9, x0, x0 + 1.3)])


# Twin rooms A (x 0..6) and B (x 9..15): B is A moved 9 m east. A's door opens on a 3 m hall
# that ends at B's west wall; B's door opens on a 1 m service corridor.
SPACING = 9.0
BUILDING = room(0.0) + room(SPACING) + [(1, 0, 6, 9), (1, 5, 6, 9), (1, 0, 15, 16), (1, 5, 15, 16), (0, 16, 0, 5)]
FACING_DOOR = 13   # the lap's keyframe at (5.1, 1.5) heading east, 0.9 m from the door


def lap(offset=gtsam.Pose2()) -> list[gtsam.Pose2]:
    """42 keyframes, 0.3 m apart, round room A's pillar (heading along the way, 45° at the
    corners), moved by ``offset`` (a pose in room A's frame)."""
    corners = [(1.2, 1.5), (5.4, 1.5), (5.4, 3.6), (1.2, 3.6)]
    poses = []
    for c in range(4):
        (x0, y0), (x1, y1) = corners[c], corners[(c + 1) % 4]
        heading = math.atan2(y1 - y0, x1 - x0)
        n = round(math.hypot(x1 - x0, y1 - y0) / 0.3)
        poses += [gtsam.Pose2(x0 + i / n * (x1 - x0), y0 + i / n * (y1 - y0),
                              heading - (math.pi / 4 if i == 0 else 0)) for i in range(n)]
    return [offset.compose(p) for p in poses]


def survey(truth, believed, sigma=LINK_SIGMA):
    """A pose graph of the believed keyframes (links between consecutive ones, σ ``sigma``) and
    each keyframe's (points, normals) scanned from its true pose."""
    graph = PoseGraph()
    graph.add_first(believed[0])
    for a, b in zip(believed[:-1], believed[1:]):
        graph.add_keyframe(a.between(b), np.diag(sigma**2))
    points = [cast(p, BUILDING).points() for p in truth]
    return graph, [(q, scan_normals(q, RegistrationConfig())) for q in points]


def revisit(drift: gtsam.Pose2, sigma=LINK_SIGMA, keyframes=None, believed=None):
    """Room A twice: the second lap 0.1 m and 3° off the first, believed moved by ``drift`` (or
    ``believed(truth)``); returns the true poses, the graph, the features and the lap length."""
    first = lap()
    second = lap(gtsam.Pose2(0.1, -0.1, math.radians(3.0)))[:keyframes]
    truth = first + second
    believed = believed(truth) if believed else first + [drift.compose(p) for p in second]
    graph, features = survey(truth, believed, sigma)
    return truth, graph, features, len(first)


def slipped(poses, at: int, slip: gtsam.Pose2) -> list[gtsam.Pose2]:
    """``poses`` as odometry would chain them if the link into keyframe ``at`` were off by ``slip``."""
    out = [poses[0]]
    for i in range(1, len(poses)):
        out.append(out[-1].compose(poses[i - 1].between(poses[i]).compose(slip if i == at else gtsam.Pose2())))
    return out


def relative_covariance(sigma, believed, j, k):
    """Covariance of keyframe k in keyframe j's frame, compounded link by link along the chain
    (δ_{i+1} = Ad(z_i⁻¹) δ_i + δ_z in GTSAM's right perturbation), independent of iSAM2."""
    cov = np.zeros((3, 3))
    for i in range(j, k):
        ad = believed[i].between(believed[i + 1]).inverse().AdjointMap()
        cov = ad @ cov @ ad.T + np.diag(sigma**2)
    return cov


def step_result(pose: gtsam.Pose2, keyframe: int) -> Localisation:
    """What ``PoseSlam._close_loops`` fills in for one keyframe."""
    return Localisation(pose, keyframe)


def off(a: gtsam.Pose2, b: gtsam.Pose2) -> tuple[float, float]:
    e = a.between(b)
    return math.hypot(e.x(), e.y()), abs(e.theta())


def test_verify_rejects_a_false_loop_between_twin_rooms():
    # the second lap runs in room B, but the graph believes it is back in room A: every
    # candidate predicts the twin place, 9 m from the truth
    first = lap()
    n = len(first)
    truth = first + lap(gtsam.Pose2(SPACING, 0.0, 0.0))
    graph, features = survey(truth, first + first)
    k = n + FACING_DOOR
    assert truth[k].equals(gtsam.Pose2(SPACING + 5.1, 1.5, 0.0), 1e-9)
    # aliased: the walls of the room read the same, only what the door shows differs
    here, twin = cast(truth[k], BUILDING).ranges, cast(truth[FACING_DOOR], BUILDING).ranges
    same = np.isclose(here, twin, atol=0.01) | (np.isinf(here) & np.isinf(twin))
    assert 0.4 < same.mean() < 0.6
    detector = LoopClosureDetector()
    candidates = detector.candidates(graph, k)
    assert candidates
    for candidate in candidates:
        assert off(truth[candidate.j].between(truth[k]), candidate.predicted)[0] > SPACING - 1.0
        assert detector.verify(candidate, graph, features) is None
    assert detector.rejected == {"inliers": len(candidates)}
    # (elsewhere on the lap, where under 40 % of the view differs, the same false loops pass
    # verification with d² ≈ 0: no check on a pair of scans can tell perfect twins apart)


def test_verify_accepts_a_true_revisit_and_recovers_the_relative_pose():
    drift = gtsam.Pose2(0.35, -0.25, math.radians(6.0))
    truth, graph, features, n = revisit(drift)
    k = n + FACING_DOOR                      # the same view of the door, this time in room A
    detector = LoopClosureDetector()
    candidates = detector.candidates(graph, k)
    assert len(candidates) == LoopClosureConfig().max_candidates
    for candidate in candidates:
        true = truth[candidate.j].between(truth[k])
        assert off(true, candidate.predicted)[0] > 0.17          # the graph's prediction is wrong...
        loop = detector.verify(candidate, graph, features)
        assert loop is not None
        dxy, dtheta = off(true, loop.match.pose)                  # ...the registration is right
        assert dxy < TOL_XY and dtheta < TOL_THETA
        assert loop.match.inlier_fraction > 0.95 and len(loop.match.degenerate) == 0
    assert not detector.rejected


def test_a_window_short_of_the_gates_is_warned_about():
    # the gates admit a loop up to search_radius + match_radius from its prediction; a window
    # left shorter (a configuration written before it was widened, or a search_radius raised
    # alone) misses those loops, and the user is told which settings disagree
    with pytest.warns(UserWarning, match=r"window_xy = 5\.0 m is shorter than search_radius \+ "
                      r"match_radius = 11\.0 m"):
        LoopClosureConfig(correlative=CorrelativeConfig(window_xy=5.0))
    with pytest.warns(UserWarning, match=r"window_xy = 11\.0 m .* = 12\.0 m"):
        LoopClosureConfig(search_radius=9.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        LoopClosureConfig()
        LoopClosureConfig(search_radius=8.0, match_radius=3.0)
        LoopClosureConfig(enabled=False, search_radius=20.0)


def test_a_loop_metres_beyond_the_graphs_guess_is_found_by_the_correlative_search():
    # the first return to the start after a long drive: the graph's guess is 6 m off, and its
    # covariance says so (σ 3 m). A true loop among the candidates the gates admit lies within
    # search_radius + match_radius (11 m) of its prediction, and the search must reach it
    # (± 5 m did not: the Infinite Corridor's first return, 5.2-5.9 m off)
    drift = gtsam.Pose2(6.0, 0.8, math.radians(2.0))
    truth, graph, features, n = revisit(drift, np.array([0.5, 0.5, 0.004]), keyframes=FACING_DOOR + 1)
    k = n + FACING_DOOR
    c = LoopClosureConfig()
    assert c.correlative.window_xy >= c.search_radius + c.match_radius
    detector = LoopClosureDetector(c)
    candidates = detector.candidates(graph, k)
    assert candidates
    for candidate in candidates:
        true = truth[candidate.j].between(truth[k])
        assert off(true, candidate.predicted)[0] > 6.0 and np.sqrt(candidate.covariance[0, 0]) > 3.0
        loop = detector.verify(candidate, graph, features)
        assert loop is not None and loop.searched
        dxy, dtheta = off(true, loop.match.pose)
        assert dxy < TOL_XY and dtheta < TOL_THETA


def test_reverse_registration_rejects_a_loop_biased_by_a_broken_submap(monkeypatch):
    # the first lap's link into keyframe 14 slipped 0.28 m and 8°: the submap round j = 11 (its
    # keyframes 6..16) is two pieces that do not fit, and the forward registration settles
    # between them; registering j's scan back to k's (intact) submap disagrees with it
    truth, graph, features, n = revisit(gtsam.Pose2(), keyframes=FACING_DOOR + 1,
                                        believed=lambda t: slipped(t, FACING_DOOR + 1,
                                                                   gtsam.Pose2(0.2, 0.2, math.radians(8.0))))
    j, k = FACING_DOOR - 2, n + FACING_DOOR
    candidate = Candidate(j, k, *graph.relative(j, k), 1.0, 0.0)
    detector = LoopClosureDetector()
    assert detector.verify(candidate, graph, features) is None
    assert detector.rejected == {"asymmetric": 1}
    monkeypatch.setattr(detector, "_symmetric", lambda *args: True)      # without the reverse check:
    biased = detector.verify(candidate, graph, features)
    assert biased is not None and biased.match.inlier_fraction > LoopClosureConfig().min_inlier_fraction
    dxy, dtheta = off(truth[j].between(truth[k]), biased.match.pose)
    assert dxy > 0.1 or dtheta > math.radians(2.0)                        # a loop that much off gets in


# The built-in office's tour, seed 4, as Pose SLAM saw it when it verified keyframe 805 (scan
# 4658, heading west along the corridor at x = 29.1 m) against keyframe 456 (scan 2615, heading
# east 0.28 m behind it, before a turn into the doors at x = 29.5): (scan, x, y, θ) of the
# submap's keyframes in 456's frame and of 805's predecessors in 805's frame, as the graph held
# them, and the graph's prediction of 805 in 456's frame (0.024 m, 0.47° off the truth).
OFFICE_SUBMAP = [
    (2582, -1.6526560063138724, -0.0031664179502727263, 0.0006749687519660502),
    (2588, -1.3500455067669819, -0.0027545069870488215, 0.0005914702169809441),
    (2595, -1.0007049779820818, -0.001878964821704604, 5.717520873058437e-05),
    (2602, -0.6522556958691332, -0.0005094799743978681, 4.8805482642181833e-05),
    (2608, -0.3498922555350106, -0.0025389437393103925, 0.0001457637924094985),
    (2615, 0.0, 0.0, 0.0),
    (2622, 0.3342307043935868, -0.0019893508514796654, 0.00036647018416430455),
    (2633, 0.5535991451034938, -0.001443728418026785, -0.31440164437834284),
    (2635, 0.58628334183528, -0.02038177129458897, -0.6207792280991827),
    (2637, 0.6459332893577034, -0.07436177282081141, -0.8810040317811969),
    (2639, 0.6912181155221866, -0.1455873112315886, -1.0967967425769614)]
OFFICE_TRACK = [
    (4626, -1.6073886958174768, 0.001067629068072673, -0.0003056796595262742),
    (4633, -1.263504559615562, -1.0224705291356218e-05, -0.00012532960578976),
    (4640, -0.9177521600471685, -0.0003642149873556988, 4.7299689442585225e-05),
    (4646, -0.6156332062770566, 0.0005963758050899215, 9.385439833119444e-05),
    (4652, -0.3117952544527398, 0.00029029614316058994, -0.00012734448261543364),
    (4658, 0.0, 0.0, 0.0)]
OFFICE_PREDICTED = gtsam.Pose2(0.2554390197228287, 0.009983322122897514, -3.1334100396265567)


def test_a_loop_slid_along_a_corridor_is_degenerate_by_the_scans_own_surfaces(monkeypatch):
    # Looking back down the corridor, the scan sees its walls and no surface across it. The
    # coarse levels slide it 0.36 m along the corridor, and the refinement pairs its wall points
    # with the jambs of the doors the submap saw: the match reads the corridor's axis as
    # observed (σ 9 mm) 0.29 m off the truth, within the Mahalanobis gate (d² 3.6). Taken, that
    # loop bent the office's map from 0.02 to 0.2 m ATE. The scan's own normals at the points
    # the submap explains observe no direction along the corridor, wherever it is placed
    log, _ = demo_tour(BUILTIN_WORLDS["office"](), 4)
    believed = ([gtsam.Pose2(x, y, t) for _, x, y, t in OFFICE_SUBMAP]
                + [OFFICE_PREDICTED.compose(gtsam.Pose2(x, y, t)) for _, x, y, t in OFFICE_TRACK])
    graph = PoseGraph()
    graph.add_first(believed[0])
    for a, b in zip(believed[:-1], believed[1:]):
        graph.add_keyframe(a.between(b), np.diag(LINK_SIGMA**2))
    features = [(q, scan_normals(q, RegistrationConfig()))
                for q in (log.scans[i].points() for i, *_ in OFFICE_SUBMAP + OFFICE_TRACK)]
    j, k = 5, len(believed) - 1
    candidate = Candidate(j, k, OFFICE_PREDICTED, np.diag([0.17, 0.19, 0.0354]) ** 2, 1.0, 1.0)
    detector = LoopClosureDetector(LoopClosureConfig(min_keyframe_gap=1))
    assert detector.verify(candidate, graph, features) is None
    assert detector.rejected == {"degenerate": 1}
    monkeypatch.setattr(detector, "_observes", lambda *args: True)      # without the scan's word:
    slid = detector.verify(candidate, graph, features)
    assert slid is not None and slid.mahalanobis < LoopClosureConfig().mahalanobis_gate
    error = log.truth[2615].between(log.truth[4658]).between(slid.match.pose)
    assert abs(error.x()) > 0.25 and np.sqrt(slid.match.covariance[0, 0]) < 0.02


def test_a_correlative_match_elsewhere_replaces_only_a_local_one_that_fails_and_that_it_far_outdoes(
        monkeypatch):
    # a poor guess sends the candidate to the correlative search; a corridor's aliases explain
    # more points than the true place where the true scan sees beyond the submap (office_f: loops
    # slid 0.9-1.7 m along it; office_h: 0.90 of a scan's points 1.5 m along a corridor, 0.68 at
    # its true place, which registration from the graph's guess found). Two places that both
    # explain enough of the scan to be a loop make the candidate ambiguous, however far one
    # outdoes the other. A match elsewhere replaces a local one that explains too little only by
    # leaving at most half as many points unexplained, and by explaining at least min_points
    # (20) of the 361 that the local one does not (30 here); otherwise the candidate is ambiguous
    truth, graph, features, n = revisit(gtsam.Pose2(), keyframes=FACING_DOOR + 1)
    j, k = FACING_DOOR, n + FACING_DOOR
    points, normals = features[k]           # 7 cm range noise: some of k's points are unexplained
    features[k] = (points + np.random.default_rng(0).normal(0.0, 0.07, points.shape), normals)
    predicted, _ = graph.relative(j, k)
    candidate = Candidate(j, k, predicted, np.diag([0.5, 0.5, 0.1]) ** 2, 1.0, 0.0)
    elsewhere = predicted.compose(gtsam.Pose2(1.0, 0.0, 0.0))
    # (a loop's least inlier fraction, the share of the local one's unexplained points left
    # unexplained elsewhere, taken)
    for least, unexplained, accepted in ((0.6, 0.2, False), (0.95, 0.8, False), (0.95, 0.2, True)):
        detector = LoopClosureDetector(LoopClosureConfig(min_inlier_fraction=least))
        found = []

        def correlative(candidate, points, submap, *rest):
            here = detector.registration.register(points, submap, candidate.predicted)
            found.append(here)
            slid = 1.0 - unexplained * (1.0 - here.inlier_fraction)
            return replace(here, pose=elsewhere, inlier_fraction=slid)
        monkeypatch.setattr(detector, "_correlative", correlative)
        monkeypatch.setattr(detector, "_symmetric", lambda *args: True)
        loop = detector.verify(candidate, graph, features)
        assert found and 0.8 <= found[0].inlier_fraction < 0.9      # 36-72 points unexplained
        if accepted:
            assert loop is not None and loop.match.pose.equals(elsewhere, 1e-9) and loop.searched
        else:
            assert loop is None and detector.rejected == {"ambiguous": 1}


def test_a_loop_the_correlative_search_found_waits_for_a_consistent_partner(monkeypatch):
    # a wide search finds a corridor's aliases (office_b: a loop 4.3 m along one, d² 15.6 inside
    # the χ² gate, bent the map by 4 m): a loop it found is one hypothesis, taken only with a
    # consistent partner however well the graph predicted it; the same loop found by registration
    # from the graph's prediction is taken alone
    for searched in (False, True):
        truth, graph, features, n = revisit(gtsam.Pose2())
        k = n + FACING_DOOR
        slam = PoseSlam()
        slam.graph, slam._features = graph, features
        slam.scan_anchor = [(k, gtsam.Pose2())]
        verify = slam.detector.verify
        monkeypatch.setattr(slam.detector, "verify", lambda *args: replace(verify(*args), searched=searched))
        slam._close_loops(k, step_result(graph.pose(k), k))
        verified = slam.loop_counts["verified"]
        assert verified == LoopClosureConfig().max_candidates
        if searched:
            assert slam.loops == [] and len(slam._pending) == verified
            assert slam.detector.rejected["pending"] == verified
        else:
            assert len(slam.loops) == verified and slam._pending == []
            assert all(loop.mahalanobis <= LoopClosureConfig().mahalanobis_gate for loop in slam.loops)


def test_mahalanobis_gate_rejects_a_loop_the_graph_contradicts():
    # a confident graph (σ 1 cm, 0.11° per link) that drifted 1.2 m and 12°: the loop is verified
    # (the scene is right) but lies far outside the graph's prediction, and the links alone (the
    # graph has no loop) predict it no better. Beyond the outright rejection threshold it is
    # turned away; with none set, it waits for a consistent partner like any loop beyond the gate
    sigma = np.array([0.01, 0.01, 0.002])
    drift = gtsam.Pose2(1.0, -0.6, math.radians(12.0))
    truth, graph, features, n = revisit(drift, sigma, keyframes=FACING_DOOR + 1)
    k = n + FACING_DOOR
    believed = graph.poses()
    config = LoopClosureConfig()
    detector = LoopClosureDetector(config)
    candidates = detector.candidates(graph, k)
    assert candidates
    for candidate in candidates:
        loop = detector.verify(candidate, graph, features)
        assert loop is not None
        assert off(truth[candidate.j].between(truth[k]), loop.match.pose)[0] < TOL_XY
        predicted_cov = relative_covariance(sigma, believed, candidate.j, k)
        np.testing.assert_allclose(candidate.covariance, predicted_cov, rtol=1e-6, atol=1e-12)
        e = believed[candidate.j].between(believed[k]).localCoordinates(loop.match.pose)
        d2 = float(e @ np.linalg.inv(predicted_cov + loop.match.covariance) @ e)
        assert math.isclose(loop.mahalanobis, d2, rel_tol=1e-6)
        assert d2 > config.mahalanobis_reject
    for rejecting in (True, False):
        slam = PoseSlam(SlamConfig(loop_closure=config if rejecting else
                                   LoopClosureConfig(mahalanobis_reject=math.inf)))
        slam.graph, slam._features = graph, features
        slam._close_loops(k, step_result(graph.pose(k), k))
        assert slam.loops == []
        if rejecting:
            assert slam._pending == [] and slam.detector.rejected["mahalanobis"] == len(candidates)
        else:
            assert len(slam._pending) == len(candidates) and slam.detector.rejected["pending"] == len(candidates)
        assert not any(is_loop for *_, is_loop in graph.edges)
        assert all(p.equals(q, 0.0) for p, q in zip(graph.poses(), believed))


def test_a_loop_beyond_the_gate_waits_for_a_consistent_partner():
    # drift of 0.94 m and 10°: d² between the χ² gate and the outright rejection. The loops of
    # the next keyframes are verified against the same submap (j ± 5): they confirm nothing until
    # the lap reaches keyframes whose submap shares no scan with the first loops'
    drift = gtsam.Pose2(0.8, -0.5, math.radians(10.0))
    later = 14
    truth, graph, features, n = revisit(drift, keyframes=FACING_DOOR + later)
    config = LoopClosureConfig()
    slam = PoseSlam()
    slam.graph, slam._features = graph, features
    slam.scan_anchor = [(n + FACING_DOOR + later - 1, gtsam.Pose2())]
    k = n + FACING_DOOR
    slam._close_loops(k, step_result(graph.pose(k), k))
    assert slam.loops == [] and len(slam._pending) == config.max_candidates
    assert slam.detector.rejected["pending"] == config.max_candidates
    assert all(config.mahalanobis_gate < p.mahalanobis <= config.mahalanobis_reject for p in slam._pending)
    for kk in range(k + 1, k + later):
        result = step_result(graph.pose(kk), kk)
        slam._close_loops(kk, result)
        if slam.loops:
            break
    assert result.corrected and kk - k <= config.pair_window
    js = [loop.candidate.j for loop in slam.loops]
    assert max(js) - min(js) > 2 * config.neighbour_keyframes
    assert sum(is_loop for *_, is_loop in graph.edges) == len(slam.loops)
    for loop in slam.loops:                  # the graph now agrees with the truth (from 0.94 m, 10°)
        j, kk = loop.candidate.j, loop.candidate.k
        dxy, dtheta = off(truth[j].between(truth[kk]), graph.pose(j).between(graph.pose(kk)))
        assert dxy < 0.01 and dtheta < math.radians(0.3)


def test_consistent_loops_from_neighbouring_keyframes():
    # two loops of the same place from keyframes k and k + 1 (turning 45° between them) to
    # j = 12 and 14 (also 45° apart), each verified against j's scan alone: both disagree with
    # the drifted graph, but agree together
    drift = gtsam.Pose2(0.35, -0.25, math.radians(6.0))
    truth, graph, features, n = revisit(drift, keyframes=FACING_DOOR + 2)
    detector = LoopClosureDetector(LoopClosureConfig(neighbour_keyframes=0))
    k = n + FACING_DOOR
    a = detector.verify(Candidate(12, k, *graph.relative(12, k), 1.0, 0.0), graph, features)
    b = detector.verify(Candidate(14, k + 1, *graph.relative(14, k + 1), 1.0, 0.0), graph, features)
    assert a is not None and b is not None
    assert off(a.candidate.predicted, a.match.pose)[0] > 0.17
    assert detector.consistent(a, b, graph) and detector.consistent(b, a, graph)
    for wrong in (gtsam.Pose2(1.0, 0.0, 0.0), gtsam.Pose2(0.0, 0.0, math.radians(3.0))):
        shifted = replace(b, match=replace(b.match, pose=b.match.pose.compose(wrong)))
        assert not detector.consistent(a, shifted, graph)
    assert not detector.consistent(a, a, graph)               # one keyframe cannot confirm itself
    # verified against submaps that share scans (j ± 5 keyframes), the two are one piece of
    # evidence: a corridor's aliasing slides both the same way, so neither confirms the other
    shared = LoopClosureDetector()
    assert not shared.consistent(a, b, graph) and not shared.consistent(b, a, graph)


def test_cauchy_loop_factor_shrugs_off_a_grossly_wrong_loop():
    config = LoopClosureConfig()
    # 12 keyframes round a 3 m square; every odometry link over-reports 2 cm and 0.5°
    truth = [gtsam.Pose2(0.0, 0.0, 0.0)]
    for i in range(11):
        truth.append(truth[-1].compose(gtsam.Pose2(1.0, 0.0, math.pi / 2 if i % 3 == 2 else 0.0)))
    bias = gtsam.Pose2(0.02, 0.0, math.radians(0.5))
    odometry = [a.between(b).compose(bias) for a, b in zip(truth[:-1], truth[1:])]
    odo_cov = np.diag([0.05, 0.05, 0.02]) ** 2
    loop_cov = np.diag([0.05, 0.05, 0.02]) ** 2
    good = (0, 11, truth[0].between(truth[11]))
    wrong = (3, 8, truth[3].between(truth[8]).compose(gtsam.Pose2(3.0, -2.0, 0.5)))   # 3.6 m, 29° off

    graph = PoseGraph()
    graph.add_first(truth[0])
    for z in odometry:
        graph.add_keyframe(z, odo_cov)
    initial = graph.poses()
    good_move = graph.add_loop(*good, loop_cov, config.cauchy_k, config.extra_updates)
    with_good = graph.poses()
    robust_move = graph.add_loop(*wrong, loop_cov, config.cauchy_k, config.extra_updates)
    robust = graph.poses()

    def gaussian(loops):
        """Plain Levenberg–Marquardt on the same prior, odometry and loops, all Gaussian."""
        factors, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        prior = gtsam.noiseModel.Diagonal.Sigmas(np.array([1e-3, 1e-3, 1e-4]))     # as PoseGraph.add_first
        factors.add(gtsam.PriorFactorPose2(0, truth[0], prior))
        for i, z in enumerate(odometry):
            factors.add(gtsam.BetweenFactorPose2(i, i + 1, z, gtsam.noiseModel.Gaussian.Covariance(odo_cov)))
        for i, j, z in loops:
            factors.add(gtsam.BetweenFactorPose2(i, j, z, gtsam.noiseModel.Gaussian.Covariance(loop_cov)))
        for i, p in enumerate(initial):
            values.insert(i, p)
        result = gtsam.LevenbergMarquardtOptimizer(factors, values).optimize()
        return [result.atPose2(i) for i in range(len(initial))]

    def moved(poses, reference):
        return max(np.hypot(*(p.translation() - q.translation())) for p, q in zip(poses, reference))

    assert good_move > 0.1                                  # the good loop corrects the drift...
    assert moved(with_good, gaussian([good])) < 0.005       # ...as a Gaussian factor would
    assert math.isclose(robust_move, moved(robust, with_good), rel_tol=1e-9)
    gaussian_move = moved(gaussian([good, wrong]), gaussian([good]))
    assert gaussian_move > 1.0                              # a Gaussian wrong loop drags the graph by metres,
    assert robust_move < 0.02 and robust_move < 0.02 * gaussian_move   # the Cauchy one by a centimetre

    cauchy = gtsam.noiseModel.mEstimator.Cauchy.Create(config.cauchy_k)
    information = np.linalg.inv(loop_cov)

    def weight(i, j, z):
        """The Cauchy weight 1 / (1 + (r / k)²) at the loop's whitened residual r."""
        e = z.localCoordinates(robust[i].between(robust[j]))
        return cauchy.weight(math.sqrt(e @ information @ e))

    assert weight(*wrong) < 0.05 and weight(*good) > 0.9


def doorways(centres, width=0.9):
    """A corridor along x (walls y = 0 and y = 2, ends at x = ±20) whose north wall has
    doorways of ``width`` m at ``centres``, each into a room 3 m deep, partitioned halfway
    between doorways."""
    centres = np.asarray(centres, float)
    edges = np.concatenate([[-20.0], np.repeat(centres, 2) + np.tile([-width / 2, width / 2], len(centres)), [20.0]])
    walls = [(1, 2.0, a, b) for a, b in edges.reshape(-1, 2)]
    walls += [(0, x, 2.0, 5.0) for x in (centres[:-1] + centres[1:]) / 2]
    return walls + [(1, 0.0, -20, 20), (1, 5.0, -20, 20), (0, -20.0, 0, 5), (0, 20.0, 0, 5)]


def test_two_places_the_scan_fits_as_well_make_a_loop_ambiguous():
    # office_h: registration from a start turned 7.5° laid a scan with one doorway on another
    # 1.5 m along the corridor, explaining 0.748 of it where the truth explained 0.608 (the
    # keyframe had seen rooms its submap had not); it was within the Mahalanobis gate (d² 8.7)
    # and bent the map by 1.5 m. Where the starts settle in two places that are both loops,
    # only one that explains far more is taken
    from slam.registration import Submap

    config = RegistrationConfig()
    here, along = gtsam.Pose2(0.3, 1.0, 0.4), gtsam.Pose2(1.5, 0.0, 0.0)
    alias = along.compose(here)
    rng = np.random.default_rng(3)
    for centres, ambiguous in ((np.arange(-18.0, 18.1, 1.5), True),                  # periodic doorways
                               (np.cumsum(rng.uniform(1.2, 2.6, 30)) - 25.0, False)):  # irregular
        walls = doorways(centres[np.abs(centres) < 19.0])
        poses = [gtsam.Pose2(x, 1.0, t) for x in np.arange(-6.0, 6.1, 0.5) for t in (0.0, math.pi)]
        scans = [cast(p, walls).points() for p in poses]
        submap = Submap.from_scans(poses, scans, [scan_normals(q, config) for q in scans], config)
        points = cast(here, walls).points()
        detector = LoopClosureDetector()
        best = detector.registration.register(points, submap, alias, start_level=2)     # from a fine start
        assert off(best.pose, alias)[0] < 0.02 and best.inlier_fraction > 0.6   # a loop at the alias
        starts = [(0.9, here), (0.95, alias)]
        found = detector._unrivalled(best, alias, starts, points, submap)
        if ambiguous:
            assert found is None
        else:                                   # the truth explains far more, and is taken
            assert found is not None and off(found.pose, here)[0] < TOL_XY
        assert detector._unrivalled(best, alias, starts[1:], points, submap) is best   # no rival start
