"""edmf_rs.dask.falsify_model(..., sensors=...): named model outputs matched to
the sensors by name on the workers, with the same result, warnings and errors
as edmf_rs.falsify_model (issue 12 part 1)."""

from __future__ import annotations

import re
import warnings

import dask
import edmf_rs
import edmf_rs.dask as edask
import numpy as np
import pandas as pd
import pytest
from edmf_rs import Thresholds
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

N_M = 5
NAMES = [f"D{i}" for i in range(N_M)]


def _g(theta):
    i = np.arange(N_M)
    return theta[:, :1] * (1.0 + 0.2 * i) + theta[:, 1:2] * np.sin(i + 1.0)


def _shuffled(order, kind="frame", extra=True):
    def model(theta):
        g = _g(theta)
        cols = {NAMES[j]: g[:, j] for j in order}
        if extra:
            cols["reaction"] = g.sum(axis=1)
        if kind == "frame":
            return pd.DataFrame(cols)
        if kind == "mapping":
            return cols
        out = np.zeros(len(g), dtype=[(k, "f8") for k in cols])
        for k, v in cols.items():
            out[k] = v
        return out
    return model


def _case(seed):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(-1.0, 1.0, (3_000, 2))
    y = _g(np.array([[0.2, -0.3]]))[0] + rng.normal(0, 0.05, N_M)
    return theta, y, Thresholds(np.full(N_M, -0.6), np.full(N_M, 0.6))


def _same(got, want):
    for name in ("candidate_indices", "per_sensor_falsified", "falsified_only_by", "n_invalid",
                 "candidate_parameters", "candidate_predictions"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(order=st.permutations(range(N_M)), kind=st.sampled_from(["frame", "mapping", "structured"]),
       seed=st.integers(0, 2**16), batch_size=st.integers(100, 3_000))
def test_shuffled_named_columns_on_dask_equal_the_local_unshuffled_answer(order, kind, seed, batch_size):
    theta, y, t = _case(seed)
    want = edmf_rs.falsify_model(_g, theta, y, t, progress=False)  # bare array, in the sensors' order
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the ignored "reaction" output
        local = edmf_rs.falsify_model(_shuffled(order, kind), theta, y, t, progress=False, sensors=NAMES)
        with dask.config.set(scheduler="threads"):
            got = edask.falsify_model(_shuffled(order, kind), theta, y, t, batch_size=batch_size, progress=False,
                                      sensors=NAMES)
    _same(local, want)
    _same(got, want)


def test_an_iterable_of_batches_and_a_warning_for_ignored_outputs():
    theta, y, t = _case(1)
    want = edmf_rs.falsify_model(_g, theta, y, t, progress=False)
    batches = (theta[i:i + 700] for i in range(0, len(theta), 700))
    with pytest.warns(UserWarning, match="model outputs not among the sensors, ignored: reaction"):
        got = edask.falsify_model(_shuffled([4, 2, 0, 1, 3]), batches, y, t, progress=False, sensors=NAMES,
                                  window=2)
    _same(got, want)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no extra output: no warning
        edask.falsify_model(_shuffled([1, 0, 2, 3, 4], extra=False), theta, y, t, progress=False, sensors=NAMES)


def _error(call):
    with pytest.raises((TypeError, ValueError)) as info:
        call()
    return type(info.value), str(info.value)


@pytest.mark.parametrize("case", ["missing", "no_sensors", "wrong_count", "not_names", "twice"])
def test_errors_are_those_of_the_local_call(case):
    theta, y, t = _case(2)
    model, sensors = _shuffled([3, 1, 0, 2, 4]), NAMES
    if case == "missing":
        model = lambda th: pd.DataFrame({n: _g(th)[:, j] for j, n in enumerate(NAMES) if n != "D3"})  # noqa: E731
    elif case == "no_sensors":
        sensors = None
    elif case == "wrong_count":
        sensors = NAMES[:3]
    elif case == "not_names":
        sensors = [1, 2, 3, 4, 5]
    else:
        sensors = ["D0", "D0", "D1", "D2", "D3"]
    local = _error(lambda: edmf_rs.falsify_model(model, theta, y, t, progress=False, sensors=sensors,
                                                 batch_size=1_000))
    with dask.config.set(scheduler="sync"):
        remote = _error(lambda: edask.falsify_model(model, theta, y, t, progress=False, sensors=sensors,
                                                    batch_size=1_000))
    # The same type and message; the batch named is the one that failed first, which Dask may order otherwise.
    batch = re.compile(r"\(batch \d+, instances \d+\.\.\d+\)|on batch \d+, instances \d+\.\.\d+")
    assert (remote[0], batch.sub("<batch>", remote[1])) == (local[0], batch.sub("<batch>", local[1]))
    if case == "missing":
        assert "provides no prediction for sensor D3" in local[1] and "D0, D1, D2, D4" in local[1]
