"""Residual minimisation (Eq. 15) and Bayesian inference (Eq. 17) over model instances."""

import numpy as np
import pytest
from edmf_rs import baselines as bl
from scipy import stats

THETA = np.linspace(-10.0, 10.0, 4001)


def linear_predictions(theta, a):
    return np.outer(theta, a)


# --- least squares -------------------------------------------------------------------------


@pytest.mark.parametrize("weights", ["measured", "sigma", np.array([1.0, 4.0, 0.5])])
def test_least_squares_recovers_an_exact_linear_model(weights):
    a = np.array([1.0, 2.5, -0.7])
    theta = np.linspace(0.5, 3.0, 26)
    g = linear_predictions(theta, a)
    y = 1.7 * a  # noise-free data generated with theta = 1.7, a grid point
    sigma = 0.1 if isinstance(weights, str) and weights == "sigma" else None
    res = bl.least_squares(g, y, weights=weights, sigma=sigma, parameters=theta)
    assert res.index == 12 and res.value == pytest.approx(1.7)
    assert res.minimum == pytest.approx(0.0, abs=1e-24)


def test_default_weights_are_inverse_squared_measurements():
    g = np.array([[1.0, 2.0], [2.0, 1.0]])
    y = np.array([2.0, 4.0])
    res = bl.least_squares(g, y)
    # ((1-2)/2)^2 + ((2-4)/4)^2 = 0.5 ; ((2-2)/2)^2 + ((1-4)/4)^2 = 0.5625
    assert res.objective == pytest.approx([0.5, 0.5625])
    assert res.weights == pytest.approx([0.25, 0.0625])
    assert res.index == 0 and res.value is None


def test_sigma_weights_pick_the_precise_sensor():
    g = np.array([[0.0, 1.0], [1.0, 0.0]])
    y = np.zeros(2)
    # Instance 0 misses the imprecise sensor (sd 10), instance 1 the precise one (sd 0.1).
    assert bl.least_squares(g, y, weights="sigma", sigma=[0.1, 10.0]).index == 0
    assert bl.least_squares(g, y, weights="sigma", sigma=[10.0, 0.1]).index == 1


@pytest.mark.parametrize(
    ("kwargs", "exc", "name"),
    [
        ({"predictions": np.ones((3, 2)), "measurements": np.ones(3)}, ValueError, "predictions"),
        ({"predictions": np.ones(3), "measurements": np.ones(3)}, ValueError, "predictions"),
        ({"measurements": [1.0, np.nan]}, ValueError, "measurements"),
        ({"measurements": [1.0, 0.0]}, ValueError, "measurements"),
        ({"weights": "nope"}, ValueError, "weights"),
        ({"weights": "sigma"}, ValueError, "sigma"),
        ({"weights": "sigma", "sigma": [1.0, -1.0]}, ValueError, "sigma"),
        ({"weights": [1.0, -1.0]}, ValueError, "weights"),
        ({"weights": [1.0, 1.0, 1.0]}, ValueError, "weights"),
        ({"parameters": [1.0]}, ValueError, "parameters"),
        ({"predictions": [["a", "b"]]}, TypeError, "predictions"),
    ],
)
def test_least_squares_bad_input_names_the_argument(kwargs, exc, name):
    args = {"predictions": np.ones((3, 2)), "measurements": np.ones(2)} | kwargs
    with pytest.raises(exc, match=name):
        bl.least_squares(args.pop("predictions"), args.pop("measurements"), **args)


# --- Bayesian inference --------------------------------------------------------------------


def test_conjugate_normal_posterior_on_a_fine_grid():
    # y_i ~ N(theta, s^2), i = 1..n, flat prior: theta | y ~ N(mean(y), s^2 / n).
    rng = np.random.default_rng(11)
    s, n = 0.8, 5
    y = 1.3 + s * rng.standard_normal(n)
    g = linear_predictions(THETA, np.ones(n))
    post = bl.bayesian_posterior(g, y, np.full(n, s**2))
    assert post.posterior.sum() == pytest.approx(1.0)
    mean = post.posterior @ THETA
    var = post.posterior @ (THETA - mean) ** 2
    assert mean == pytest.approx(y.mean(), abs=1e-6)
    assert var == pytest.approx(s**2 / n, rel=1e-4)


def test_combined_mean_shifts_the_posterior():
    # Residual g - y has mean mu: theta | y ~ N(y + mu, s^2) for one sensor.
    g = linear_predictions(THETA, [1.0])
    post = bl.bayesian_posterior(g, [2.0], [0.25], mean=-0.5)
    assert post.posterior @ THETA == pytest.approx(1.5, abs=1e-6)


def test_full_correlated_covariance_matches_scipy():
    rng = np.random.default_rng(5)
    n_m = 4
    # Strongly correlated errors: correlation 0.9^|i-j| (positive definite), unequal sds.
    lag = np.abs(np.subtract.outer(np.arange(n_m), np.arange(n_m)))
    sd = np.array([0.5, 1.0, 2.0, 0.3])
    cov = 0.9**lag * np.outer(sd, sd)
    g = rng.standard_normal((30, n_m))
    y = rng.standard_normal(n_m)
    mu = np.array([0.1, -0.2, 0.0, 0.3])
    post = bl.bayesian_posterior(g, y, cov, mean=mu)
    # Eq. 17 is the density of y under N(g(theta) - mean, cov).
    expected = np.array([stats.multivariate_normal(gi - mu, cov).logpdf(y) for gi in g])
    assert post.log_likelihood == pytest.approx(expected, rel=1e-10)
    weights = np.exp(expected - expected.max())
    assert post.posterior == pytest.approx(weights / weights.sum(), rel=1e-9)
    diagonal = bl.bayesian_posterior(g, y, np.diag(cov), mean=mu)
    assert not np.allclose(diagonal.posterior, post.posterior, rtol=1e-3)


def test_vector_of_variances_equals_diagonal_matrix():
    rng = np.random.default_rng(2)
    g, y, var = rng.standard_normal((20, 3)), rng.standard_normal(3), np.array([0.5, 1.0, 2.0])
    a = bl.bayesian_posterior(g, y, var)
    b = bl.bayesian_posterior(g, y, np.diag(var))
    assert a.log_likelihood == pytest.approx(b.log_likelihood, rel=1e-12)


def test_log_sum_exp_survives_tiny_likelihoods():
    g = linear_predictions(np.array([0.0, 1.0, 2.0]), [1.0])
    post = bl.bayesian_posterior(g, [1e4], [1e-4])  # every likelihood underflows exp()
    assert np.all(np.isfinite(post.posterior)) and post.posterior.sum() == pytest.approx(1.0)
    assert post.map_index == 2 and post.hpd_indices.tolist() == [2]


def test_prior_weights_multiply_the_likelihood():
    g = linear_predictions(np.array([0.0, 1.0, 2.0]), [1.0])
    flat = bl.bayesian_posterior(g, [1.0], [1.0])
    weighted = bl.bayesian_posterior(g, [1.0], [1.0], prior=[0.0, 1.0, 3.0])
    expected = flat.posterior * np.array([0.0, 1.0, 3.0])
    assert weighted.posterior == pytest.approx(expected / expected.sum())
    assert weighted.posterior[0] == 0.0


@pytest.mark.parametrize(
    ("posterior", "mass", "expected"),
    [
        ([0.05, 0.5, 0.15, 0.3], 0.95, [1, 2, 3]),   # 0.5 + 0.3 + 0.15 reaches 0.95 exactly
        ([0.05, 0.5, 0.15, 0.3], 0.8, [1, 3]),
        ([0.05, 0.5, 0.15, 0.3], 0.81, [1, 2, 3]),   # the instance crossing the mass is included
        ([0.1, 0.6, 0.3], 0.95, [0, 1, 2]),
        ([1.0, 0.0, 0.0], 0.95, [0]),
    ],
)
def test_hpd_set_takes_instances_by_decreasing_posterior(posterior, mass, expected):
    assert np.flatnonzero(bl.hpd_mask(np.array(posterior), mass)).tolist() == expected


def test_hpd_set_of_a_normal_posterior_is_about_four_sd_wide():
    g = linear_predictions(THETA, [1.0])
    post = bl.bayesian_posterior(g, [0.0], [1.0])
    inside = THETA[post.hpd_mask]
    assert inside.min() == pytest.approx(-1.96, abs=0.01) and inside.max() == pytest.approx(1.96, abs=0.01)
    assert post.hpd_size == inside.size and post.mass == 0.95


@pytest.mark.parametrize(
    ("kwargs", "exc", "name"),
    [
        ({"predictions": np.ones((3, 3))}, ValueError, "predictions"),
        ({"measurements": [np.inf, 1.0]}, ValueError, "measurements"),
        ({"covariance": [1.0, 1.0, 1.0]}, ValueError, "covariance"),
        ({"covariance": [1.0, 0.0]}, ValueError, "covariance"),
        ({"covariance": [[1.0, 2.0], [2.0, 1.0]]}, ValueError, "covariance"),   # not positive definite
        ({"covariance": [[1.0, 0.5], [0.1, 1.0]]}, ValueError, "covariance"),   # not symmetric
        ({"covariance": [[1.0, np.nan], [np.nan, 1.0]]}, ValueError, "covariance"),
        ({"covariance": np.ones((2, 2, 2))}, ValueError, "covariance"),
        ({"covariance": "diag"}, TypeError, "covariance"),
        ({"prior": [1.0, -1.0, 1.0]}, ValueError, "prior"),
        ({"prior": [0.0, 0.0, 0.0]}, ValueError, "prior"),
        ({"prior": [1.0, 1.0]}, ValueError, "prior"),
        ({"mean": [0.0, 0.0, 0.0]}, ValueError, "mean"),
        ({"mean": "zero"}, TypeError, "mean"),
        ({"mass": 1.0}, ValueError, "mass"),
    ],
)
def test_posterior_bad_input_names_the_argument(kwargs, exc, name):
    args = {"predictions": np.ones((3, 2)), "measurements": np.ones(2), "covariance": [1.0, 1.0]} | kwargs
    with pytest.raises(exc, match=name):
        bl.bayesian_posterior(args.pop("predictions"), args.pop("measurements"), args.pop("covariance"), **args)
