"""adaptive_falsify (issue 16): no false candidate, the dense run's candidate
ranges within 2 % of the domain, a falsified model class stays falsified."""

import edmf_rs
import numpy as np
import pytest
from edmf_rs import reference
from edmf_rs.adaptive import AdaptiveResult, adaptive_falsify
from edmf_rs.engine.sampling import Parameter, sobol

PARAMS = [Parameter(f"x{j}", 0.0, 1.0) for j in range(3)]
TRUE = np.array([[0.4, 0.6, 0.5]])
THRESHOLDS = edmf_rs.Thresholds(np.full(4, -0.06), np.full(4, 0.06))


def analytic(theta):
    """A cheap nonlinear model class: 3 parameters, 4 sensors."""
    x0, x1, x2 = theta.T
    return np.column_stack([x0 + x1**2, x1 * x2 + x0, np.sin(3 * x2) + x0 * x1, x0 - 0.5 * x2])


def dense_ranges(model, params, y, thresholds, n):
    """Per-parameter candidate ranges (unit domain) of a dense Sobol' run."""
    theta = sobol(params, n, seed=5).all()
    result = edmf_rs.falsify_model(model, theta, y, thresholds, progress=False)
    return _unit_ranges(result.candidate_parameters, params), result.n_candidates


def _unit_ranges(theta, params):
    u = np.column_stack([p.to_unit(theta[:, j]) for j, p in enumerate(params)])
    return np.stack([u.min(axis=0), u.max(axis=0)])


def assert_no_false_candidate(result: AdaptiveResult, y, thresholds):
    """Every candidate passes Eq. 8 on its real output, and every real run that
    passes is a candidate (the NumPy reference decides, not the code under test)."""
    ref = reference.falsify(result.run_predictions, y, thresholds)
    np.testing.assert_array_equal(result.falsification.candidate_indices, ref.candidate_indices)
    r = result.candidate_predictions - y
    assert ((r >= thresholds.low) & (r <= thresholds.high)).all()


@pytest.fixture(scope="module")
def analytic_run():
    y = analytic(TRUE)[0]
    return y, adaptive_falsify(analytic, PARAMS, y, THRESHOLDS, budget=300, n_screen=2**15, seed=0)


def test_analytic_candidates_are_real_and_match_a_dense_run(analytic_run):
    y, result = analytic_run
    assert_no_false_candidate(result, y, THRESHOLDS)
    dense, n_dense = dense_ranges(analytic, PARAMS, y, THRESHOLDS, 2**18)
    assert n_dense > 100 and result.n_candidates > 10
    np.testing.assert_allclose(_unit_ranges(result.candidate_parameters, PARAMS), dense, atol=0.02)
    assert result.n_runs <= 300 and result.n_runs * 10 <= 2**18


def test_every_run_is_recorded_once_and_every_wave_reported(analytic_run):
    _, result = analytic_run
    assert np.unique(result.run_parameters, axis=0).shape[0] == result.n_runs
    assert sum(w.n_runs for w in result.waves) == result.n_runs
    assert [w.index for w in result.waves] == list(range(len(result.waves)))
    assert result.waves[0].kind == "initial" and result.waves[0].n_runs == 20 * 3
    assert result.waves[-1].kind == "final"
    np.testing.assert_array_equal(np.bincount(result.run_wave), [w.n_runs for w in result.waves])
    for w in result.waves[:-1]:
        assert 0 < w.kept_fraction < 1 and w.validated
        assert w.loo_error.shape == (4,) and w.loo_coverage.shape == (4,)
    d = result.as_dict()
    assert d["runs"] == result.n_runs and len(d["waves"]) == len(result.waves)
    assert result.confidence is None


def test_same_inputs_same_result():
    def model(theta):
        return np.column_stack([theta[:, 0] + theta[:, 1], theta[:, 0] - theta[:, 1]])
    t = edmf_rs.Thresholds([-0.1, -0.1], [0.1, 0.1])
    runs = [adaptive_falsify(model, [[0, 1], [0, 1]], [1.0, 0.0], t, budget=100, n_screen=2**12, seed=3)
            for _ in range(2)]
    np.testing.assert_array_equal(runs[0].run_parameters, runs[1].run_parameters)
    np.testing.assert_array_equal(runs[0].falsification.candidate_indices, runs[1].falsification.candidate_indices)


def test_a_falsified_model_class_gives_no_candidate_and_says_how_sure():
    y = analytic(TRUE)[0] + np.array([0.0, 0.0, 0.0, 0.5])  # x0 - x2/2 cannot reach this with x0 + x1^2 fixed
    params = PARAMS
    dense_theta = sobol(params, 2**16, seed=5).all()
    assert edmf_rs.falsify_model(analytic, dense_theta, y, THRESHOLDS, progress=False).n_candidates == 0
    result = adaptive_falsify(analytic, params, y, THRESHOLDS, budget=200, n_screen=2**13, seed=1)
    assert result.n_candidates == 0 and result.model_class_falsified
    assert_no_false_candidate(result, y, THRESHOLDS)
    text = result.confidence
    assert f"none of {result.n_runs} real model runs" in text and "c =" in text
    assert result.n_runs <= 200


def test_bounds_as_an_array_and_log_scales():
    def model(theta):
        return np.column_stack([np.log10(theta[:, 0]) + theta[:, 1], theta[:, 1]])
    t = edmf_rs.Thresholds([-0.05, -0.05], [0.05, 0.05])
    y = np.array([3.5, 0.5])
    r = adaptive_falsify(model, [Parameter("k", 1e2, 1e5, scale="log"), Parameter("b", 0.0, 1.0)], y, t,
                         budget=100, n_screen=2**12)
    assert_no_false_candidate(r, y, t)
    k = np.log10(r.candidate_parameters[:, 0])
    assert r.n_candidates > 0 and np.all(np.abs(k - 3.0) <= 0.1 + 1e-9)
    r2 = adaptive_falsify(lambda th: th[:, :1] + th[:, 1:], np.array([[0.0, 1.0], [0.0, 1.0]]), [1.0],
                          edmf_rs.Thresholds([-0.05], [0.05]), budget=100, n_screen=2**12)
    assert r2.n_candidates > 0 and r2.parameters[0].name == "theta0"


def test_girder_reaches_every_range_end_of_a_dense_run():
    """The girder (examples/girder.py, SG5 excluded): the adaptive candidates
    are real and reach each end of the dense run's candidate ranges to within
    2 % of the domain (they may go further: the dense run under-resolves the
    thin candidate region, and every adaptive candidate passes Eq. 8)."""
    from edmf_rs import cli
    from edmf_rs.examples import girder

    project = edmf_rs.Project.from_toml(cli.EXAMPLES / "girder-sg5-excluded.toml")
    thresholds = edmf_rs.threshold_bounds(project.combined_uncertainty(), project.phi, project.correction)
    kept = list(project.kept)

    def model(theta):
        return girder.predict(theta)[:, kept]

    params, y = project.parameters, project.measured
    dense, n_dense = dense_ranges(model, params, y, thresholds, 2**15)
    result = adaptive_falsify(model, params, y, thresholds, budget=240, n_screen=2**14, seed=0)
    assert_no_false_candidate(result, y, thresholds)
    assert n_dense > 50 and result.n_candidates > 20 and result.n_runs <= 240
    found = _unit_ranges(result.candidate_parameters, params)
    assert np.all(found[0] <= dense[0] + 0.02) and np.all(found[1] >= dense[1] - 0.02), (found, dense)
