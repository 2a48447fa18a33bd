"""Uncertainty sources in project files: triangular and truncated normal shorthands,
any continuous scipy.stats distribution by name with its own parameters, and the
messages for bad names and parameters."""

import numpy as np
import pytest
from edmf_rs.engine import intervals
from edmf_rs.engine.distributions import distribution
from edmf_rs.project import Project, ProjectError
from scipy import stats

from _projects import project_text, write_project
from _projects import uncertainty as source

MODEL = "def predict(theta):\n    return theta @ __import__('numpy').array([[1.0, 2.0]])\n"
BASE = project_text(identification={"name": "dist"}, parameters={"a": (0.0, 2.0)},
                    sampling={"method": "grid", "points": {"a": 11}}, model={"function": "dmodel:predict"},
                    sensors=[{"name": "S1", "value": 1.0}, {"name": "S2", "value": 2.0}])
NOISE = source(name="noise", kind="measurement", distribution="normal", sd=0.01)


def project(tmp_path, *sources) -> Project:
    return Project.from_toml(write_project(tmp_path, BASE + "".join(sources), modules={"dmodel": MODEL}))


def test_lognorm_by_scipy_name_with_its_own_parameters(tmp_path):
    p = project(tmp_path, source(name="creep", kind="model", distribution="lognorm", params={"s": 0.25, "scale": 1.0}))
    src = p.uncertainty[0]
    d = src.base()
    assert d.dist.name == "lognorm" and d.kwds == {"s": 0.25, "scale": 1.0}
    c = p.combined_uncertainty()
    # a single source at each sensor: its exact distribution, no Monte Carlo for the thresholds
    assert c.exact_sensors.all() and c.marginals[0][1].dist.name == "lognorm"
    t = edmf_threshold(c)
    want = intervals.shortest_interval(stats.lognorm(0.25), t.probability)
    np.testing.assert_allclose([t.low[0], t.high[0]], want)
    assert "lognorm(s 0.25, scale 1)" in src.describe()


def edmf_threshold(c):
    import edmf_rs

    return edmf_rs.threshold_bounds(c)


def test_triangular_shorthand(tmp_path):
    p = project(tmp_path, source(name="tri", kind="model", distribution="triangular", low=-1.0, mode=0.0, high=2.0),
                NOISE)
    d = p.uncertainty[0].base()
    # triangular(a, c, b): mean (a + b + c) / 3, P(X <= c) = (c - a) / (b - a)
    assert d.mean() == pytest.approx((-1.0 + 0.0 + 2.0) / 3)
    assert d.cdf(0.0) == pytest.approx(1.0 / 3.0)  # (c - a) / (b - a)
    assert d.support() == (-1.0, 2.0)
    c = p.combined_uncertainty()
    assert not c.exact and not c.symmetric.any()  # asymmetric mode: the shortest window


def test_symmetric_triangular_and_truncated_normal_take_the_central_window(tmp_path):
    p = project(tmp_path, source(name="tri", kind="model", distribution="triangular", low=-1.0, mode=0.0, high=1.0),
                source(name="tn", kind="model", distribution="truncated_normal", mean=0.0, sd=1.0, low=-1.5,
                       high=1.5), NOISE)
    tn = p.uncertainty[1].base()
    # truncation of N(0, 1) to [-1.5, 1.5]: cdf(x) = (Phi(x) - Phi(-1.5)) / (Phi(1.5) - Phi(-1.5))
    x = 0.7
    assert tn.cdf(x) == pytest.approx((stats.norm.cdf(x) - stats.norm.cdf(-1.5)) / (stats.norm.cdf(1.5) - stats.norm.cdf(-1.5)))
    c = p.combined_uncertainty()
    assert c.symmetric.all()
    import edmf_rs

    assert edmf_rs.threshold_bounds(c, method="monte-carlo").method == ("central", "central")
    t = edmf_rs.threshold_bounds(c)  # the default: numerical convolution, central interval of a symmetric U_c
    assert t.method == ("convolution", "convolution")
    np.testing.assert_allclose(t.low, -t.high, atol=1e-6 * t.width.max())


def test_truncated_normal_mean_off_centre_is_asymmetric():
    d = distribution("truncated_normal", {"mean": 0.5, "sd": 1.0, "low": -1.0, "high": 1.0})
    assert not intervals.is_symmetric(d)
    assert d.support() == (-1.0, 1.0)


@pytest.mark.parametrize("family, params, words", [
    ("lognormal", {"s": 1}, ["uncertainty[0].distribution", "source 'bad'", "'triangular'", "did you mean 'lognorm'"]),
    ("lognorm", {"sigma": 0.2}, ["uncertainty[0].params", "source 'bad'", "unknown parameter 'sigma'",
                                 "accepted: s, loc, scale"]),
    ("lognorm", {"scale": 2.0}, ["uncertainty[0].params", "lognorm needs s", "accepted: s, loc, scale"]),
    ("gamma", {"a": -1.0}, ["uncertainty[0].params", "gamma does not accept a = -1", "a, loc, scale"]),
    ("t", {"df": 3, "scale": "x"}, ["uncertainty[0].params", "scale of t: expected a number"]),
])
def test_bad_scipy_names_and_parameters(tmp_path, family, params, words):
    with pytest.raises(ValueError) as info:
        project(tmp_path, source(name="bad", kind="model", distribution=family, params=params))
    assert isinstance(info.value, ProjectError)
    for w in words:
        assert w in str(info.value), (w, str(info.value))


@pytest.mark.parametrize("kw, words", [
    ({"distribution": "triangular", "low": 0.0, "mode": 2.0, "high": 1.0},
     ["uncertainty[0]", "source 'bad'", "triangular does not accept", "low, mode, high"]),
    ({"distribution": "triangular", "low": 0.0, "high": 1.0}, ["triangular needs mode", "low, mode, high"]),
    ({"distribution": "truncated_normal", "mean": 0.0, "sd": 1.0, "low": 1.0, "high": -1.0},
     ["truncated_normal does not accept", "mean, sd, low, high"]),
    ({"distribution": "triangular", "low": 0.0, "mode": 0.5, "high": 1.0, "sd": 1.0},
     ["uncertainty[0].sd", "no sd for a triangular"]),
    ({"distribution": "lognorm", "params": {"s": 0.5}, "sd": 1.0}, ["uncertainty[0].sd", "params = {"]),
    ({"distribution": "normal", "sd": 1.0, "mode": 0.0}, ["uncertainty[0].mode", "no mode for a normal"]),
    ({"distribution": "triangular", "params": {"c": 0.5}}, ["uncertainty[0].params", "no params for triangular"]),
])
def test_bad_shorthand_parameters(tmp_path, kw, words):
    with pytest.raises(ProjectError) as info:
        project(tmp_path, source(name="bad", kind="model", **kw))
    for w in words:
        assert w in str(info.value), (w, str(info.value))


def test_distribution_function_accepts_any_continuous_scipy_family():
    d = distribution("t", {"df": 4.0, "loc": 1.0, "scale": 2.0})
    assert d.median() == pytest.approx(1.0) and d.std() == pytest.approx(2.0 * np.sqrt(4.0 / 2.0))
    assert distribution("normal", {"sd": 2.0}).std() == pytest.approx(2.0)
    with pytest.raises(ValueError, match="accepted: df, loc, scale"):
        distribution("t", {"nu": 3})
