"""Bad input to adaptive_falsify: errors and warnings that say what to change."""

import warnings

import edmf_rs
import numpy as np
import pytest
from edmf_rs.adaptive import adaptive_falsify

T = edmf_rs.Thresholds([-0.1, -0.1], [0.1, 0.1])
BOUNDS = [[0.0, 1.0], [0.0, 1.0]]


def linear(theta):
    return np.column_stack([theta[:, 0] + theta[:, 1], theta[:, 0] - theta[:, 1]])


def test_fewer_initial_runs_than_parameters():
    with pytest.raises(ValueError, match=r"n_initial: expected at least n_params \+ 1 = 3 runs.*20 x n_params"):
        adaptive_falsify(linear, BOUNDS, [1.0, 0.0], T, budget=100, n_initial=2)


def test_thin_initial_design_warns():
    with pytest.warns(UserWarning, match="n_initial: 4 runs for 2 parameters is a thin initial design"):
        adaptive_falsify(linear, BOUNDS, [1.0, 0.0], T, budget=40, n_initial=4, wave_size=10, n_screen=1024)


def test_budget_too_small_for_one_wave():
    with pytest.raises(ValueError, match=r"budget: expected at least n_initial \+ wave_size = 40 \+ 20 = 60"):
        adaptive_falsify(linear, BOUNDS, [1.0, 0.0], T, budget=50)
    with pytest.warns(UserWarning, match="budget: 70 runs leave room for the initial design and the final wave"):
        adaptive_falsify(linear, BOUNDS, [1.0, 0.0], T, budget=70, n_screen=1024)


def test_nan_outputs_name_the_run_or_are_falsified():
    def nan_model(theta):
        out = linear(theta)
        out[theta[:, 0] > 0.9] = np.nan
        return out
    with pytest.raises(ValueError, match="model: returned NaN for instance .*nan='falsify'"):
        adaptive_falsify(nan_model, BOUNDS, [1.0, 0.0], T, budget=100, n_screen=1024)
    r = adaptive_falsify(nan_model, BOUNDS, [1.0, 0.0], T, budget=100, n_screen=1024, nan="falsify")
    assert r.falsification.n_invalid > 0
    assert not np.isnan(r.candidate_predictions).any() and r.n_candidates > 0


def test_constant_output_warns_and_is_emulated_exactly():
    def flat(theta):
        return np.column_stack([theta[:, 0] + theta[:, 1], np.full(theta.shape[0], 0.02)])
    with pytest.warns(UserWarning, match="sensor 1: every run gave 0.02; emulated as that constant"):
        r = adaptive_falsify(flat, BOUNDS, [1.0, 0.0], T, budget=100, n_screen=1024)
    assert r.n_candidates > 0
    # Constant outside the thresholds at every run: the model class is falsified.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = adaptive_falsify(flat, BOUNDS, [1.0, 0.5], T, budget=100, n_screen=1024)
    assert r.model_class_falsified and r.confidence is not None


@pytest.mark.parametrize("kwargs, match", [
    (dict(c=-1.0), "c: expected a number in"),
    (dict(n_screen=0), "n_screen: expected a positive integer"),
    (dict(nan="skip"), "nan: expected 'raise' or 'falsify'"),
    (dict(validation_coverage=1.5), "validation_coverage"),
])
def test_bad_options(kwargs, match):
    with pytest.raises(ValueError, match=match):
        adaptive_falsify(linear, BOUNDS, [1.0, 0.0], T, budget=100, **kwargs)


def test_bad_bounds_model_and_thresholds():
    with pytest.raises(ValueError, match=r"bounds: expected a \(p, 2\) array"):
        adaptive_falsify(linear, [0.0, 1.0], [1.0, 0.0], T, budget=100)
    with pytest.raises(ValueError, match="bounds: theta0.low: expected low < high"):
        adaptive_falsify(linear, [[1.0, 0.0], [0.0, 1.0]], [1.0, 0.0], T, budget=100)
    with pytest.raises(TypeError, match="model: expected a callable"):
        adaptive_falsify(None, BOUNDS, [1.0, 0.0], T, budget=100)
    with pytest.raises(TypeError, match="thresholds: expected edmf_rs.Thresholds"):
        adaptive_falsify(linear, BOUNDS, [1.0, 0.0], (-1, 1), budget=100)
    with pytest.raises(ValueError, match="measurements: expected 2 values"):
        adaptive_falsify(linear, BOUNDS, [1.0], T, budget=100)
