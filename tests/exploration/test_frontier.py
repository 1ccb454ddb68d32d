import numpy as np
import pytest

from exploration.frontier import FrontierMap, frontier_map, frontier_map_within, l1_gradient

RES = 0.1


def grid(n=120):
    c = (np.arange(n) + 0.5) * RES
    return np.meshgrid(c, c)


def test_l1_gradient_of_a_plane():
    x, y = grid()
    g = l1_gradient(2.0 * x - 3.0 * y, RES)
    np.testing.assert_allclose(g, 5.0, atol=1e-9)


def test_free_disc_in_unknown_space_gives_its_rim():
    x, y = grid()
    r = np.hypot(x - 6.0, y - 6.0)
    # free (0.1) inside 3 m, unknown (0.5) outside, a smooth step 0.2 m wide
    prob = 0.5 - 0.4 / (1 + np.exp((r - 3.0) / 0.05))
    prob_occ = np.full_like(prob, 0.5)
    f = frontier_map(prob, prob_occ, RES, beta=2.5)
    rim = np.abs(r - 3.0) < 0.1
    assert f[rim].min() > 0.8
    assert np.abs(r[np.unravel_index(np.argmax(f), f.shape)] - 3.0) < 0.1
    assert np.abs(f[(r < 2.0) | (r > 4.0)]).max() < 1e-3  # flat inside and outside


def test_obstacles_give_no_frontier():
    x, y = grid()
    # a wall across free space: high in Λ and in Λo
    wall = np.exp(-((x - 6.0) / 0.1) ** 2)
    prob = 0.1 + 0.85 * wall
    prob_occ = 0.5 + 0.45 * wall
    f = frontier_map(prob, prob_occ, RES, beta=2.5)
    assert f.max() <= 1e-9
    # the same Λ step without the obstacle evidence is a frontier
    assert frontier_map(prob, np.full_like(prob, 0.5), RES).max() > 1.0


def test_units_are_per_meter():
    x, y = grid()
    prob = np.clip(0.5 - 0.2 * (x - 6.0), 0.1, 0.5)
    occ = np.full_like(prob, 0.5)
    coarse = frontier_map(prob[::2, ::2], occ[::2, ::2], 2 * RES, smoothing=0)
    fine = frontier_map(prob, occ, RES, smoothing=0)
    assert coarse[30, 28] == pytest.approx(fine[60, 56], rel=1e-6)


def test_shape_mismatch_is_rejected():
    with pytest.raises(ValueError, match="same shape"):
        frontier_map(np.zeros((3, 3)), np.zeros((3, 4)), RES)


@pytest.mark.parametrize("smoothing", [0.0, 0.1, 0.25])
def test_the_frontier_map_within_a_box_is_the_whole_map_s_there(smoothing):
    """Boxes inside the map, on its edges and corners, one cell and the whole map: F computed
    on a box and its margin equals the whole map's F there, to the last bit (the smoothing
    and differences read the same cells); without the margin (the box alone) it does not."""
    rng = np.random.default_rng(8)
    prob = np.clip(rng.random((70, 90)) * 0.3 + (rng.random((70, 90)) < 0.4) * 0.5, 0.0, 1.0)
    prob_occ = rng.random((70, 90))
    whole = frontier_map(prob, prob_occ, RES, smoothing=smoothing)
    boxes = [((20, 35), (30, 52)), ((0, 9), (0, 12)), ((61, 70), (80, 90)), ((0, 70), (44, 45)),
             ((33, 34), (51, 52)), ((0, 70), (0, 90))]
    for rows, cols in boxes:
        box = frontier_map_within(prob, prob_occ, RES, rows, cols, smoothing=smoothing)
        assert np.array_equal(box, whole[rows[0]:rows[1], cols[0]:cols[1]]), (rows, cols)
    alone = frontier_map(prob[20:35, 30:52], prob_occ[20:35, 30:52], RES, smoothing=smoothing)
    assert not np.allclose(alone, whole[20:35, 30:52])


def test_the_frontier_map_between_updates_is_the_whole_map_s():
    """A map updated in a box at a time (a scan's reach), in one cell, at its edges, not at
    all, then grown: after each update ``FrontierMap`` equals F of the whole map to the last
    bit, and the arrays it gave before stay as they were."""
    rng = np.random.default_rng(3)
    prob = np.clip(rng.random((70, 90)) * 0.3 + (rng.random((70, 90)) < 0.4) * 0.5, 0.0, 1.0)
    prob_occ = rng.random((70, 90))
    frontier = FrontierMap(beta=2.5, smoothing=0.1)
    given = []
    updates = [(None, None), (slice(20, 35), slice(30, 52)), (slice(40, 41), slice(7, 8)),
               (slice(0, 5), slice(80, 90)), (slice(60, 70), slice(0, 90)), (slice(0, 0), slice(0, 0))]
    for rows, cols in updates:
        if rows is not None:
            prob[rows, cols] = rng.random(prob[rows, cols].shape)
            prob_occ[rows, cols] = rng.random(prob[rows, cols].shape)
        values = frontier(prob, prob_occ, RES, (0.0, 0.0))
        assert np.array_equal(values, frontier_map(prob, prob_occ, RES, 2.5, 0.1))
        given.append((values, values.copy()))
    grown = np.pad(prob, ((0, 5), (3, 0)), constant_values=0.5)
    grown_occ = np.pad(prob_occ, ((0, 5), (3, 0)), constant_values=0.5)
    assert np.array_equal(frontier(grown, grown_occ, RES, (-0.3, 0.0)),
                          frontier_map(grown, grown_occ, RES, 2.5, 0.1))
    assert all(np.array_equal(values, kept) for values, kept in given)
