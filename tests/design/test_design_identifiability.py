"""Expected identifiability (Rust) against the NumPy reference, on the same draws."""

import edmf_rs
import numpy as np
import pytest
from edmf_rs import design
from edmf_rs.design import reference as ref
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats


@st.composite
def cases(draw):
    n = draw(st.integers(1, 60))
    n_loc = draw(st.integers(1, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        g = rng.integers(0, 4, size=(n, n_loc)).astype(np.float64)  # ties and values on bounds
    else:
        g = rng.normal(size=(n, n_loc)) * rng.uniform(0.1, 3, size=n_loc)
    g = g.astype(draw(st.sampled_from([np.float64, np.float32])))
    sd = rng.uniform(0.05, 1.0, size=n_loc)
    if draw(st.booleans()):
        combined = edmf_rs.combine(measurement=[stats.norm(0, sd)])
    else:
        combined = edmf_rs.combine(model=[stats.uniform(-sd, 2 * sd)], n_samples=2000, seed=1)
    m = draw(st.integers(1, n_loc))
    sensors = rng.permutation(n_loc)[:m].tolist()
    return g, combined, sensors, draw(st.integers(0, 1000))


@given(cases())
def test_sizes_match_the_reference_on_the_same_draws(case):
    g, combined, sensors, seed = case
    r = design.expected_identifiability(g, combined, sensors, n_simulations=40, seed=seed)
    expected = ref.expected_identifiability(g, combined, sensors, n_simulations=40, seed=seed)
    np.testing.assert_array_equal(r.sizes, expected)
    assert r.sizes.min() >= 0 and r.sizes.max() <= g.shape[0]


def test_candidate_counts_on_bounds_are_inclusive():
    g = np.array([[0.0], [1.0], [2.0], [3.0]])
    truth = np.array([1], dtype=np.uint64)
    residuals = np.zeros((1, 1))
    # y = 1; residual g - y in [-1, 1] keeps instances 0, 1, 2 (bounds included).
    sizes = edmf_rs._core.design_candidate_counts(g, [0], truth, residuals, np.array([-1.0]), np.array([1.0]))
    assert sizes.tolist() == [3]
    assert ref.candidate_counts(g, [0], truth, residuals, np.array([-1.0]), np.array([1.0])).tolist() == [3]


def test_curve_points_equal_single_sets_and_sidak_widens():
    rng = np.random.default_rng(3)
    g = rng.normal(size=(400, 5))
    combined = edmf_rs.combine(measurement=[stats.norm(0, 0.4)], n_sensors=5)
    curve = design.identifiability_curve(g, combined, [4, 2, 0], n_simulations=60, seed=5)
    for m in (1, 2, 3):
        single = design.expected_identifiability(g, combined, [4, 2, 0][:m], n_simulations=60, seed=5)
        np.testing.assert_array_equal(curve.sizes[m - 1], single.sizes)
    # A second sensor that repeats the first (same predictions, same residual
    # draws) is no new information, but Sidak widens the bounds of both: the
    # candidate sets can only grow.
    dup = np.column_stack([g[:, 0], g[:, 0]])
    s = np.random.default_rng(2).normal(0, 0.4, size=5000)
    c2 = edmf_rs.CombinedUncertainty(2, samples=np.column_stack([s, s]))
    one = design.expected_identifiability(dup, c2, [0], n_simulations=80, seed=1)
    two = design.expected_identifiability(dup, c2, [0, 1], n_simulations=80, seed=1)
    assert np.all(two.sizes >= one.sizes) and two.mean > one.mean


def test_summary_fractions():
    g = np.linspace(0, 10, 101)[:, None]
    u = edmf_rs.combine(measurement=[stats.norm(0, 0.5)], n_sensors=1)
    r = design.expected_identifiability(g, u, [0], n_simulations=100)
    s = r.summary()
    assert s["mean_fraction"] == pytest.approx(r.sizes.mean() / 101)
    assert s["p95"] == np.percentile(r.sizes, 95)


def test_bad_input():
    g = np.zeros((5, 3))
    u = edmf_rs.combine(measurement=[stats.norm(0, 1)], n_sensors=3)
    with pytest.raises(ValueError, match="^sensors:"):
        design.expected_identifiability(g, u, [0, 0])
    with pytest.raises(ValueError, match="^sensors:"):
        design.expected_identifiability(g, u, [3])
    with pytest.raises(ValueError, match="^combined:"):
        design.expected_identifiability(g, edmf_rs.combine(measurement=[stats.norm(0, 1)], n_sensors=2), [0])
    with pytest.raises(ValueError, match="^n_simulations:"):
        design.expected_identifiability(g, u, [0], n_simulations=0)
