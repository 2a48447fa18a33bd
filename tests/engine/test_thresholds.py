"""Threshold bounds (Eqs. 5 and 6): Rust shortest intervals against the NumPy
reference, closed forms for distributions, and the three corrections."""

import math

import edmf_rs
import numpy as np
import pytest
from edmf_rs import reference
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import stats


@given(
    samples=st.integers(2, 6).flatmap(
        lambda n_m: arrays(np.float64, st.tuples(st.integers(20, 400), st.just(n_m)),
                           elements=st.floats(-1e6, 1e6, allow_nan=False))),
    phi=st.floats(0.05, 0.95),
    correction=st.sampled_from(["sidak", "bonferroni", "none"]),
)
def test_sample_thresholds_match_reference(samples, phi, correction):
    p = edmf_rs.sensor_probability(phi, samples.shape[1], correction)
    if samples.shape[0] < math.ceil(1 / (1 - p)):
        with pytest.raises(ValueError, match="samples are needed"):
            edmf_rs.threshold_bounds(samples, phi, correction, estimator="shortest")
        return
    got = edmf_rs.threshold_bounds(samples, phi, correction, estimator="shortest")  # the plain window
    want = reference.threshold_bounds(samples, phi, correction)
    np.testing.assert_array_equal(got.low, want.low)
    np.testing.assert_array_equal(got.high, want.high)
    assert got.probability == want.probability and got.correction == correction


@pytest.mark.parametrize("layout", ["C", "F", "strided"])
def test_skewed_and_bimodal_samples(layout):
    rng = np.random.default_rng(11)
    n = 40_000
    skewed = rng.exponential(1.0, n)
    # 70 % of the mass near 0, 30 % near 10: the shortest 60 % interval sits in the big mode.
    bimodal = np.where(rng.random(n) < 0.7, rng.normal(0, 0.1, n), rng.normal(10, 0.1, n))
    samples = np.column_stack([skewed, bimodal])
    if layout == "F":
        samples = np.asfortranarray(samples)
    elif layout == "strided":
        samples = np.repeat(samples, 2, axis=1)[:, ::2]
    t = edmf_rs.threshold_bounds(samples, phi=0.6 ** 2, estimator="shortest")  # per-sensor probability 0.6
    want = reference.threshold_bounds(np.ascontiguousarray(samples), phi=0.6 ** 2)
    np.testing.assert_array_equal(t.low, want.low)
    np.testing.assert_array_equal(t.high, want.high)
    # Exponential: the shortest interval starts at the mode, 0, and ends at -ln(1 - p).
    assert t.low[0] < 1e-3 and abs(t.high[0] + math.log(0.4)) < 0.03
    assert -0.5 < t.low[1] < t.high[1] < 0.5


def test_ties_in_samples_pick_the_lowest_window():
    samples = np.array([[0.0], [1.0], [2.0], [3.0]])
    t = edmf_rs.threshold_bounds(samples, phi=0.5, correction="none", estimator="shortest")
    assert (t.low[0], t.high[0]) == (0.0, 1.0)


def test_normal_uses_eq6_and_matches_sidak_probability():
    sd = np.array([1.0, 2.0, 0.5])
    mean = np.array([0.0, -1.0, 3.0])
    t = edmf_rs.threshold_bounds(stats.norm(mean, sd), phi=0.95)
    p = 0.95 ** (1 / 3)
    z = stats.norm.ppf(0.5 + p / 2)
    np.testing.assert_allclose(t.low, mean - z * sd, rtol=1e-12)
    np.testing.assert_allclose(t.high, mean + z * sd, rtol=1e-12)
    assert t.probability == pytest.approx(p)


@pytest.mark.parametrize("dist", [stats.expon(scale=2.0), stats.lognorm(0.6), stats.gamma(2.5), stats.beta(2, 5)])
def test_asymmetric_distributions_get_their_shortest_interval(dist):
    t = edmf_rs.threshold_bounds([dist], phi=0.9)
    lo, hi = t.low[0], t.high[0]
    assert dist.cdf(hi) - dist.cdf(lo) == pytest.approx(0.9, abs=1e-9)
    want = reference.shortest_interval_of(dist, 0.9)
    assert hi - lo <= (want[1] - want[0]) + 1e-9  # at least as short as a brute-force search
    central = dist.ppf(0.95) - dist.ppf(0.05)
    assert hi - lo < central


def test_corrections():
    assert edmf_rs.sensor_probability(0.95, 10, "sidak") == pytest.approx(0.95 ** 0.1)
    assert edmf_rs.sensor_probability(0.95, 10, "bonferroni") == pytest.approx(0.995)
    assert edmf_rs.sensor_probability(0.95, 10, "none") == 0.95
    t = edmf_rs.threshold_bounds(stats.norm(np.zeros(10), 1.0), phi=0.95, correction="bonferroni")
    assert t.high[0] == pytest.approx(stats.norm.ppf(1 - 0.05 / 20))


def test_combined_normal_is_exact_and_monte_carlo_is_close():
    y = np.array([1.0, 2.0, 4.0])
    model = edmf_rs.relative_to_measured(stats.norm(-0.10, 0.15), y)
    exact = edmf_rs.combine(model=[model], measurement=[stats.norm(0, 0.02)])
    assert exact.exact
    np.testing.assert_allclose(exact.mean, -0.1 * y)
    np.testing.assert_allclose(exact.std, np.sqrt((0.15 * y) ** 2 + 0.02 ** 2))
    # A uniform source forces Monte Carlo; its bounds approach the exact ones as it narrows.
    mc = edmf_rs.combine(model=[model, stats.uniform(-1e-9, 2e-9)], measurement=[stats.norm(0, 0.02)],
                         n_samples=400_000, seed=1)
    assert not mc.exact and mc.samples.shape == (400_000, 3)
    t_exact = edmf_rs.threshold_bounds(exact)
    t_mc = edmf_rs.threshold_bounds(mc)
    np.testing.assert_allclose(t_mc.low, t_exact.low, rtol=0.02)
    np.testing.assert_allclose(t_mc.high, t_exact.high, rtol=0.02)
    again = edmf_rs.combine(model=[model, stats.uniform(-1e-9, 2e-9)], measurement=[stats.norm(0, 0.02)],
                            n_samples=400_000, seed=1)
    np.testing.assert_array_equal(mc.samples, again.samples)


def test_combine_subtracts_measurement_sources():
    # U_c = model - measurement (Eq. 4): a measurement mean of +1 shifts U_c by -1.
    c = edmf_rs.combine(model=stats.norm(0, 1), measurement=[[stats.norm(1, 1), stats.norm(2, 1)]])
    np.testing.assert_allclose(c.mean, [-1.0, -2.0])
    np.testing.assert_allclose(c.std, np.sqrt(2.0))


def test_relative_to_measured_handles_negative_readings():
    y = np.array([2.0, -2.0])
    n = edmf_rs.relative_to_measured(stats.norm(-0.1, 0.15), y)
    np.testing.assert_allclose(n.mean(), [-0.2, 0.2])
    np.testing.assert_allclose(n.std(), [0.3, 0.3])
    u = edmf_rs.relative_to_measured(stats.uniform(0.0, 0.1), y)  # U[0, 10 %] of y
    np.testing.assert_allclose(u.support()[0], [0.0, -0.2])
    np.testing.assert_allclose(u.support()[1], [0.2, 0.0])
    with pytest.raises(ValueError, match="measured"):
        edmf_rs.relative_to_measured(stats.lognorm(0.5), y)


def test_uniform_combined_samples_give_the_rectangle_of_eq7():
    # Sum of two uniforms is triangular: symmetric, so the shortest interval is central.
    c = edmf_rs.combine(model=stats.uniform(-1, 2), measurement=stats.uniform(-1, 2), n_sensors=2,
                        n_samples=200_000, seed=0)
    t = edmf_rs.threshold_bounds(c, phi=0.81)  # 0.9 per sensor
    half = 2 - 2 * math.sqrt(0.1)  # triangular on [-2, 2]: P(|X| <= h) = 0.9
    np.testing.assert_allclose(t.high, half, atol=0.02)
    np.testing.assert_allclose(t.low, -half, atol=0.02)
