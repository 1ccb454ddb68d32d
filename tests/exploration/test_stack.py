"""The onboard stack, one scan at a time: regeneration after SLAM corrections, the mapping
modes, and the first commands of a closed loop."""

import dataclasses
import math

import gtsam
import numpy as np
import pytest

from exploration.explorer import ExplorerConfig
from exploration.stack import Stack, StackConfig
from mapping.com import ContinuousOccupancyMap
from mapping.config import COMConfig
from mapping.logodds import LogOddsGrid
from sim.lidar import Lidar, LidarConfig
from sim.world import World
from sim.worlds import BUILTIN_WORLDS
from slam.localiser import Localisation

# A short run: the drift threshold lowered from 0.2 as in tests/mapping/test_com.py. Over the
# scans below, a 0.4 m / 3 degree pose error cumulates about 0.07 of excess divergence, a
# 1 cm one nothing (each divergence stays under 5 x the median of the consistent scans).
COM = COMConfig(drift={"threshold": 0.02})
# poses given with each scan; a keyframe after 0.3 m or 10 degrees (stated here: the tests
# below derive which scans are keyframes from it)
GIVEN = {"poses": "truth", "slam": {"keyframes": {"min_translation": 0.3, "min_rotation_deg": 10.0}}}
GRID_CONFIG = StackConfig(**GIVEN, explorer=ExplorerConfig(method="grid"))


def room_world() -> World:
    """10 m x 8 m room (walls 0.5 m) with a 2 m x 1.5 m box in the middle."""
    return BUILTIN_WORLDS["room"]().world


def tour() -> list[gtsam.Pose2]:
    """16 sensor poses on a loop around the box, looking along the loop and outward."""
    poses = []
    for k in range(16):
        a = 2 * np.pi * k / 16
        poses.append(gtsam.Pose2(5 + 3.4 * np.cos(a), 4 + 2.6 * np.sin(a),
                                 a + np.pi / 2 + (0.6 if k % 2 else -0.6)))
    return poses


TRUTH = tour() + tour()[:8]                  # a loop, then half of it again
N_TRUE, CORRECTION = 16, 23                  # scans 16..22 drift; scan 23 closes the loop


@pytest.fixture(scope="module")
def scans():
    lidar = Lidar(seed=3)
    return [lidar.scan(room_world(), p, 0.1 * i) for i, p in enumerate(TRUTH)]


@pytest.fixture(scope="module")
def truth_com(scans):
    """The COM fed every scan at its true pose, in order (θ fitted on scan 0)."""
    return fed(ContinuousOccupancyMap(COM), TRUTH, scans)


class ScriptedLocaliser:
    """A localiser that plays a script: every scan is a keyframe; scans from ``N_TRUE`` on are
    estimated at ``error`` composed with their true pose, until scan ``correct_at``, where a
    loop closure moves every estimate back to the truth (``corrected``). ``pose(i)`` is the
    current estimate of scan i, so it changes at the correction. With ``corrected=False``
    the loop is closed without moving anything; ``withdrawn`` loops taken back out there."""

    def __init__(self, truth, error: gtsam.Pose2, correct_at: int = CORRECTION,
                 corrected: bool = True, withdrawn: int = 0):
        self.truth, self.error, self.correct_at, self.corrected = truth, error, correct_at, corrected
        self.withdrawn = withdrawn
        self.keyframe_scans = []
        self.localised_at: list[gtsam.Pose2] = []     # each scan's pose when it was localised
        self._poses: list[gtsam.Pose2] = []

    def step(self, odometry, scan, given=None) -> Localisation:
        i = len(self._poses)
        self.keyframe_scans.append(scan)
        self._poses.append(self.error.compose(self.truth[i]) if i >= N_TRUE else self.truth[i])
        if i == self.correct_at:
            before = list(self._poses)
            if self.corrected:
                self._poses = list(self.truth[:i + 1])
            moved = max(np.hypot(*(a.translation() - b.translation()))
                        for a, b in zip(self._poses, before))
            here = Localisation(self._poses[i], i, loops=[(0, i)], moved=float(moved),
                                corrected=self.corrected, withdrawn=self.withdrawn)
        else:
            here = Localisation(self._poses[i], i)
        self.localised_at.append(here.pose)
        return here

    def pose(self, i: int) -> gtsam.Pose2:
        return self._poses[i]

    def trajectory(self) -> list[gtsam.Pose2]:
        return list(self._poses)

    def positions(self, indices) -> np.ndarray:
        return np.array([[self._poses[i].x(), self._poses[i].y()] for i in indices]).reshape(-1, 2)

    def keyframe_poses(self) -> list[gtsam.Pose2]:
        return list(self._poses)

    def loop_pairs(self) -> np.ndarray:
        return np.array([[0, self.correct_at]]) if len(self._poses) > self.correct_at else np.zeros((0, 2), int)


def run(stack, scans, n=None):
    return [stack.step(None, s, p) for p, s in zip(TRUTH[:n], scans[:n])]


def same(a, b) -> bool:
    return a.shape == b.shape and np.array_equal(a, b)


def index(scans, scan) -> int:
    """Which of ``scans`` is ``scan`` (the object itself)."""
    return next(i for i, s in enumerate(scans) if s is scan)


def fed(new_map, poses, scans):
    """A fresh map fed ``scans`` at ``poses`` in order."""
    for p, s in zip(poses, scans):
        new_map.update(p, s)
    return new_map


# ---------------------------------------------------------------- regeneration

def test_large_correction_regenerates_the_com_from_the_corrected_poses(scans, truth_com):
    stack = Stack(StackConfig(**GIVEN, com=COM), planning=False)
    stack.localiser = ScriptedLocaliser(TRUTH, gtsam.Pose2(0.4, 0.0, math.radians(3)))
    steps = run(stack, scans, CORRECTION)
    assert stack.map.needs_regeneration          # drifted past the threshold ...
    assert stack.regenerations == 0              # ... but nothing is relearned before a correction
    # the map so far holds the drifted scans where they were localised
    drifted = fed(ContinuousOccupancyMap(COM), stack.localiser.localised_at,
                  scans[:CORRECTION])
    np.testing.assert_array_equal(stack.map.prob(), drifted.prob())

    steps.append(stack.step(None, scans[CORRECTION], TRUTH[CORRECTION]))
    assert [s.regenerated for s in steps] == [False] * CORRECTION + [True]
    assert steps[-1].loops == 1 and stack.loops == 1 and stack.keyframes == CORRECTION + 1
    assert stack.regenerations == 1
    # rebuilt from every mapped scan at its current (true) pose: the map a COM builds when it
    # knew the true poses all along (θ is fitted on scan 0 in both, at the same pose)
    truth = truth_com
    np.testing.assert_array_equal(stack.map.origin, truth.origin)
    np.testing.assert_array_equal(stack.map.prob(), truth.prob())
    np.testing.assert_array_equal(stack.map.prob_occ(), truth.prob_occ())
    drifted.update(TRUTH[CORRECTION], scans[CORRECTION])
    assert not same(drifted.prob(), truth.prob())       # what it would be without the rebuild
    assert stack.map.drift.cumulated == 0.0 and not stack.map.needs_regeneration


def test_small_correction_leaves_the_com_alone(scans, truth_com):
    stack = Stack(StackConfig(**GIVEN, com=COM), planning=False)
    stack.localiser = ScriptedLocaliser(TRUTH, gtsam.Pose2(0.01, 0.0, 0.0))
    steps = run(stack, scans)
    assert steps[-1].loops == 1 and not any(s.regenerated for s in steps)
    assert stack.regenerations == 0 and stack.map.drift.cumulated == 0.0
    # the map keeps the scans where they were fused, 1 cm off: not the corrected poses
    online = fed(ContinuousOccupancyMap(COM), stack.localiser.localised_at, scans)
    np.testing.assert_array_equal(stack.map.prob(), online.prob())
    truth = truth_com
    assert not same(stack.map.prob(), truth.prob())


def test_a_correction_under_the_coms_drift_still_rebuilds_the_planners_grid(scans):
    """The planner reads its clearance off the costmap grid's hits, a centimetre scale (a door
    0.04 m wider than the robot): they follow every correction, as the grid method's map does,
    while the COM waits for its drift check. 2 cm: past the grid's 1 cm ``unmoved``."""
    config = StackConfig(**GIVEN, com=COM)
    stack = Stack(config)
    assert isinstance(stack.costmap, LogOddsGrid) and stack.costmap is not stack.map
    stack.localiser = ScriptedLocaliser(TRUTH, gtsam.Pose2(0.02, 0.0, 0.0))
    steps = run(stack, scans)
    assert steps[-1].loops == 1 and not any(s.regenerated for s in steps)
    assert stack.regenerations == 0 and stack.costmap_regenerations == 1
    online = fed(ContinuousOccupancyMap(COM), stack.localiser.localised_at, scans)
    np.testing.assert_array_equal(stack.map.prob(), online.prob())      # the COM as fused
    truth = fed(LogOddsGrid(config.grid), TRUTH, scans)
    np.testing.assert_array_equal(stack.costmap.logodds, truth.logodds)
    np.testing.assert_array_equal(np.sort(stack.costmap.hits(), axis=0), np.sort(truth.hits(), axis=0))


def test_a_correction_that_withdraws_a_loop_regenerates_the_com_without_drift(scans, truth_com):
    # a small correction (2 cm, past the 1 cm of ``drift.unmoved``), but taking a false loop
    # back out: the map may have been relearnt under it wherever the robot is not, and the drift
    # check reads only where it maps
    stack = Stack(StackConfig(**GIVEN, com=COM), planning=False)
    stack.localiser = ScriptedLocaliser(TRUTH, gtsam.Pose2(0.02, 0.0, 0.0), withdrawn=1)
    steps = run(stack, scans)
    assert [s.regenerated for s in steps] == [False] * CORRECTION + [True]
    assert stack.regenerations == 1
    np.testing.assert_array_equal(stack.map.prob(), truth_com.prob())


@pytest.mark.parametrize("error", [gtsam.Pose2(0.4, 0.0, math.radians(3)), gtsam.Pose2(0.02, 0.0, 0.0)],
                         ids=["40cm", "2cm"])
def test_any_correction_regenerates_the_grid_from_the_corrected_poses(scans, error):
    """A grid has no drift measure: any correction, even 2 cm (past its 1 cm ``unmoved``),
    rebuilds it, and the rebuilt grid is the one fed every scan at its corrected pose."""
    stack = Stack(GRID_CONFIG, planning=False)
    assert isinstance(stack.map, LogOddsGrid)
    stack.localiser = ScriptedLocaliser(TRUTH, error)
    steps = run(stack, scans)
    assert [s.regenerated for s in steps] == [False] * CORRECTION + [True]
    assert stack.regenerations == 1
    truth = fed(LogOddsGrid(GRID_CONFIG.grid), TRUTH, scans)
    np.testing.assert_array_equal(stack.map.origin, truth.origin)
    np.testing.assert_array_equal(stack.map.logodds, truth.logodds)
    online = fed(LogOddsGrid(GRID_CONFIG.grid), stack.localiser.localised_at, scans)
    assert not same(online.logodds, truth.logodds)          # the rebuild changed it


def test_a_loop_without_correction_does_not_regenerate_the_grid(scans):
    stack = Stack(GRID_CONFIG, planning=False)
    stack.localiser = ScriptedLocaliser(TRUTH, gtsam.Pose2(0.4, 0.0, 0.0), corrected=False)
    steps = run(stack, scans)
    assert steps[-1].loops == 1 and not any(s.regenerated for s in steps)
    assert stack.regenerations == 0


# ---------------------------------------------------------------- mapping modes

def test_mapping_off_keeps_no_map_but_localises(scans):
    stack = Stack(StackConfig(**GIVEN), mapping="off", planning=False)
    assert stack.map is None
    steps = [stack.step(None, s, p) for p, s in zip(TRUTH[:6], scans[:6])]
    assert [s.pose for s in steps] == TRUTH[:6]
    assert stack.localiser.trajectory() == TRUTH[:6]
    # tour poses are > 0.3 m apart: every scan is a keyframe
    assert [s.keyframe for s in steps] == list(range(6)) and stack.keyframes == 6
    # a correction with no map to regenerate is harmless
    stack = Stack(StackConfig(**GIVEN), mapping="off", planning=False)
    stack.localiser = ScriptedLocaliser(TRUTH, gtsam.Pose2(0.4, 0.0, 0.0))
    steps = run(stack, scans)
    assert steps[-1].loops == 1 and stack.regenerations == 0 and stack.map is None


def test_mapping_final_fuses_nothing_until_the_end_then_uses_the_final_poses(scans, truth_com):
    stack = Stack(StackConfig(**GIVEN, com=COM), mapping="final", planning=False)
    stack.localiser = ScriptedLocaliser(TRUTH, gtsam.Pose2(0.4, 0.0, math.radians(3)))
    steps = run(stack, scans)
    assert stack.map.prob().size == 0 and stack.map.keyframes == 0     # nothing fused yet
    assert stack.regenerations == 0 and not any(s.regenerated for s in steps)
    assert len(stack.mapped_scans()) == len(TRUTH)
    final = stack.final_map()
    assert final is stack.map
    truth = truth_com                                                      # the final poses
    np.testing.assert_array_equal(final.origin, truth.origin)
    np.testing.assert_array_equal(final.prob(), truth.prob())


def test_map_every_maps_every_nth_scan_instead_of_the_keyframes():
    """Poses 0.12 m apart along a line: keyframes (0.3 m) are scans 0, 3, 6; map_every=2 maps
    scans 0, 2, 4, 6 instead."""
    world = room_world()
    lidar = Lidar(seed=5)
    poses = [gtsam.Pose2(2.0 + 0.12 * i, 4.0, 0.0) for i in range(7)]
    line = [lidar.scan(world, p, 0.1 * i) for i, p in enumerate(poses)]
    for every, mapped in ((0, [0, 3, 6]), (2, [0, 2, 4, 6])):
        config = GRID_CONFIG.model_copy(update={"map_every": every})
        stack = Stack(config, mapping="online", planning=False)
        steps = [stack.step(None, s, p) for p, s in zip(poses, line)]
        assert [s.keyframe is not None for s in steps] == [i in (0, 3, 6) for i in range(7)]
        assert [index(line, scan) for _, scan in stack.mapped_scans()] == mapped
        reference = fed(LogOddsGrid(config.grid), [poses[i] for i in mapped], [line[i] for i in mapped])
        np.testing.assert_array_equal(stack.map.logodds, reference.logodds)


@pytest.mark.parametrize("mapping", ["final", "off"])
def test_planning_needs_the_map_online(mapping):
    with pytest.raises(ValueError, match="planning needs the map online"):
        Stack(StackConfig(**GIVEN), mapping=mapping)
    Stack(StackConfig(**GIVEN), mapping=mapping, planning=False)     # fine without


def test_unknown_mapping_mode_is_rejected():
    with pytest.raises(ValueError, match="online, final or off"):
        Stack(StackConfig(**GIVEN), mapping="sometimes", planning=False)


# ---------------------------------------------------------------- closed loop, first steps

def room_with_door(door: bool) -> World:
    """A 4 m x 3 m room (x 1-5 m, y 3-6 m); with ``door``, a 1 m door in its right wall
    (x 5-5.25 m, y 4-5 m) onto a hall (x 5.25-12 m, y 0.5-9.5 m)."""
    occ = np.ones((200, 260), bool)
    occ[60:120, 20:100] = False
    if door:
        occ[80:100, 100:105] = False
        occ[10:190, 105:240] = False
    return World(occ, (0.05, 0.05))


ROBOT = gtsam.Pose2(3.0, 4.55, 0.0)         # the room's centre row of 0.1 m cells, facing the door


def first_steps(config, world, n=10):
    """A 360-degree scan of ``world`` from ``ROBOT``, fed ``n`` times 0.5 s apart (the robot
    does not move: only the first is a keyframe, mapped and planned on)."""
    scan = Lidar(LidarConfig(fov_deg=360, beams=720), seed=0).scan(world, ROBOT, 0.0)
    stack = Stack(config)
    steps = [stack.step(None, dataclasses.replace(scan, timestamp=0.5 * k), ROBOT) for k in range(n)]
    return stack, steps


def assert_spins_for_four_seconds(steps):
    """The top turn rate is π/2: the spin lasts 4 s, stamps 0-3.5 s (8 scans)."""
    for s in steps[:8]:
        assert s.command.v == 0.0 and s.command.w == math.pi / 2 and s.done is None


def test_closed_loop_heads_for_the_door_after_the_spin():
    """The room is convex and seen whole by the 360-degree scan from its centre, so its only
    frontier lies past the door, where the hall is seen through it (grid map: free cells
    beside unknown ones, at the sides of the cone seen through the door). The nearest is just
    past the door, straight ahead: after the spin the robot drives at top speed straight at
    it (the path starts along its row, y = 4.55 m: the carrot is dead ahead)."""
    stack, steps = first_steps(GRID_CONFIG, room_with_door(True))
    assert steps[0].plan is not None and steps[0].plan.new_goal
    goal = steps[0].plan.goal
    assert 5.25 - 0.6 <= goal[0] <= 5.25 + 0.6 and 4.0 <= goal[1] <= 5.0       # at the door
    path = steps[0].plan.path
    assert (np.abs(path[path[:, 0] <= 3.5, 1] - 4.55) < 1e-9).all()                # straight ahead
    world = room_with_door(True)
    assert not any(world.collides(tuple(p), 0.26) for p in path)      # radius + margin, less the range noise
    assert_spins_for_four_seconds(steps)
    for s in steps[8:]:
        assert s.command.event is None and s.done is None
        assert s.command.v == pytest.approx(0.5, abs=1e-9) and s.command.w == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("config", [
    GRID_CONFIG,
    # the COM with free points 0.1 m apart: by default they are thinned to one per 0.3 m voxel
    # while only cells within 0.2 m of a training point are queried, which leaves unseen
    # cells inside seen free space (62 of the room's 816 inner cells from this scan), and
    # F > 0.6 on them
    StackConfig(**GIVEN, com=COMConfig(training={"free_step": 0.1, "free_voxel": 0.1})),
], ids=["grid", "com"])
def test_closed_loop_in_a_closed_room_spins_then_is_done(config):
    """Without the door the 360-degree scan sees the whole room: no frontier, so exploration is
    over from the first plan, but the robot still turns for 4 s before it says so; then it
    stands still."""
    stack, steps = first_steps(config, room_with_door(False))
    assert steps[0].plan.goal is None and steps[0].plan.done == "frontiers_exhausted"
    assert stack.explorer.blacklist.centres == []     # no frontier, not a blacklisted one
    assert_spins_for_four_seconds(steps)
    for s in steps[8:]:
        assert s.command.v == 0.0 and s.command.w == 0.0 and s.done == "frontiers_exhausted"


class CorrectedOnce:
    """Every scan at ``truth``, but the second (the second keyframe, mapped) localised at
    ``error`` composed with it, until the next scan closes a loop that moves it to ``truth``."""

    def __init__(self, truth: gtsam.Pose2, error: gtsam.Pose2):
        self.truth, self.error = truth, error
        self.keyframe_scans, self._poses = [], []

    def step(self, odometry, scan, given=None) -> Localisation:
        i = len(self._poses)
        self._poses.append(self.error.compose(self.truth) if i == 1 else self.truth)
        if i < 2:
            self.keyframe_scans.append(scan)
            return Localisation(self._poses[i], i)
        if i == 2:
            self._poses[1] = self.truth
            return Localisation(self.truth, loops=[(0, 1)], moved=0.1, corrected=True)
        return Localisation(self.truth)

    def pose(self, i: int) -> gtsam.Pose2:
        return self._poses[i]

    def positions(self, indices) -> np.ndarray:
        return np.array([[self._poses[i].x(), self._poses[i].y()] for i in indices]).reshape(-1, 2)

    def keyframe_poses(self) -> list[gtsam.Pose2]:
        return self._poses[:2]

    def loop_pairs(self) -> np.ndarray:
        return np.zeros((0, 2), int)


def test_a_map_left_where_its_scans_were_fused_is_relearnt_before_the_stop():
    """The room's second keyframe is fused 0.1 m off, and a loop then moves it back, under the
    COM's drift check (no later keyframe measures any drift): the stop is decided on the map
    relearnt at the corrected pose, and the run ends with that map, not the one it fused."""
    config = StackConfig(**GIVEN, com=COMConfig(training={"free_step": 0.1, "free_voxel": 0.1}))
    scan = Lidar(LidarConfig(fov_deg=360, beams=720), seed=0).scan(room_with_door(False), ROBOT, 0.0)
    stack = Stack(config)
    stack.localiser = CorrectedOnce(ROBOT, gtsam.Pose2(0.1, 0.0, 0.0))
    steps = [stack.step(None, dataclasses.replace(scan, timestamp=0.5 * k)) for k in range(8)]
    assert not any(s.regenerated or s.done for s in steps)          # the spin: the COM as fused
    fused = fed(ContinuousOccupancyMap(config.com), [ROBOT, gtsam.Pose2(0.1, 0, 0).compose(ROBOT)], [scan] * 2)
    np.testing.assert_array_equal(stack.map.prob(), fused.prob())
    steps += [stack.step(None, dataclasses.replace(scan, timestamp=0.5 * k)) for k in (8, 9)]
    assert steps[8].regenerated and steps[8].done == "frontiers_exhausted"
    assert stack.regenerations == 1 and stack.costmap_regenerations == 1
    at_truth = fed(ContinuousOccupancyMap(config.com), [ROBOT] * 2, [scan] * 2)
    np.testing.assert_array_equal(stack.map.prob(), at_truth.prob())
    assert not same(fused.prob(), at_truth.prob())
    assert not steps[9].regenerated and steps[9].done == "frontiers_exhausted"
