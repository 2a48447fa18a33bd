"""Leave-one-sensor-out and sensitivity, checked against brute-force refalsification."""

import edmf_rs
import numpy as np
import pytest
from edmf_rs.engine.thresholds import Thresholds
from edmf_rs.project.diagnostics import (
    SCALES,
    SensitivityTracker,
    findings,
    leave_one_out,
)
from scipy import stats

N_M = 6
NAMES = tuple(f"S{i}" for i in range(N_M))
RNG = np.random.default_rng(20130)
THETA = RNG.uniform(0.0, 1.0, (6000, 2))
B = RNG.normal(0.0, 1.0, (2, N_M))


def model(theta):
    return theta @ B


def measurements(offset_sensor=None, offset=0.0):
    y = model(np.array([[0.4, 0.6]]))[0] + RNG.normal(0.0, 0.02, N_M) + 0.05
    if offset_sensor is not None:
        y[offset_sensor] += offset
    return y


Y = measurements()


def exact():
    return edmf_rs.combine(model=[stats.norm(0.05, 0.08)], measurement=[stats.norm(0.0, 0.03)], n_sensors=N_M)


def monte_carlo():
    return edmf_rs.combine(model=[stats.uniform(-0.1, 0.3)], measurement=[stats.norm(0.0, 0.03)],
                           n_sensors=N_M, n_samples=100_000, seed=4)


def run(combined, y=Y, phi=0.95, correction="sidak"):
    thresholds = edmf_rs.threshold_bounds(combined, phi, correction)
    tracker = SensitivityTracker(thresholds, combined, y)
    # small batches: the counts must add up across them
    result = edmf_rs.falsify_model(model, THETA, y, thresholds, batch_size=777, progress=False, on_batch=tracker)
    return thresholds, result, tracker.finish()


def count(thresholds, y=Y, keep=slice(None)):
    return edmf_rs.falsify(model(THETA)[:, keep], y[keep], thresholds).n_candidates


def test_leave_one_out_equals_refalsifying_without_each_sensor():
    thresholds, result, _ = run(exact())
    loo = leave_one_out(result, NAMES)
    assert 0 < loo.n_candidates < THETA.shape[0]
    for i in range(N_M):
        keep = [j for j in range(N_M) if j != i]
        without = Thresholds(thresholds.low[keep], thresholds.high[keep])
        assert loo.candidates_without_sensor[i] == count(without, keep=keep), NAMES[i]
    assert loo.suspects == ()


def test_one_sensor_that_alone_falsifies_the_model_class_is_named():
    y = measurements(offset_sensor=3, offset=2.0)
    thresholds, result, sens = run(exact(), y)
    loo = leave_one_out(result, NAMES)
    assert result.n_candidates == 0
    keep = [0, 1, 2, 4, 5]
    alone = count(Thresholds(thresholds.low[keep], thresholds.high[keep]), y, keep)
    assert alone > 0 and loo.suspects == (3,) and loo.candidates_without_sensor[3] == alone
    text = findings(loo, sens)
    assert text[0].startswith(f"Sensor S3 alone falsifies the model class: ignoring it leaves {alone:,} candidates")
    # the closest instance: the smallest scale admitting it, by brute force
    r = model(THETA) - y
    c, h = (thresholds.low + thresholds.high) / 2, (thresholds.high - thresholds.low) / 2
    s_min = np.max(np.abs(r - c) / h, axis=1)
    k = int(np.argmin(s_min))
    assert sens.closest_instance == k and sens.smallest_scale == pytest.approx(s_min[k], rel=1e-12)
    np.testing.assert_array_equal(sens.closest_parameters, THETA[k])
    outside = (r < thresholds.low) | (r > thresholds.high)
    assert sens.closest_violated == tuple(np.flatnonzero(outside[k]))
    assert sens.fewest_violated == outside.sum(axis=1).min()


@pytest.mark.parametrize("combined", [exact, monte_carlo])
def test_candidates_against_the_scale_factor(combined):
    thresholds, result, sens = run(combined())
    c = (thresholds.low + thresholds.high) / 2
    for k in (40, 90, int(np.flatnonzero(SCALES == 1.0)[0]), 130, 180):
        s = SCALES[k]
        scaled = Thresholds(c + s * (thresholds.low - c), c + s * (thresholds.high - c))
        assert sens.candidates_at_scale[k] == count(scaled), s
    assert sens.candidates_at_scale[SCALES == 1.0][0] == result.n_candidates
    assert np.all(np.diff(sens.candidates_at_scale) >= 0)


@pytest.mark.parametrize("correction", ["sidak", "bonferroni", "none"])
def test_candidates_against_phi_exact(correction):
    combined = exact()
    thresholds, result, sens = run(combined, correction=correction)
    assert sens.phi_exact
    for k in (0, 10, 30, 48, sens.phis.size - 2, int(np.flatnonzero(sens.phis == 0.95)[0])):
        phi = float(sens.phis[k])
        assert sens.candidates_at_phi[k] == count(edmf_rs.threshold_bounds(combined, phi, correction)), phi
    # smallest phi admitting an instance, by brute force: Eq. 6 inverted per instance
    d = np.max(np.abs(model(THETA) - Y - combined.mean) / combined.std, axis=1).min()
    p = 1.0 - 2.0 * stats.norm.sf(d)
    expected = {"sidak": p**N_M, "bonferroni": max(0.0, 1.0 - N_M * (1.0 - p)), "none": p}[correction]
    assert sens.smallest_phi == pytest.approx(expected, abs=1e-9)


def test_candidates_against_phi_monte_carlo():
    combined = monte_carlo()
    thresholds, result, sens = run(combined)
    assert not sens.phi_exact
    for k in (0, 20, 45, int(np.flatnonzero(sens.phis == 0.95)[0]), sens.phis.size - 1):
        phi = float(sens.phis[k])
        # the Rust core's shortest intervals of the same samples (the plain window; the
        # identification's own phi uses the thresholds themselves)
        want = thresholds if phi == 0.95 else edmf_rs.threshold_bounds(combined, phi, estimator="shortest")
        assert sens.candidates_at_phi[k] == count(want), phi
    assert sens.candidates_at_phi[sens.phis == 0.95][0] == result.n_candidates


def test_monte_carlo_grid_stops_where_the_samples_cannot_resolve_phi():
    combined = edmf_rs.combine(model=[stats.uniform(-0.1, 0.3)], n_sensors=N_M, n_samples=2000, seed=1)
    thresholds = edmf_rs.threshold_bounds(combined, 0.95)
    tracker = SensitivityTracker(thresholds, combined, Y)
    # phi^(1/6) needs 1 / (1 - phi^(1/6)) samples: 2000 allow phi up to about 0.997
    assert tracker.phis.max() < 0.9975 and 0.995 in tracker.phis


def test_leave_one_out_needs_diagnostics():
    thresholds = edmf_rs.threshold_bounds(exact(), 0.95)
    result = edmf_rs.falsify(model(THETA), Y, thresholds, diagnostics=False)
    with pytest.raises(ValueError, match="diagnostics=True"):
        leave_one_out(result, NAMES)
