"""Probe of threshold bounds (Eqs. 5-7) against independent references: scipy's
closed-form quantiles, computed here without the code under test."""

import warnings

import edmf_rs
import numpy as np
import pytest
from edmf_rs.engine import intervals
from edmf_rs.engine.distributions import distribution
from scipy import stats


@pytest.mark.parametrize("kind", ["combine", "list", "vectorised"])
@pytest.mark.parametrize(("phi", "n_m", "correction"), [(0.999999, 50, "sidak"), (0.999999, 50, "bonferroni")])
def test_normal_upper_bound_keeps_the_digits_of_a_small_tail(kind, phi, n_m, correction):
    # Eq. 6 for a normal U_c: T_high = F^-1(1 - tail) = isf(tail), with tail = (1 - p)/2.
    # With p = 1 - 2e-8, 1 - tail rounds away ~1e-8 of the tail: the old bound was off by ~1e-10 of the width.
    p = phi ** (1 / n_m) if correction == "sidak" else 1 - (1 - phi) / n_m
    tail = (1 - p) / 2
    want_low, want_high = stats.norm.ppf(tail, 0.5, 2.0), stats.norm.isf(tail, 0.5, 2.0)
    if kind == "combine":
        combined = edmf_rs.combine(model=stats.norm(0.5, 2.0), measurement=stats.norm(0, 1e-300), n_sensors=n_m)
    elif kind == "list":
        combined = [stats.norm(0.5, 2.0)] * n_m
    else:
        combined = stats.norm(np.full(n_m, 0.5), 2.0)
    t = edmf_rs.threshold_bounds(combined, phi, correction)
    width = want_high - want_low
    np.testing.assert_allclose(t.low, want_low, rtol=0, atol=1e-13 * width)
    np.testing.assert_allclose(t.high, want_high, rtol=0, atol=1e-13 * width)
    assert t.method == ("exact",) * n_m


def test_shortest_interval_of_a_skewed_distribution_near_p_one():
    # Exponential: the shortest interval holding p is [0, -ln(1 - p)] (density decreasing from 0).
    p = 1 - 1e-9 + 2 ** -40  # not representable as 1 - (tail) with a round tail
    d = stats.expon(scale=3.0)
    low, high = intervals.shortest_interval(d, p)
    want = -3.0 * np.log1p(-p)
    assert low >= 0 and low < 1e-12 * want
    assert abs(high - want) <= 1e-12 * want
    # the interval holds p: its upper tail is 1 - p, to 1e-9 of the tail itself
    assert abs(d.sf(high) + d.cdf(low) - (1 - p)) <= 1e-9 * (1 - p)


def test_raw_samples_with_the_plain_estimator_warn_of_thin_tails():
    # Documented: a UserWarning for Monte Carlo sensors with fewer than ~100 samples per tail.
    # 5000 samples, p = 0.95**(1/2): about 0.5 * 5000 * (1 - p) = 63 samples per tail.
    samples = np.random.default_rng(0).normal(size=(5000, 2))
    with pytest.warns(UserWarning, match="Monte Carlo samples fall in each tail"):
        edmf_rs.threshold_bounds(samples, 0.95, estimator="shortest")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # enough samples: no warning
        edmf_rs.threshold_bounds(np.random.default_rng(0).normal(size=(50_000, 2)), 0.95, estimator="shortest")


@pytest.mark.parametrize(("name", "params", "match"), [
    (3, {}, "name: expected the name of a distribution"),
    ("normal", [("sd", 1.0)], "params: expected a dict"),
])
def test_distribution_by_name_refuses_wrong_types_naming_the_argument(name, params, match):
    with pytest.raises(TypeError, match=match):
        distribution(name, params)
