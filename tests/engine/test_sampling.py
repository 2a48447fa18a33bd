"""Samplers of the parameter domain: grid, Latin hypercube, Sobol'; linear and log scales."""

import math

import numpy as np
import pytest
from edmf_rs.engine.sampling import Parameter, grid, latin_hypercube, sobol

E = Parameter("E", 20e3, 100e3, unit="MPa")
K = Parameter("K", 1e8, 1e12, scale="log")


def strata(values: np.ndarray, low: float, high: float, n: int, log: bool = False) -> list[int]:
    """Which of n equal strata (equal in log space when log) each value falls in, sorted."""
    if log:
        values, low, high = np.log10(values), math.log10(low), math.log10(high)
    return sorted(np.floor((values - low) / (high - low) * n).astype(int).tolist())


def test_grid_linear_and_log_values_and_order():
    s = grid([E, K], {"E": 3, "K": 5})
    theta = s.all()
    assert s.n == 15 and theta.shape == (15, 2)
    # first parameter varies slowest, like nested loops; bounds included
    assert theta[:, 0].tolist() == [20e3] * 5 + [60e3] * 5 + [100e3] * 5
    np.testing.assert_allclose(theta[:5, 1], [1e8, 1e9, 1e10, 1e11, 1e12], rtol=1e-12)
    np.testing.assert_allclose(theta[5:10, 1], theta[:5, 1])


def test_grid_paper_cantilever_101_points():
    theta = grid([E], {"E": 101}).all()[:, 0]
    assert theta.size == 101 and theta[0] == 20e3 and theta[-1] == 100e3
    np.testing.assert_allclose(np.diff(theta), 800.0)


def test_grid_single_point_is_the_centre():
    assert grid([E], [1]).all()[0, 0] == 60e3
    assert grid([K], [1]).all()[0, 0] == pytest.approx(1e10)


@pytest.mark.parametrize("points, message", [
    ({"E": 3}, "missing K"),
    ({"E": 3, "K": 2, "G": 4}, "unknown parameter G"),
    ({"E": 0, "K": 2}, "positive integer"),
    ([3], "expected 2 counts"),
])
def test_grid_rejects_bad_points(points, message):
    with pytest.raises((ValueError, TypeError), match=message):
        grid([E, K], points)


@pytest.mark.parametrize("make", [latin_hypercube, sobol])
def test_qmc_bounds_counts_and_reproducible(make):
    s = make([E, K], 256, seed=3)
    theta = s.all()
    assert theta.shape == (256, 2)
    assert np.all((theta[:, 0] >= 20e3) & (theta[:, 0] <= 100e3))
    assert np.all((theta[:, 1] >= 1e8) & (theta[:, 1] <= 1e12))
    np.testing.assert_array_equal(theta, make([E, K], 256, seed=3).all())
    assert not np.array_equal(theta, make([E, K], 256, seed=4).all())


@pytest.mark.parametrize("make", [latin_hypercube, sobol])
def test_qmc_log_scale_is_uniform_in_log_space(make):
    # One point per stratum of width 1/16 in each dimension: for a Latin
    # hypercube by construction, for 16 Sobol' points by their net property.
    theta = make([E, K], 16, seed=11).all()
    assert strata(theta[:, 0], 20e3, 100e3, 16) == list(range(16))
    assert strata(theta[:, 1], 1e8, 1e12, 16, log=True) == list(range(16))


@pytest.mark.parametrize("make", [latin_hypercube, sobol])
def test_batches_stream_the_same_points(make):
    s = make([E, K], 1000, seed=5)
    whole = s.all()
    for size in (1, 7, 256, 5000):
        np.testing.assert_array_equal(np.concatenate(list(s.batches(size))), whole)


def test_grid_batches_stream_the_same_points():
    s = grid([E, K], {"E": 7, "K": 9})
    np.testing.assert_array_equal(np.concatenate(list(s.batches(10))), s.all())
    assert [b.shape[0] for b in s.batches(10)] == [10] * 6 + [3]


@pytest.mark.parametrize("kwargs, message", [
    (dict(low=5.0, high=5.0), "low < high"),
    (dict(low=6.0, high=5.0), "low < high"),
    (dict(low=0.0, high=5.0, scale="log"), "low > 0"),
    (dict(low=1.0, high=5.0, scale="ln"), "'linear' or 'log'"),
    (dict(low=float("nan"), high=5.0), "finite number"),
])
def test_parameter_rejects_bad_domain(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Parameter("x", **kwargs)


def test_to_unit_inverts_from_unit():
    u = np.linspace(0, 1, 11)
    for p in (E, K):
        np.testing.assert_allclose(p.to_unit(p.from_unit(u)), u, atol=1e-12)
