"""Probe 24 findings: Dask arrays with rows of unknown size, the borderline
functions' and Thresholds' standard-error arguments, and named model outputs
whose columns differ in length: each gives the right result or an error naming
the argument and what was expected."""

from __future__ import annotations

import dask
import dask.array as da
import edmf_rs
import edmf_rs.dask as edask
import numpy as np
import pytest
from edmf_rs import Thresholds
from edmf_rs.engine.borderline import BorderlineCounter, borderline_instances, borderline_mask
from edmf_rs.engine.sensors import SensorMatch, SensorMismatch

# -- 1. edmf_rs.dask.falsify: rows of unknown size, columns split ------------


@pytest.mark.parametrize("col_chunks", [1, 2])
def test_dask_falsify_rows_of_unknown_size_with_split_columns(monkeypatch, col_chunks):
    monkeypatch.setattr(edask, "_client", lambda client: None)  # the local threaded scheduler
    rng = np.random.default_rng(24)
    n, n_m = 1_003, 3
    predictions = rng.normal(0.0, 1.0, (n, n_m))
    keep = rng.random(n) < 0.7
    low, high = np.array([-1.2, -1.0, -1.5]), np.array([1.1, 1.3, 0.9])
    y = np.array([0.1, -0.2, 0.05])
    t = Thresholds(low, high)
    P = da.from_array(predictions, chunks=(200, col_chunks))[da.from_array(keep, chunks=200)]
    assert np.isnan(P.chunks[0][0]) and len(P.chunks[1]) > 1  # unknown row sizes, columns split

    with dask.config.set(scheduler="threads"):
        got = edask.falsify(P, y, t, progress=False)

    rows = predictions[keep]
    r = rows - y
    expected = np.flatnonzero(np.all((low <= r) & (r <= high), axis=1))
    assert got.n_instances == rows.shape[0]
    np.testing.assert_array_equal(got.candidate_indices, expected)
    want = edmf_rs.falsify(rows, y, t)
    np.testing.assert_array_equal(got.candidate_indices, want.candidate_indices)
    np.testing.assert_array_equal(got.per_sensor_falsified, want.per_sensor_falsified)
    np.testing.assert_array_equal(got.falsified_only_by, want.falsified_only_by)


# -- 2. borderline_instances / borderline_mask arguments -------------------

T1 = Thresholds([-1.0], [1.0], se_low=[0.01], se_high=[0.01])
P1 = np.array([[0.0], [0.99], [1.5]])


@pytest.mark.parametrize("k", ["2", None, True, [2.0]])
def test_borderline_k_of_the_wrong_type_is_named(k):
    for f in (borderline_instances, borderline_mask):
        with pytest.raises(TypeError, match=r"^k: expected a number of standard errors >= 0"):
            f(P1, [0.0], T1, k=k)
    with pytest.raises(TypeError, match=r"^k: expected"):
        BorderlineCounter(T1, [0.0], k=k)


@pytest.mark.parametrize("k", [-1.0, float("nan"), float("inf"), -np.inf])
def test_borderline_k_out_of_range_is_named(k):
    with pytest.raises(ValueError, match=r"^k: expected a finite number of standard errors >= 0"):
        borderline_mask(P1, [0.0], T1, k=k)


def test_borderline_k_accepts_integers_and_numpy_numbers():
    assert borderline_instances(P1, [0.0], T1, k=2).tolist() == [1]
    assert borderline_instances(P1, [0.0], T1, k=np.float32(2.0)).tolist() == [1]
    assert borderline_instances(P1, [0.0], T1, k=0).tolist() == []


def test_borderline_predictions_not_numeric_are_named():
    with pytest.raises(TypeError, match=r"^predictions: expected real numbers"):
        borderline_instances([["a"]], [0.0], T1)


def test_borderline_thresholds_not_thresholds_are_named():
    for f in (borderline_instances, borderline_mask):
        with pytest.raises(TypeError, match=r"^thresholds: expected edmf_rs.Thresholds, got tuple"):
            f(P1, [0.0], (-1.0, 1.0))
    with pytest.raises(TypeError, match=r"^thresholds: expected edmf_rs.Thresholds"):
        BorderlineCounter((-1.0, 1.0), [0.0])


# -- 3. Thresholds(se_low=..., se_high=...) ---------------------------------


@pytest.mark.parametrize("name", ["se_low", "se_high"])
@pytest.mark.parametrize("value", [[0.1, 0.1, 0.1], [0.1], 0.1, [[0.1, 0.1]]])
def test_thresholds_standard_errors_of_the_wrong_length_are_named(name, value):
    with pytest.raises(ValueError, match=rf"^{name}: expected 2 standard errors \(one per sensor\)"):
        Thresholds([-1.0, -1.0], [1.0, 1.0], **{name: value})


@pytest.mark.parametrize("name", ["se_low", "se_high"])
@pytest.mark.parametrize("value", [[0.1, np.nan], [-0.1, 0.0], [0.0, -np.inf]])
def test_thresholds_standard_errors_nan_or_negative_are_refused(name, value):
    with pytest.raises(ValueError, match=rf"^{name}: expected standard errors >= 0, got"):
        Thresholds([-1.0, -1.0], [1.0, 1.0], **{name: value})


def test_thresholds_standard_errors_not_numeric_are_named():
    with pytest.raises(TypeError, match=r"^se_high: expected real numbers, got dtype <U1$"):
        Thresholds([-1.0, -1.0], [1.0, 1.0], se_high=["a", "b"])


def test_thresholds_standard_errors_the_library_makes_stay_valid():
    # +inf is what the bootstrap reports when it cannot estimate an SE; 0 marks an exact bound.
    t = Thresholds([-1.0, -1.0], [1.0, 1.0], se_low=[np.inf, 0.0], se_high=[0, 2])
    assert t.se_low.tolist() == [np.inf, 0.0] and t.se_high.tolist() == [0.0, 2.0]
    assert t.se_high.dtype == np.float64
    rng = np.random.default_rng(0)
    mc = edmf_rs.threshold_bounds(rng.normal(size=(20_000, 2)), 0.9)
    assert mc.se_low.shape == (2,) and np.all(mc.se_low > 0) and np.all(mc.se_high > 0)


# -- 4. named model outputs whose columns differ in length -----------------


def _ragged(theta):
    return {"D1": theta[:, 0], "D2": theta[:1, 0]}


def test_sensor_match_columns_of_different_lengths_are_named():
    with pytest.raises(SensorMismatch, match=r"^returned columns of different lengths for the sensors "
                                             r"\(D1 has 5, D2 has 1 rows\)"):
        SensorMatch(["D1", "D2"])(_ragged(np.zeros((5, 1))), 5)


def test_falsify_model_mapping_with_ragged_columns_names_sensors_and_lengths():
    t = Thresholds([-1.0, -1.0], [1.0, 1.0])
    with pytest.raises(ValueError, match=r"^model: returned columns of different lengths for the sensors "
                                         r"\(D1 has 5, D2 has 1 rows\).*\(batch 0"):
        edmf_rs.falsify_model(_ragged, np.zeros((5, 1)), [0.0, 0.0], t, sensors=["D1", "D2"], progress=False)


def test_dask_falsify_model_mapping_with_ragged_columns_names_sensors_and_lengths(monkeypatch):
    monkeypatch.setattr(edask, "_client", lambda client: None)
    t = Thresholds([-1.0, -1.0], [1.0, 1.0])
    with dask.config.set(scheduler="threads"), pytest.raises(
            ValueError, match=r"^model: returned columns of different lengths for the sensors \(D1 has 5, D2 has 1"):
        edask.falsify_model(_ragged, np.zeros((5, 1)), [0.0, 0.0], t, sensors=["D1", "D2"], progress=False)
