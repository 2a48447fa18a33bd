"""A source of scale 0, of any family, is a fixed offset (Eq. 4): U_c moves by +loc for a model
source and -loc for a measurement source, and the thresholds are computed as if the source were
absent: exact when the other sources are normal, by convolution when they can be convolved, never
by Monte Carlo because of the offset. The expected bounds are computed here from scipy directly."""

import warnings

import edmf_rs
import numpy as np
import pytest
from edmf_rs.engine import convolution
from edmf_rs.project.sources import UncertaintySource, combine_sources
from hypothesis import given
from hypothesis import strategies as st
from scipy import optimize, special, stats

# scipy reports mean, median and ppf of these as NaN; each is the constant loc.
FIXED = {
    "uniform": lambda c: stats.uniform(c, 0.0),
    "triang": lambda c: stats.triang(0.3, loc=c, scale=0.0),
    "lognorm": lambda c: stats.lognorm(0.5, loc=c, scale=0.0),
    "t": lambda c: stats.t(3.0, c, 0.0),
    "norm": lambda c: stats.norm(c, 0.0),
}
SIGN = {"model": 1.0, "measurement": -1.0}


def normal_bounds(mean, sd, phi):
    """Sidak per-sensor probability and the central interval of N(mean, sd) per sensor (Eq. 6)."""
    mean, sd = np.broadcast_arrays(np.asarray(mean, dtype=float), np.asarray(sd, dtype=float))
    p = phi ** (1.0 / mean.size)
    low, high = stats.norm.interval(p, loc=mean, scale=sd)
    return np.asarray(low), np.asarray(high)


def assert_bounds(t, low, high, rel=1e-12):
    """Equal to ``rel`` of the width, and to rounding of the bounds' magnitude."""
    atol = rel * float(np.max(high - low)) + 1e-14 * float(np.max(np.abs([low, high])))
    np.testing.assert_allclose(t.low, low, rtol=0, atol=atol)
    np.testing.assert_allclose(t.high, high, rtol=0, atol=atol)


def bounds(model, measurement, phi=0.95, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no thin-tail warning: nothing is sampled for the bounds
        return edmf_rs.threshold_bounds(edmf_rs.combine(model=model, measurement=measurement, **kwargs), phi)


@pytest.mark.parametrize("family", sorted(FIXED))
@pytest.mark.parametrize("side", ["model", "measurement"])
@pytest.mark.parametrize("layout", ["scalar", "vectorised", "per-sensor"])
def test_an_offset_added_to_normal_sources_gives_the_shifted_exact_normal(family, side, layout):
    c = 0.3
    offsets = np.array([0.3, -1.25, 4.0])
    if layout == "scalar":
        fixed = FIXED[family](c)
        shift = np.full(3, c)
    elif layout == "vectorised":
        fixed = FIXED[family](offsets)
        shift = offsets
    else:
        fixed = [FIXED[family](x) for x in offsets]
        shift = offsets
    model = [stats.norm([-0.2, 0.1, 0.5], [0.3, 0.15, 0.6])]
    measurement = [stats.norm(0.05, 0.02)]
    (model if side == "model" else measurement).append(fixed)
    t = bounds(model, measurement, n_sensors=3)
    sd = np.hypot([0.3, 0.15, 0.6], 0.02)
    low, high = normal_bounds(np.array([-0.2, 0.1, 0.5]) - 0.05 + SIGN[side] * shift, sd, 0.95)
    assert_bounds(t, low, high)
    assert t.method == ("exact",) * 3 and t.gaussian is True and not t.monte_carlo


@pytest.mark.parametrize("family", ["uniform", "lognorm"])
def test_the_bounds_do_not_depend_on_the_seed_or_the_sample_count(family):
    model = [stats.norm(0.4, [0.3, 0.5]), FIXED[family](0.7)]
    measurement = [stats.norm(0.0, [0.1, 0.1]), FIXED[family](-0.2)]
    a = edmf_rs.combine(model=model, measurement=measurement, seed=0, n_samples=1000)
    b = edmf_rs.combine(model=model, measurement=measurement, seed=12345, n_samples=50_000)
    assert a.exact and b.exact and a.samples is None
    ta, tb = edmf_rs.threshold_bounds(a, 0.9), edmf_rs.threshold_bounds(b, 0.9)
    np.testing.assert_array_equal(ta.low, tb.low)
    np.testing.assert_array_equal(ta.high, tb.high)
    assert ta.method == ("exact", "exact") and ta.n_samples is None and ta.seed is None
    low, high = normal_bounds(0.4 + 0.7 + 0.2, np.hypot([0.3, 0.5], 0.1), 0.9)
    assert_bounds(ta, low, high)


def test_a_fixed_offset_does_not_check_or_use_n_samples():
    """As with normal sources only: no samples are drawn, so n_samples is not asked for."""
    c = edmf_rs.combine(model=[stats.norm(0, 1), stats.uniform(2.0, 0.0)], n_sensors=3, n_samples=0)
    assert c.exact and c.mean.tolist() == [2.0, 2.0, 2.0]


@given(
    n_m=st.integers(1, 6),
    phi=st.floats(0.05, 0.99),
    c=st.floats(-1e3, 1e3),
    locs=st.lists(st.floats(-1e3, 1e3), min_size=6, max_size=6),
    sds=st.lists(st.floats(1e-3, 1e2), min_size=6, max_size=6),
    noise=st.floats(1e-3, 10.0),
    family=st.sampled_from(sorted(FIXED)),
    side=st.sampled_from(["model", "measurement"]),
)
def test_property_offset_shifts_the_exact_normal_bounds(n_m, phi, c, locs, sds, noise, family, side):
    loc, sd = np.array(locs[:n_m]), np.array(sds[:n_m])
    model = [stats.norm(loc, sd)]
    measurement = [[stats.norm(0.0, noise) for _ in range(n_m)]]
    (model if side == "model" else measurement).append(FIXED[family](c))
    t = bounds(model, measurement, phi=phi, seed=None, n_samples=1)
    low, high = normal_bounds(loc + SIGN[side] * c, np.sqrt(sd**2 + noise**2), phi)
    assert_bounds(t, low, high, rel=1e-9)
    assert t.method == ("exact",) * n_m and t.gaussian is True


def uniform_plus_normal_cdf(x, a, b, sd):
    """cdf of U(a, b) + N(0, sd): the integral of the normal cdf over the uniform, in closed form."""
    def g(u):  # integral of Phi(v / sd) dv up to u
        return u * special.ndtr(u / sd) + sd * stats.norm.pdf(u / sd)
    return (g(x - a) - g(x - b)) / (b - a)


@pytest.mark.parametrize("side", ["model", "measurement"])
def test_an_offset_with_sources_that_are_convolved_gives_the_shifted_convolution(side):
    c = -0.35
    model = [stats.uniform(-1.0, [2.0, 2.0])]
    measurement = [stats.norm(0.0, [0.2, 0.4])]
    (model if side == "model" else measurement).append(stats.triang(0.3, loc=c, scale=0.0))
    combined = edmf_rs.combine(model=model, measurement=measurement, n_samples=2000)
    t = edmf_rs.threshold_bounds(combined, 0.95)
    other = edmf_rs.threshold_bounds(edmf_rs.combine(model=model, measurement=measurement, n_samples=50_000,
                                                     seed=99), 0.95)
    assert t.method == ("convolution",) * 2 and not t.monte_carlo and t.gaussian is False
    np.testing.assert_array_equal(t.low, other.low)
    np.testing.assert_array_equal(t.high, other.high)
    shift = SIGN[side] * c
    # the convolution of the sources with spread, moved by the offset
    plain = convolution.shortest_bounds([((1.0, stats.uniform(-1.0, 2.0)), (-1.0, stats.norm(0.0, s)))
                                         for s in (0.2, 0.4)], t.probability, symmetric=[True, True])
    assert_bounds(t, plain.low + shift, plain.high + shift, rel=1e-9)
    # and U(-1, 1) + N(0, sd) + shift in closed form, symmetric: the central interval (Eq. 6)
    tail = 0.5 * (1.0 - t.probability)
    for j, s in enumerate((0.2, 0.4)):
        high = optimize.brentq(lambda x: uniform_plus_normal_cdf(x, -1.0, 1.0, s) - (1.0 - tail), 0.0, 10.0,
                               xtol=1e-14)
        width = 2.0 * high
        assert abs(t.high[j] - (high + shift)) <= 3e-4 * width
        assert abs(t.low[j] - (-high + shift)) <= 3e-4 * width


@pytest.mark.parametrize("side", ["model", "measurement"])
def test_an_offset_beside_a_single_source_keeps_its_exact_distribution(side):
    c = 0.25
    model, measurement = [stats.lognorm(0.5, scale=1.0)], []
    (model if side == "model" else measurement).append(stats.uniform(c, 0.0))
    combined = edmf_rs.combine(model=model, measurement=measurement, n_sensors=3, n_samples=1000)
    t = edmf_rs.threshold_bounds(combined, 0.9)
    assert t.method == ("exact",) * 3 and not t.monte_carlo
    # the shortest interval of the lognormal (Eq. 5), minimising ppf(a + p) - ppf(a) over a
    ln = stats.lognorm(0.5)
    best = optimize.minimize_scalar(lambda a: ln.ppf(a + t.probability) - ln.ppf(a), bounds=(0.0, 1 - t.probability),
                                    method="bounded", options={"xatol": 1e-13})
    low, high = ln.ppf(best.x) + SIGN[side] * c, ln.ppf(best.x + t.probability) + SIGN[side] * c
    assert_bounds(t, np.full(3, low), np.full(3, high), rel=1e-6)
    np.testing.assert_allclose(combined.mean, ln.mean() + SIGN[side] * c)


def test_relative_to_a_zero_reading_is_an_offset_at_that_sensor():
    """relative_to_measured gives scale 0 where the reading is 0: that sensor keeps its exact normal."""
    y = np.array([2.0, 0.0, 3.0])
    combined = edmf_rs.combine(model=edmf_rs.relative_to_measured(stats.uniform(-0.1, 0.2), y),
                               measurement=stats.norm(0.01, 0.02), n_samples=2000)
    t = edmf_rs.threshold_bounds(combined, 0.95)
    assert t.method == ("convolution", "exact", "convolution") and not t.monte_carlo
    low, high = normal_bounds(np.full(3, -0.01), 0.02, 0.95)
    assert abs(t.low[1] - low[1]) <= 1e-12 and abs(t.high[1] - high[1]) <= 1e-12
    # a fraction of zero width is an offset at every sensor
    t = bounds(edmf_rs.relative_to_measured(stats.uniform(0.05, 0.0), y), stats.norm(0.0, 0.02))
    low, high = normal_bounds(0.05 * y, np.full(3, 0.02), 0.95)
    assert_bounds(t, low, high)
    assert t.method == ("exact",) * 3


def test_project_sources_relative_to_a_zero_reading():
    """The project's per-sensor combination: the uniform fraction of a 0 reading is an offset of 0."""
    sources = (UncertaintySource("model", "model", "uniform", (-0.1, 0.1), "measured", (0, 1)),
               UncertaintySource("noise", "measurement", "normal", (0.0, 0.02), "absolute", (0, 1)))
    combined = combine_sources(sources, np.array([2.0, 0.0]), n_samples=2000)
    t = edmf_rs.threshold_bounds(combined, 0.95)
    assert t.method == ("convolution", "exact")
    low, high = normal_bounds(np.zeros(2), np.full(2, 0.02), 0.95)
    assert abs(t.low[1] - low[1]) <= 1e-12 and abs(t.high[1] - high[1]) <= 1e-12


@pytest.mark.parametrize("model, measurement, sensor", [
    ([stats.uniform(0.3, 0.0), stats.triang(0.5, loc=1.0, scale=0.0)], [stats.lognorm(0.5, 0.1, 0.0)], 0),
    ([stats.uniform(0.3, 0.0)], [stats.lognorm(0.5, loc=0.1, scale=[1.0, 0.0]), stats.norm(0.0, [2.0, 0.0])], 1),
    ([[stats.t(3, 0.0, 1.0), stats.t(3, 5.0, 0.0)]], [stats.uniform(0.0, 0.0)], 1),
])
def test_a_sensor_whose_every_source_is_an_offset_is_still_refused(model, measurement, sensor):
    with pytest.raises(ValueError, match=rf"model, measurement: the combined standard deviation is zero at sensor "
                                         rf"{sensor}$"):
        edmf_rs.combine(model=model, measurement=measurement, n_sensors=2, n_samples=1000)
