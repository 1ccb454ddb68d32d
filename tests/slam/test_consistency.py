"""The map's self-consistency: how far scan points lie from the surfaces seen there on a revisit."""

import math

import gtsam
import numpy as np
import pytest

from slam.consistency import revisit_distances, self_consistency, travel
from wall_scans import cast

CORRIDOR = [(1, 0.0, -50, 50), (1, 2.0, -50, 50)]          # two walls along x, 2 m apart
ROOM = CORRIDOR + [(0, -3.0, 0, 2), (0, 6.0, 0, 2)]         # closed at both ends


def two_passes(shift: gtsam.Pose2, walls=ROOM):
    """Scans from x = 0…3 m along the corridor's middle, taken once and again 100 m of travel
    later; the second pass believed ``shift`` (in the world frame) away from where it was."""
    truth = [gtsam.Pose2(0.5 * i, 1.0, 0.1 * i) for i in range(7)]
    scans = [cast(p, walls).points() for p in truth] * 2
    believed = truth + [gtsam.Pose2(shift.x() + p.x(), shift.y() + p.y(), shift.theta() + p.theta())
                        for p in truth]
    driven = np.concatenate([np.linspace(0.0, 3.0, 7), np.linspace(103.0, 106.0, 7)])
    return believed, scans, driven


def test_a_pass_believed_off_across_the_walls_lies_that_far_from_the_first():
    # 7 cm across the corridor: every point seen again lies 7 cm off the other pass's walls,
    # read along their normal
    believed, scans, driven = two_passes(gtsam.Pose2(0.0, 0.07, 0.0), CORRIDOR)
    d = revisit_distances(believed, scans, driven=driven)
    seen = d[np.isfinite(d)]
    assert seen.size > 0.9 * d.size
    np.testing.assert_allclose(seen, 0.07, atol=1e-9)
    summary = self_consistency(d)
    assert math.isclose(summary["median_m"], 0.07) and math.isclose(summary["p90_m"], 0.07)


def test_a_shift_along_a_featureless_corridor_is_not_seen():
    # what the measure cannot see, as scan matching cannot: a pass believed 0.3 m along an open
    # corridor lays its walls on the same lines; only where one pass saw 0.3 m of wall farther
    # than the other (the laser's range ends it) do points meet the other's last hits, which
    # have no normal, point to point
    believed, scans, driven = two_passes(gtsam.Pose2(0.3, 0.0, 0.0), CORRIDOR)
    d = revisit_distances(believed, scans, driven=driven)
    assert np.median(d) < 1e-9 and np.mean(d < 1e-9) > 0.95
    # with the corridor's ends in view, the ends' points show the shift
    believed, scans, driven = two_passes(gtsam.Pose2(0.3, 0.0, 0.0), ROOM)
    d = revisit_distances(believed, scans, driven=driven)
    assert math.isclose(np.nanmax(d), 0.3, rel_tol=1e-6)


def test_scans_close_in_travel_are_not_a_revisit():
    # one pass only, 3 m of travel: nothing is seen again; a pass beyond the radius neither
    believed, scans, driven = two_passes(gtsam.Pose2())
    assert np.isnan(revisit_distances(believed[:7], scans[:7], driven=driven[:7])).all()
    believed, scans, driven = two_passes(gtsam.Pose2(0.0, 0.7, 0.0), CORRIDOR)
    assert self_consistency(revisit_distances(believed, scans, driven=driven, radius=0.5)) == {
        "revisited": 0.0, "median_m": None, "p90_m": None, "mean_m": None}


def test_a_revisit_behind_many_scans_of_a_robot_standing_still_is_found():
    # 40 scans from one spot (their nearest neighbours are each other: too near in travel), then
    # one scan 6 cm across the corridor after 50 m: every point of the standing scans finds it
    here = gtsam.Pose2(1.0, 1.0, 0.2)
    scan = cast(here, CORRIDOR).points()
    believed = [here] * 40 + [gtsam.Pose2(1.0, 1.06, 0.2)]
    driven = np.array([0.0] * 40 + [50.0])
    d = revisit_distances(believed, [scan] * 41, driven=driven)
    np.testing.assert_allclose(d, 0.06, atol=1e-9)


def test_travel_is_the_distance_driven():
    poses = [gtsam.Pose2(0, 0, 0), gtsam.Pose2(3, 4, 1), gtsam.Pose2(3, 4, 2), gtsam.Pose2(3, 0, 0)]
    np.testing.assert_allclose(travel(poses), [0, 5, 5, 9])


def test_each_point_meets_the_nearest_point_of_the_scans_far_enough_in_travel():
    # against every pair of points, on a drive down a corridor and half-way back that stops
    # (equal travel) and turns on the way: the nearest point within the radius among the scans
    # at least 5 m of travel away, read along its normal (or point to point without one)
    from slam.config import RegistrationConfig
    from slam.registration import scan_normals, transform

    rng = np.random.default_rng(4)
    x = np.concatenate([np.linspace(0.0, 20.0, 41), np.linspace(19.5, 10.0, 20)])
    x = np.repeat(x, rng.choice([1, 2], size=len(x)))                  # stops
    truth = [gtsam.Pose2(xi, rng.uniform(0.6, 1.4), rng.uniform(-np.pi, np.pi)) for xi in x]
    scans = [cast(p, CORRIDOR, n=37, max_range=3.0).points() for p in truth]
    driven = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(x)))])
    d = revisit_distances(truth, scans, driven=driven, radius=0.3)

    world = np.concatenate([transform(p, s) for p, s in zip(truth, scans)])
    normal = np.concatenate([transform(gtsam.Pose2(0, 0, p.theta()), scan_normals(s, RegistrationConfig()))
                             for p, s in zip(truth, scans)])
    at = np.concatenate([np.full(len(s), t) for s, t in zip(scans, driven)])
    pairwise = np.linalg.norm(world[:, None] - world[None], axis=2)
    pairwise[np.abs(at[:, None] - at[None]) < 5.0] = np.inf
    q = np.argmin(pairwise, axis=1)
    seen = pairwise[np.arange(len(world)), q] < 0.3
    offset = world - world[q]
    along = np.abs(np.sum(offset * normal[q], axis=1))
    expected = np.where(np.isfinite(along), along, np.linalg.norm(offset, axis=1))
    assert 0.2 < seen.mean() < 0.95          # revisits and first visits both
    np.testing.assert_array_equal(np.isfinite(d), seen)
    np.testing.assert_allclose(d[seen], expected[seen], rtol=0, atol=1e-12)


def test_the_travel_must_not_decrease():
    believed, scans, driven = two_passes(gtsam.Pose2())
    with pytest.raises(ValueError, match="driven"):
        revisit_distances(believed, scans, driven=driven[::-1])
