"""The cantilever example of Sec. 4: geometry, model, model error and simulated data."""

import math

import numpy as np
import pytest
from edmf_rs.examples import cantilever as cl


def test_constants_are_the_papers():
    assert (cl.E_TRUE, cl.FORCE, cl.LENGTH, cl.INERTIA) == (70e3, 5e3, 3000.0, 6.75e8)
    assert cl.INERTIA == pytest.approx(300.0**4 / 12)  # 300 mm x 300 mm square section
    assert cl.E_GRID.shape == (101,)
    assert (cl.E_GRID[0], cl.E_GRID[-1], cl.GRID_STEP) == (20e3, 100e3, 800.0)


def test_scenarios_are_frozen_data():
    s1, s2, s3 = cl.SCENARIOS
    assert (s1.number, s1.K, s1.model_uncertainty_recognised) == (1, math.inf, False)
    assert (s2.number, s2.K, s2.model_uncertainty_recognised) == (2, 12e10, True)
    assert (s3.number, s3.K, s3.model_uncertainty_recognised) == (3, 12e10, False)
    assert not s1.has_model_error and s2.has_model_error and s3.has_model_error
    with pytest.raises(AttributeError):
        s1.K = 1.0
    assert cl.scenario(2) is s2
    with pytest.raises(ValueError, match="number"):
        cl.scenario(4)


def test_sensor_positions():
    assert cl.sensor_positions(1).tolist() == [3000.0]
    assert cl.sensor_positions(2).tolist() == [1750.0, 3000.0]
    x = cl.sensor_positions(10)
    assert x[0] == 750.0 and x[-1] == 3000.0 and np.allclose(np.diff(x), 250.0)
    assert cl.sensor_positions(50)[0] == 550.0
    with pytest.raises(ValueError, match="n_m"):
        cl.sensor_positions(0)


def test_tip_deflection_matches_hand_value():
    # F l^3 / (3 E I) = 5e3 * 2.7e10 / (3 * 7e4 * 6.75e8) = 0.952381 mm
    assert cl.deflection([3000.0], 70e3)[0] == pytest.approx(0.9523809523809523, rel=1e-12)


def test_predictions_cover_the_grid_at_once():
    x = cl.sensor_positions(10)
    g = cl.predictions(x)
    assert g.shape == (101, 10)
    # v is proportional to 1/E: each row is the E* row scaled by E*/E.
    ref = cl.deflection(x, cl.E_TRUE)
    assert np.allclose(g, ref[None, :] * cl.E_TRUE / cl.E_GRID[:, None], rtol=1e-12)
    assert np.all(np.diff(g[:, -1]) < 0)  # stiffer beam, smaller deflection


def test_model_error_is_a_rigid_rotation():
    x = np.array([500.0, 3000.0])
    assert np.array_equal(cl.model_error(x, math.inf), [0.0, 0.0])
    # F l x / K = 5e3 * 3000 * 3000 / 12e10 = 0.375 mm, and the model under-predicts.
    assert cl.model_error(x, 12e10) == pytest.approx([-0.0625, -0.375])
    with pytest.raises(ValueError, match="K"):
        cl.model_error(x, 0.0)


def test_simulated_measurements_follow_eq13():
    x = cl.sensor_positions(2)
    y = cl.simulate_measurements(x, 12e10, np.random.default_rng(3), size=40_000)
    assert y.shape == (40_000, 2)
    expected = cl.deflection(x, 70e3) + 5e3 * 3000 * x / 12e10
    assert np.allclose(y.mean(axis=0), expected, atol=4 * 0.02 / 200)
    assert np.allclose(y.std(axis=0), 0.02, rtol=0.03)
    assert abs(np.corrcoef(y.T)[0, 1]) < 0.03  # independent sensors


def test_simulation_is_deterministic_and_row_k_does_not_depend_on_size():
    x = cl.sensor_positions(10)
    a = cl.simulate_measurements(x, math.inf, 7, size=5)
    b = cl.simulate_measurements(x, math.inf, np.random.default_rng(7), size=50)
    assert np.array_equal(a, b[:5])
    assert cl.simulate_measurements(x, math.inf, 7).shape == (10,)


@pytest.mark.parametrize("number", [1, 2, 3])
def test_combined_moments_agree_with_combine(number):
    scn = cl.scenario(number)
    y = cl.simulate_measurements(cl.sensor_positions(10), scn.K, 1)
    mean, sd = cl.combined_moments(scn, y)
    combined = cl.combined_uncertainty(scn, y)
    assert combined.exact
    assert np.allclose(mean, combined.mean, rtol=1e-12, atol=1e-15)
    assert np.allclose(sd, combined.std, rtol=1e-12)


def test_recognised_model_uncertainty_is_relative_to_measured():
    y = np.array([0.5, 1.0])
    mean, sd = cl.combined_moments(cl.scenario(2), y)
    assert mean == pytest.approx([-0.05, -0.10])
    assert sd == pytest.approx(np.sqrt((0.15 * y) ** 2 + 0.02**2))
    mean, sd = cl.combined_moments(cl.scenario(3), y)
    assert np.array_equal(mean, [0.0, 0.0]) and np.array_equal(sd, [0.02, 0.02])
    assert (cl.MODEL_FRACTION.mean(), cl.MODEL_FRACTION.std()) == pytest.approx((-0.10, 0.15))
