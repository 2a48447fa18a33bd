"""adaptive_falsify reads named model outputs (DataFrame, mapping) by name
with ``sensors=``, as falsify_model does, and names a bad ``seed``."""

import edmf_rs
import numpy as np
import pandas as pd
import pytest
from edmf_rs.adaptive import adaptive_falsify

T = edmf_rs.Thresholds([-0.1, -0.1], [0.1, 0.1])
BOUNDS = [[0.0, 1.0], [0.0, 1.0]]
Y = [1.0, 0.0]
FAST = dict(budget=100, n_screen=1024)


def frame(theta):
    """Columns in another order than the measurements, and one no sensor uses."""
    return pd.DataFrame({"B": theta[:, 0] - theta[:, 1], "T": np.zeros(len(theta)), "A": theta[:, 0] + theta[:, 1]})


def test_dataframe_outputs_are_matched_by_name():
    with pytest.warns(UserWarning, match="model outputs not among the sensors, ignored: T"):
        r = adaptive_falsify(frame, BOUNDS, Y, T, sensors=["A", "B"], **FAST)
    theta = r.run_parameters
    np.testing.assert_array_equal(r.run_predictions, np.column_stack([theta[:, 0] + theta[:, 1],
                                                                      theta[:, 0] - theta[:, 1]]))
    assert r.n_candidates > 0


def test_mapping_missing_a_sensor_and_bad_sensors_are_named():
    def mapping(theta):
        return {"A": theta[:, 0] + theta[:, 1], "C": theta[:, 1]}
    with pytest.raises(ValueError, match=r"model: provides no prediction for sensor B: the measurements have A, B"):
        adaptive_falsify(mapping, BOUNDS, Y, T, sensors=["A", "B"], **FAST)
    with pytest.raises(ValueError, match=r"sensors: expected 2 names \(one per measurement\), got 1"):
        adaptive_falsify(frame, BOUNDS, Y, T, sensors=["A"], **FAST)
    with pytest.raises(TypeError, match=r"model: returned DataFrame with named columns .*pass sensors=\[...\]"):
        adaptive_falsify(frame, BOUNDS, Y, T, **FAST)  # the advice given is now an argument that exists


@pytest.mark.parametrize("seed, error", [(-1, ValueError), ("a", TypeError), (True, TypeError)])
def test_bad_seed_is_named(seed, error):
    def linear(theta):
        return np.column_stack([theta[:, 0] + theta[:, 1], theta[:, 0] - theta[:, 1]])
    with pytest.raises(error, match=r"seed: expected an integer >= 0, got "):
        adaptive_falsify(linear, BOUNDS, Y, T, seed=seed, **FAST)
