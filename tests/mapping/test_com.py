"""The continuous occupancy map on simulated worlds: accuracy, regeneration, bad input."""

import gtsam
import numpy as np
import pytest
from pydantic import ValidationError

from mapping.com import ContinuousOccupancyMap, _Fused
from mapping.config import COMConfig, TrainingConfig
from mapping.metrics import KNOWN, coverage, roc_auc
from mapping.training import beam_samples
from sim.world_io import load_ros_map
from slam.scan import LaserScan

from simworlds import corridor_pass, room_tour, scans_at


def auc_vs_truth(com, world, margin=0.1):
    """AUC of Λ over the observed cells of the COM against the true map, leaving out the
    ``margin`` band on each side of the wall surfaces: hits straddle the surface, so cells
    there hold both kinds of evidence. Occupied cells are the observable skin of the walls
    (within ``margin`` of free space), free cells those at least ``margin`` from walls."""
    iy, ix = np.nonzero(com.observed())
    xy = com.origin + np.column_stack([ix, iy]) * com.resolution
    truth = world.is_occupied(xy)
    around = xy[:, None, :] + margin * np.array([[1, 0], [-1, 0], [0, 1], [0, -1]])
    skin = truth & ~world.is_occupied(around).all(axis=1)
    clear = ~truth & (world.clearance_at(xy) >= margin)
    keep = skin | clear
    return roc_auc(truth[keep], com.prob()[iy, ix][keep])


def test_beam_samples_never_pass_the_hit_and_no_return_beams_are_free():
    scan = LaserScan(np.array([2.0, 8.0, np.nan, -1.0, np.inf, 0.0]),
                     np.deg2rad([0.0, 90.0, 10.0, 20.0, 180.0, 30.0]), max_range=8.0)
    c = TrainingConfig(max_range=6.0, free_step=0.5, free_margin=0.2)
    s = beam_samples(gtsam.Pose2(1.0, 2.0, 0.0), scan, c)
    np.testing.assert_allclose(s.hits, [[3.0, 2.0]])
    assert set(s.free_beam) == {0, 1, 4}                 # NaN, negative, zero give nothing
    d = np.hypot(*(s.free - [1.0, 2.0]).T)
    assert d[s.free_beam == 0].max() <= 1.8 + 1e-9       # stops free_margin before the hit
    assert d[s.free_beam == 1].max() == pytest.approx(6.0)  # no return: free up to max_range
    assert d[s.free_beam == 4].max() == pytest.approx(6.0)  # +inf is a no return too


def test_corridor_from_ground_truth_poses_has_auc_near_one(corridor):
    poses = [gtsam.Pose2(x, 2.0, 0.0 if i % 2 == 0 else np.pi) for i, x in enumerate(np.arange(1.5, 12.6, 0.5))]
    com = ContinuousOccupancyMap()
    for p, s in zip(poses, scans_at(corridor, poses)):
        com.update(p, s)
    assert auc_vs_truth(com, corridor) > 0.98
    P = com.prob()
    assert np.isfinite(P).all() and np.isfinite(com.var()).all()
    # corridor centre is free, the walls occupied
    xs = np.arange(2.0, 12.0, 0.5)
    centre = com.sample(P, np.column_stack([xs, np.full_like(xs, 2.0)]))
    wall = com.sample(com.prob_occ(), np.column_stack([xs, np.full_like(xs, 3.02)]))
    assert centre.max() < 0.3 and wall.min() > 0.6
    # coverage of the reachable free space farther than a robot radius from the walls
    reach = corridor.reachable((2.0, 2.0), 0.25)
    iy, ix = np.nonzero(reach)
    xy = corridor.center_of(np.column_stack([ix, iy]))
    assert coverage(com.sample(P, xy), 0.2) > 0.95


def test_regeneration_removes_the_doubled_walls_of_perturbed_poses(room):
    loop = room_tour()
    poses = loop + loop[:10]                 # one loop, then the first part again
    scans = scans_at(room, poses, seed=1)
    # the second pass carries a pose error, as before a loop closure corrects it
    error = gtsam.Pose2(0.35, -0.25, 0.06)
    wrong = poses[:16] + [error.compose(p) for p in poses[16:]]

    config = COMConfig(drift={"threshold": 0.02})   # a short run: a lower threshold
    good = ContinuousOccupancyMap(config)
    js_good = [good.update(p, s) for p, s in zip(poses, scans)]
    bad = ContinuousOccupancyMap(config)
    js_bad = [bad.update(p, s) for p, s in zip(wrong, scans)]

    def doubled(com):
        """Cells more than 0.25 m from any true wall that the map calls occupied."""
        iy, ix = np.nonzero(com.observed())
        xy = com.origin + np.column_stack([ix, iy]) * com.resolution
        far = ~room.is_occupied(xy) & (room.clearance_at(xy) > 0.25)
        return int((com.prob_occ()[iy, ix][far] > 0.8).sum() + (com.prob()[iy, ix][far] > 0.5).sum())

    assert doubled(good) <= 2 and doubled(bad) > 30
    # the loop is identical; on the second pass the local maps disagree with the map
    assert js_bad[:16] == pytest.approx(js_good[:16])
    assert np.mean(js_bad[16:]) > 2.5 * np.mean(js_good[16:])
    assert bad.needs_regeneration and not good.needs_regeneration
    bad.regenerate(zip(poses, scans))                       # corrected poses
    assert not bad.needs_regeneration
    assert doubled(bad) == doubled(good)
    np.testing.assert_allclose(bad.prob(), good.prob())     # same keyframes, same map
    assert auc_vs_truth(bad, room) > 0.97


def _predicted_cells(com):
    """A list that gathers how many cells each GP prediction of ``com`` queries from now on."""
    cells, predict = [], com._predict
    com._predict = lambda gp, pts, blocks, q, start: cells.append(len(q)) or predict(gp, pts, blocks, q, start)
    return cells


def test_regeneration_relearns_what_moved_and_gives_the_map_relearnt_from_scratch(room):
    loop = room_tour()
    poses = loop + loop[:10]
    scans = scans_at(room, poses, seed=1)
    error = gtsam.Pose2(0.35, -0.25, 0.06)
    wrong = poses[:8] + [error.compose(p) for p in poses[8:12]] + poses[12:]
    fresh = ContinuousOccupancyMap()
    for p, s in zip(poses, scans):
        fresh.update(p, s)
    com = ContinuousOccupancyMap()
    # keyframes 8-11 off, those after them train on their points, 20-25 not fused yet
    for p, s in zip(wrong[:20], scans[:20]):
        com.update(p, s)
    com.regenerate(zip(poses, scans))
    _assert_same_map(com, fresh)
    again = _predicted_cells(com)
    before = com.prob()
    com.regenerate(zip(poses, scans))                 # nothing moved: nothing relearnt
    assert again == [] and np.array_equal(com.prob(), before)


def _assert_same_map(com, fresh):
    """Same frame and the same BCM sums, bit for bit."""
    assert (com.frame.ix0, com.frame.iy0, com.frame.shape) == (
        fresh.frame.ix0, fresh.frame.iy0, fresh.frame.shape)
    for a, b in ((com._occ, fresh._occ), (com._free, fresh._free)):
        np.testing.assert_array_equal(a.precision, b.precision)
        np.testing.assert_array_equal(a.weighted, b.weighted)


def test_regeneration_leaves_the_blocks_only_unmoved_keyframes_reach(corridor):
    poses, wrong = corridor_pass()
    scans = scans_at(corridor, poses, seed=3)
    fresh = ContinuousOccupancyMap()
    everything = _predicted_cells(fresh)
    for p, s in zip(poses, scans):
        fresh.update(p, s)
    com = ContinuousOccupancyMap()
    for p, s in zip(wrong, scans):
        com.update(p, s)
    relearnt = _predicted_cells(com)
    com.regenerate(zip(poses, scans))
    _assert_same_map(com, fresh)
    # the last keyframes (x >= 11.5 m) reach back 10 m: the blocks at x < 1.5 m stand
    assert 0 < sum(relearnt) < sum(everything)


def test_regeneration_keeps_keyframes_whose_points_moved_less_than_the_tolerance(room):
    poses = room_tour()[:12]
    scans = scans_at(room, poses, seed=2)
    nudged = [gtsam.Pose2(0.004, 0.0, 0.0).compose(p) for p in poses[:6]] + [
        gtsam.Pose2(0.0, 0.0, 0.003).compose(p) for p in poses[6:]]
    com = ContinuousOccupancyMap(COMConfig(drift={"unmoved": 0.01}))
    for p, s in zip(poses, scans):
        com.update(p, s)
    before = com.prob()
    relearnt = _predicted_cells(com)
    com.regenerate(zip(nudged, scans))
    # a 4 mm shift keeps its keyframes; a 0.003 rad turn moves points up to the scans' reach
    # (beyond 3.3 m) by a centimetre or more, so those keyframes are relearnt
    reach = max(kf.reach for kf in com._fused_keyframes[6:])
    assert reach * 0.003 > 0.01
    assert relearnt and not np.array_equal(com.prob(), before)
    assert [kf.pose for kf in com._fused_keyframes[:6]] == poses[:6]
    assert [kf.pose for kf in com._fused_keyframes[6:]] == nudged[6:]


def test_bad_scans_never_crash_or_put_nan_in_the_map():
    com = ContinuousOccupancyMap()
    angles = np.deg2rad(np.arange(-90, 91, 1.0))
    nothing = LaserScan(np.full(181, np.nan), angles, 8.0)
    assert com.update(gtsam.Pose2(), nothing) == 0.0              # no usable beam at all
    assert com.update(gtsam.Pose2(), LaserScan(np.zeros(0), np.zeros(0), 8.0)) == 0.0   # empty
    open_space = LaserScan(np.full(181, np.inf), angles, 8.0)    # no hits: free points only
    com.update(gtsam.Pose2(), open_space)
    rng = np.random.default_rng(0)
    r = rng.uniform(0.5, 5, 181)
    r[rng.random(181) < 0.3] = np.nan
    r[rng.random(181) < 0.1] = -2.0
    r[rng.random(181) < 0.1] = np.inf
    com.update(gtsam.Pose2(0.5, 0.2, 0.3), LaserScan(r, angles, 8.0))
    for grid in (com.prob(), com.prob_occ(), com.prob_free(), com.var(), com.var_occ(), com.var_free()):
        assert np.isfinite(grid).all()
    assert ((com.prob() > 0) & (com.prob() < 1)).all()
    assert com.prob_free()[com.observed()].mean() < 0.5           # the open space became free
    # reading the map far outside what was mapped gives "unknown"
    np.testing.assert_allclose(com.sample(com.prob(), np.array([[500.0, -300.0]])), 0.5)
    with pytest.raises(ValueError, match="not finite"):
        com.update(gtsam.Pose2(np.nan, 0.0, 0.0), open_space)
    with pytest.raises(TypeError, match="Pose2"):
        com.update((0.0, 0.0, 0.0), open_space)
    kept = com.keyframes
    with pytest.raises(ValueError, match="max_cells"):             # a wild pose
        com.update(gtsam.Pose2(1e6, -1e6, 0.0), open_space)
    assert com.keyframes == kept and np.isfinite(com.prob()).all()


def test_config_rejects_non_positive_length_scales():
    with pytest.raises(ValidationError):
        COMConfig(obstacle={"matern_length": 0.0})
    with pytest.raises(ValidationError):
        COMConfig(free={"length_bounds": (0.5, 0.1)})
    with pytest.raises(ValidationError):
        COMConfig(query={"resolution": -0.1})


def test_config_keeps_each_gps_lengths_at_least_its_training_spacing():
    with pytest.raises(ValidationError, match=r"free\.length_bounds: 0\.05 m .*training\.free_voxel"):
        COMConfig(free={"length_bounds": (0.05, 0.5)})
    with pytest.raises(ValidationError, match=r"free\.se_length: 0\.2 m"):
        COMConfig(free={"se_length": 0.2})
    with pytest.raises(ValidationError, match=r"obstacle\.length_bounds: 0\.1 m .*training\.voxel = 0\.2"):
        COMConfig(training={"voxel": 0.2})
    # a partial section keeps that GP's own defaults instead of the generic ones
    assert COMConfig(free={"nu": 2.5}).free.length_bounds == COMConfig().free.length_bounds


def test_a_first_frame_in_clutter_still_reads_the_space_it_saw_as_free(shared_data):
    """lab_f_scan's seed-2 start looks at clutter: hits and free points interleave, and the ±1
    fit of the lengths falls to 0.12 m, under the 0.3 m spacing of the free points. The COM
    then read 33 % of the free space along the beams as free, and that run stopped at 72 %
    coverage. Every point along a beam, 0.3 m past the sensor up to 0.3 m short of its hit
    (within 6 m), is free space the laser crossed."""
    world = load_ros_map(shared_data / "maps" / "suite" / "lab_f_scan.yaml")
    pose = gtsam.Pose2(44.175, 27.425, -0.1374)
    scan = scans_at(world, [pose])[0]
    com = ContinuousOccupancyMap()
    com.update(pose, scan)
    ranges = np.where(np.isfinite(scan.ranges), scan.ranges, scan.max_range)
    crossed = np.vstack([
        np.arange(0.3, min(r, 6.0) - 0.3, 0.05)[:, None] * [np.cos(a), np.sin(a)]
        for a, r in zip(scan.angles + pose.theta(), ranges)]) + [pose.x(), pose.y()]
    assert len(crossed) > 1000 and not world.is_occupied(crossed).any()
    assert np.mean(com.sample(com.prob(), crossed) < 0.5 - KNOWN) > 0.95


def test_local_gps_see_at_most_max_train_points_however_large_the_pool(room, monkeypatch):
    """The cost per keyframe is bounded: each block's GP gets the ``max_train`` nearest points
    of a training pool that grows with the history of keyframes."""
    import mapping.com as com_module

    seen = []
    real = com_module.predict_blocks

    def spy(kernel, noise, pts, idx, qxy, start):
        seen.append((len(pts), idx.shape[1], int((idx < len(pts)).sum(axis=1).max())))
        return real(kernel, noise, pts, idx, qxy, start)

    monkeypatch.setattr(com_module, "predict_blocks", spy)
    com = ContinuousOccupancyMap(COMConfig(query={"history": 5, "max_train": 12}))
    poses = room_tour()
    for p, s in zip(poses, scans_at(room, poses)):
        com.update(p, s)
    pool, width, used = np.array(seen).T
    assert pool.max() > 20 * 12 and width.max() == 12 and used.max() == 12


def test_the_query_set_is_the_cells_near_the_points_within_the_window_grouped_by_block():
    """Every cell whose centre offset from a point's cell is within ``near`` and that lies in
    the window, once, grouped by block (blocks row by row, and the cells row by row within
    each), against a brute force over the window."""
    com = ContinuousOccupancyMap(COMConfig(query={"near": 0.25, "window": 3.0, "block": 4}))
    rng = np.random.default_rng(5)
    pts = rng.uniform(-2.2, 1.7, (40, 2))
    kf = _Fused(None, np.array([-0.3, 0.2]), pts[:25], pts[25:])
    cells, blocks, start = com._query_set(kf)
    res, near = 0.1, 0.25
    own = np.unique(np.floor(pts / res).astype(int), axis=0)
    lo, hi = np.floor((np.array([-0.3, 0.2]) - 1.5) / res), np.floor((np.array([-0.3, 0.2]) + 1.5) / res)
    want = {(x, y) for x in range(int(lo[0]), int(hi[0]) + 1) for y in range(int(lo[1]), int(hi[1]) + 1)
            if (np.sum((own - [x, y]) ** 2, axis=1) * res * res <= near ** 2 + 1e-12).any()}
    assert sorted(map(tuple, cells)) == sorted(want) and len(cells) == len(want)
    assert start[0] == 0 and start[-1] == len(cells) and np.all(np.diff(start) > 0)
    assert [tuple(b) for b in blocks] == sorted(map(tuple, blocks), key=lambda b: (b[1], b[0]))
    for b, block in enumerate(blocks):
        run = cells[start[b]:start[b + 1]]
        assert np.all(np.floor_divide(run, 4) == block)
        assert [tuple(c) for c in run] == sorted(map(tuple, run), key=lambda c: (c[1], c[0]))
