"""Threshold bounds of U_c by numerical convolution (Eq. 4) against an independent reference:
the cdf of U_c = sign_a A + sign_b B as the convolution integral by composite Gauss-Legendre
quadrature (panels split at the sources' edges),
its quantiles by brentq and the shortest interval by a bounded scalar minimisation."""

import math

import edmf_rs
import numpy as np
import pytest
from edmf_rs.engine import convolution, intervals
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import optimize, stats

_GL = np.polynomial.legendre.leggauss(20)


class Reference:
    """cdf of sa*A + sb*B: integral over t of pdf_{sa A}(t) * P(sb B <= x - t)."""

    def __init__(self, a, sa, b, sb):
        self.a, self.sa, self.b, self.sb = a, sa, b, sb
        lo, hi = a.ppf(1e-15), a.isf(1e-15)
        lo, hi = (lo, hi) if sa > 0 else (-hi, -lo)
        self.t = (lo, hi)
        self.edges_b = [sb * e for e in b.support() if np.isfinite(e)]
        self.kinks_a = [sa * e for e in a.support() if np.isfinite(e)]
        # panels between A's quantiles too, so a long tail does not starve the bulk of nodes
        self.quantiles_a = list(sa * a.ppf([1e-9, 1e-6, 1e-3, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999,
                                            1 - 1e-6, 1 - 1e-9]))
        lb, hb = b.ppf(1e-15), b.isf(1e-15)
        self.range = (lo + min(sb * lb, sb * hb), hi + max(sb * lb, sb * hb))

    def cdf(self, x):
        pts = [x - e for e in self.edges_b] + self.kinks_a + self.quantiles_a
        cuts = np.unique(np.clip([*self.t, *pts], *self.t))
        # composite Gauss-Legendre (20 nodes on 64 panels between consecutive kinks):
        # the integrand is smooth on each panel, so the sum converges fast
        u, w = _GL
        left = np.concatenate([np.linspace(a, b, 65)[:-1] for a, b in zip(cuts[:-1], cuts[1:])])
        width = np.concatenate([np.full(64, (b - a) / 64) for a, b in zip(cuts[:-1], cuts[1:])])
        t = (left[:, None] + width[:, None] * (u[None, :] + 1) / 2).ravel()
        y = x - t
        g = self.b.cdf(y) if self.sb > 0 else self.b.sf(-y)
        f = self.a.pdf(self.sa * t) * g
        return float(np.sum(f.reshape(-1, u.size) * w[None, :] * width[:, None] / 2))

    def quantile(self, q):
        return optimize.brentq(lambda x: self.cdf(x) - q, *self.range, xtol=1e-13, rtol=1e-13)

    def shortest(self, p):
        def width(alpha):
            return self.quantile(alpha + p) - self.quantile(alpha)

        grid = np.linspace(0, 1 - p, 21)[1:-1]
        w = [width(a) for a in grid]
        k = int(np.argmin(w))
        lo, hi = (grid[k - 1] if k else 1e-9), (grid[k + 1] if k + 1 < grid.size else 1 - p - 1e-9)
        best = optimize.minimize_scalar(width, bounds=(lo, hi), method="bounded",
                                        options={"xatol": 1e-10 * (1 - p)})
        a = best.x if best.fun <= w[k] else grid[k]
        return self.quantile(a), self.quantile(a + p)


def test_reference_matches_a_closed_form():
    ref = Reference(stats.norm(0, 1), 1.0, stats.norm(0, 1), -1.0)  # N(0, 2)
    lo, hi = ref.shortest(0.95)
    z = stats.norm.ppf(0.975) * math.sqrt(2)
    assert hi == pytest.approx(z, abs=1e-7) and lo == pytest.approx(-z, abs=1e-7)


def _check(ref, b, p, j=0, bound_tol=None):
    """Coverage >= p under the reference, width at most 0.1 % over the reference's shortest,
    and (well-conditioned cases) each bound within bound_tol of the width."""
    lo, hi = ref.shortest(p)
    width = hi - lo
    coverage = ref.cdf(b.high[j]) - ref.cdf(b.low[j])
    assert coverage >= p - 1e-9, (coverage, p)
    assert b.high[j] - b.low[j] <= width * (1 + 1e-3), (b.high[j] - b.low[j], width)
    if bound_tol is not None:
        assert abs(b.low[j] - lo) <= bound_tol * width and abs(b.high[j] - hi) <= bound_tol * width
    return lo, hi


@pytest.mark.parametrize("n_m", [10, 50])
def test_normal_plus_uniform_meets_the_issue_targets(n_m):
    model, measurement = stats.norm(0, 1), stats.uniform(-2, 4)
    t = edmf_rs.threshold_bounds(edmf_rs.combine(model=model, measurement=measurement, n_sensors=n_m))
    assert set(t.method) == {"convolution"} and not t.monte_carlo
    ref = Reference(model, 1.0, measurement, -1.0)
    lo, hi = ref.shortest(t.probability)
    width = hi - lo
    assert np.all(np.abs(t.low - lo) <= 0.005 * width) and np.all(np.abs(t.high - hi) <= 0.005 * width)
    assert np.all(t.width <= 1.01 * width)
    assert np.all(ref.cdf(t.high[0]) - ref.cdf(t.low[0]) >= t.probability)
    # far tighter than the issue's targets: the numerical error is below 1e-4 of the width
    assert np.all(np.abs(t.low - lo) <= 2e-4 * width) and np.all(t.se_low <= 1e-4 * width)


@pytest.mark.parametrize("n_m", [10, 50])
def test_lognormal_plus_normal_meets_the_issue_targets(n_m):
    model, measurement = stats.lognorm(0.5), stats.norm(0, 0.3)
    t = edmf_rs.threshold_bounds(edmf_rs.combine(model=model, measurement=measurement, n_sensors=n_m))
    assert set(t.method) == {"convolution"}
    ref = Reference(model, 1.0, measurement, -1.0)
    lo, hi = ref.shortest(t.probability)
    width = hi - lo
    assert np.all(np.abs(t.low - lo) <= 0.005 * width) and np.all(np.abs(t.high - hi) <= 0.005 * width)
    assert np.all(t.width <= 1.01 * width)
    assert ref.cdf(t.high[0]) - ref.cdf(t.low[0]) >= t.probability
    assert np.all(np.abs(t.high - hi) <= 2e-4 * width)


def _family(kind, scale, shape):
    if kind == "norm":
        return stats.norm(0.3 * scale, scale)
    if kind == "uniform":
        return stats.uniform(-scale, 2 * scale * (0.5 + shape))
    if kind == "lognorm":
        return stats.lognorm(0.1 + 0.7 * shape, scale=scale)
    if kind == "triang":
        return stats.triang(shape, loc=-scale, scale=2 * scale)
    return stats.truncnorm(-0.5 - 2 * shape, 1.0 + shape, loc=0.1, scale=scale)


KINDS = ["norm", "uniform", "lognorm", "triang", "truncnorm"]


@given(ka=st.sampled_from(KINDS), kb=st.sampled_from(KINDS), sa=st.floats(0.1, 10.0), sb=st.floats(0.1, 10.0),
       shape_a=st.floats(0.05, 0.95), shape_b=st.floats(0.05, 0.95),
       signs=st.sampled_from([(1.0, -1.0), (1.0, 1.0), (-1.0, -1.0)]), p=st.floats(0.8, 0.999))
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_sources_match_the_independent_reference(ka, kb, sa, sb, shape_a, shape_b, signs, p):
    a, b = _family(ka, sa, shape_a), _family(kb, sb, shape_b)
    ref = Reference(a, signs[0], b, signs[1])
    # as threshold_bounds does: the central interval when every source is symmetric (a flat-topped
    # U_c, e.g. uniform + uniform, has no unique shortest interval)
    sym = [intervals.is_symmetric(a) and intervals.is_symmetric(b)]
    bounds = convolution.shortest_bounds([((signs[0], a), (signs[1], b))], p, symmetric=sym)
    _check(ref, bounds, p)
    assert bounds.error[0] <= 1e-3 * (bounds.high[0] - bounds.low[0])


def test_a_flat_topped_combined_uncertainty_gets_a_shortest_window_not_a_wandering_one():
    # Found by the property test above: a narrow lognormal plus a wide uniform has a flat top, so many
    # windows are shortest; the grid's choice among them moved between refinements and the convergence
    # error widened the bounds by up to 20 % (p = 0.8: 13.53 where the shortest is 11.20).
    cases = [(_family("lognorm", 0.5, 0.125), _family("uniform", 7.0, 0.5), (0.8, 0.875, 0.95)),
             (_family("uniform", 3.0, 0.75), _family("triang", 0.5, 0.75), (0.8125, 0.9))]  # was 6.905 for 6.094
    for a, b, probabilities in cases:
        ref = Reference(a, 1.0, b, -1.0)
        for p in probabilities:
            bounds = convolution.shortest_bounds([((1.0, a), (-1.0, b))], p, symmetric=[False])
            _check(ref, bounds, p)


def test_measurement_sources_are_mirrored_per_eq_4():
    # U_c = model - measurement: a lognormal measurement error gives a long LEFT tail
    src = [((1.0, stats.norm(0, 0.2)), (-1.0, stats.lognorm(0.5)))]
    b = convolution.shortest_bounds(src, 0.99)
    _check(Reference(stats.norm(0, 0.2), 1.0, stats.lognorm(0.5), -1.0), b, 0.99, bound_tol=2e-4)
    assert b.high[0] < 0.5 and b.low[0] < -2.5


def test_vectorised_sensors_equal_one_by_one_and_exact_sensors_stay_exact():
    y = np.array([1.0, 2.0, 5.0, 0.5])
    model = edmf_rs.relative_to_measured(stats.uniform(-0.2, 0.3), y)
    c = edmf_rs.combine(model=model, measurement=stats.norm(0, 0.05))
    t = edmf_rs.threshold_bounds(c, phi=0.9)
    for j, yj in enumerate(y):
        one = convolution.shortest_bounds([((1.0, stats.uniform(-0.2 * yj, 0.3 * yj)), (-1.0, stats.norm(0, 0.05)))],
                                          t.probability, symmetric=[True])
        assert t.low[j] == pytest.approx(one.low[0], rel=1e-9, abs=1e-12)
        assert t.high[j] == pytest.approx(one.high[0], rel=1e-9, abs=1e-12)
    assert t.method == ("convolution",) * 4


def test_monte_carlo_stays_selectable_and_raw_samples_use_it():
    c = edmf_rs.combine(model=stats.uniform(-1, 2), measurement=stats.norm(0, 0.5), n_sensors=2, n_samples=50_000)
    mc = edmf_rs.threshold_bounds(c, method="monte-carlo")
    conv = edmf_rs.threshold_bounds(c)
    assert mc.method == ("central", "central") and mc.monte_carlo
    assert conv.method == ("convolution", "convolution") and not conv.monte_carlo
    assert np.all(np.abs(mc.low - conv.low) < 0.02 * conv.width)
    raw = edmf_rs.threshold_bounds(c.samples)
    assert raw.method == ("shortest", "shortest")
    with pytest.raises(ValueError, match="method"):
        edmf_rs.threshold_bounds(c, method="exactly")


def test_heavy_tailed_sources_fall_back_to_monte_carlo():
    c = edmf_rs.combine(model=stats.cauchy(0, 0.01), measurement=stats.norm(0, 1), n_sensors=1, n_samples=50_000)
    assert not convolution.convolvable(c.sources[0])
    t = edmf_rs.threshold_bounds(c)
    assert t.method == ("central",)
    with pytest.raises(ValueError, match="sensor 0 cannot be convolved"):
        convolution.shortest_bounds(c.sources, 0.9)
