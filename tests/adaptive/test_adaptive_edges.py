"""The edges of the kept region (issue 16): the runs that decide the candidate
ranges go to the kept points at each parameter's ends, walked on the
emulator's mean to the extreme of the region, and the model decides."""

import warnings

import edmf_rs
import numpy as np
import pytest
from edmf_rs import reference
from edmf_rs.adaptive import adaptive_falsify, waves
from edmf_rs.adaptive.design import edge_points, edge_rows
from edmf_rs.adaptive.edges import push, walk
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays


def test_edge_points_are_the_kept_points_with_each_parameters_lowest_and_highest_values():
    kept = np.array([[0.50, 0.20, 0.9],   # 0
                     [0.10, 0.60, 0.5],   # 1: lowest x0
                     [0.90, 0.55, 0.4],   # 2: highest x0
                     [0.30, 0.05, 0.6],   # 3: lowest x1
                     [0.40, 0.95, 0.1],   # 4: highest x1, lowest x2
                     [0.60, 0.50, 0.99],  # 5: highest x2
                     [0.20, 0.40, 0.2],   # 6: 2nd lowest x0, 2nd lowest x2
                     [0.80, 0.70, 0.7]])  # 7: 2nd highest x0
    # one per end: lows of x0, x1, x2, then highs of x0, x1, x2; row 4 is an end twice, kept once
    assert edge_points(kept, 1).tolist() == [1, 3, 4, 2, 5]
    # two per end: x0 lows 1, 6; x1 lows 3, 0; x2 lows 4, 6; x0 highs 2, 7; x1 highs 4, 7; x2 highs 5, 0
    assert edge_points(kept, 2).tolist() == [1, 6, 3, 0, 4, 2, 7, 5]
    rows, cols, signs = edge_rows(kept, 1)
    assert rows.tolist() == [1, 3, 4, 2, 4, 5]
    assert cols.tolist() == [0, 1, 2, 0, 1, 2] and signs.tolist() == [-1, -1, -1, 1, 1, 1]
    # more per end than points: every point, once
    assert sorted(edge_points(kept[:3], 10).tolist()) == [0, 1, 2]


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 30), st.integers(1, 4)), elements=st.floats(0, 1)),
       st.integers(1, 5))
def test_edge_points_match_a_brute_force_oracle(points, n):
    expected = []
    for sign in (1, -1):
        for j in range(points.shape[1]):
            ranked = sorted(range(points.shape[0]), key=lambda i: (sign * points[i, j], i))
            expected += ranked[:n]
    unique = [i for k, i in enumerate(expected) if i not in expected[:k]]
    assert edge_points(points, n).tolist() == unique


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_edge_points_reject_a_bad_count(bad):
    with pytest.raises(ValueError, match="n_per_end"):
        edge_points(np.zeros((3, 2)), bad)


def band(u):
    """A thin slanted band: x0 - 0.5 x2 in [0.29, 0.31]; its x0 ends are at corners (x2 = 0, 1)."""
    s = u[:, 0] - 0.5 * u[:, 2]
    return (s >= 0.29) & (s <= 0.31)


def test_walk_reaches_the_corner_an_axis_push_misses():
    start = np.array([[0.45, 0.5, 0.3], [0.55, 0.5, 0.5]])
    axes, signs = np.array([0, 0]), np.array([-1.0, 1.0])
    pushed = push(start, axes, signs, band)
    np.testing.assert_allclose(pushed[:, 0], [0.29 + 0.15, 0.31 + 0.25], atol=1e-6)  # stays on its x2 line
    walked = walk(start, axes, signs, band)
    assert band(walked).all()
    np.testing.assert_allclose(walked[:, 0], [0.29, 0.81], atol=1e-4)  # x0's true ends (x2 = 0 and 1)


def slanted(theta):
    return np.column_stack([theta[:, 0] - 0.5 * theta[:, 2], theta[:, 1]])


def _run():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return adaptive_falsify(slanted, [[0, 1]] * 3, [0.3, 0.5], edmf_rs.Thresholds([-0.01, -0.4], [0.01, 0.4]),
                                budget=150, n_screen=4096, seed=0)


def test_a_thin_kept_region_gets_its_true_candidate_ranges(monkeypatch):
    """The candidate set's x0 range is [0.29, 0.81] (x2 at its bounds). Edge
    points walked to the corners find it; one axis-pushed point per end (the
    earlier rule) stopped short."""
    new = _run()
    y, t = np.array([0.3, 0.5]), edmf_rs.Thresholds([-0.01, -0.4], [0.01, 0.4])
    ref = reference.falsify(new.run_predictions, y, t)  # the model decides
    np.testing.assert_array_equal(new.falsification.candidate_indices, ref.candidate_indices)
    c = new.candidate_parameters
    np.testing.assert_allclose([c[:, 0].min(), c[:, 0].max()], [0.29, 0.81], atol=5e-4)
    np.testing.assert_allclose([c[:, 2].min(), c[:, 2].max()], [0.0, 1.0], atol=1e-3)
    monkeypatch.setattr(waves, "EDGE_POINTS", 1)
    monkeypatch.setattr(waves, "WALK", False)
    old = _run().candidate_parameters
    # Both find an end by bisection to 2^-24 of the box (`push`'s steps): below that, ends are equal.
    res = 2.0**-24
    assert (c.min(axis=0) <= old.min(axis=0) + res).all() and (c.max(axis=0) >= old.max(axis=0) - res).all()
    assert c[:, 0].min() < old[:, 0].min() - 1e-3 or c[:, 0].max() > old[:, 0].max() + 1e-3
