"""edmf_rs.dask on a real multi-process LocalCluster gives exactly the
in-process result; Dask stays an optional dependency."""

from __future__ import annotations

import subprocess
import sys

import dask.array as da
import edmf_rs
import edmf_rs.dask as edask
import numpy as np
import pytest
from distributed import Client, LocalCluster
from edmf_rs import Thresholds

N_M = 8


def _case(n=30_011, seed=2):
    rng = np.random.default_rng(seed)
    predictions = rng.normal(0.0, 1.0, (n, N_M))
    predictions[rng.random(n) < 0.6] *= 0.3
    predictions[11::503, 4] = np.nan
    return predictions, np.zeros(N_M), Thresholds(np.full(N_M, -1.4), np.full(N_M, 1.4))


def _model(theta):
    i = np.arange(N_M)
    return theta[:, :1] * (1.0 + 0.1 * i) + theta[:, 1:2] * np.cos(i)


def _same(got, want):
    assert got.n_instances == want.n_instances
    for name in ("candidate_indices", "per_sensor_falsified", "falsified_only_by", "n_invalid", "n_violated",
                 "candidate_parameters", "candidate_predictions"):
        a, b = getattr(got, name), getattr(want, name)
        assert (a is None) == (b is None), name
        if a is not None:
            np.testing.assert_array_equal(a, b, err_msg=name)


@pytest.fixture(scope="module")
def client():
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as c:
        yield c


def test_dask_array_matches_in_process(client):
    predictions, y, t = _case()
    for chunks in ((4_000, N_M), (7_001, 3), (30_011, N_M)):  # split columns are gathered first
        arr = da.from_array(predictions, chunks=chunks)
        _same(edask.falsify(arr, y, t, client=client), edmf_rs.falsify(predictions, y, t, keep_violations=False))
    arr = da.from_array(predictions.astype(np.float32), chunks=(5_000, N_M))
    _same(edask.falsify(arr, y, t, keep_violations=True),  # on the default (current) client
          edmf_rs.falsify(predictions.astype(np.float32), y, t, keep_violations=True))
    screened = edask.falsify(arr, y, t, diagnostics=False, client=client)
    np.testing.assert_array_equal(screened.candidate_indices,
                                  edmf_rs.falsify(predictions.astype(np.float32), y, t).candidate_indices)
    assert screened.thresholds is t


def test_worker_pools_match_worker_threads(client):
    predictions, y, t = _case(1_000)
    edask.falsify(da.from_array(predictions, chunks=(500, N_M)), y, t, client=client)
    assert set(client.run(edmf_rs.get_num_threads).values()) == {1}


def test_model_on_workers_matches_in_process(client):
    theta = np.random.default_rng(4).uniform(-1.0, 1.0, (20_000, 2))
    _, y, t = _case()
    want = edmf_rs.falsify_model(_model, theta, y, t, batch_size=1_500)
    assert 0 < want.n_candidates < len(theta)
    _same(edask.falsify_model(_model, theta, y, t, batch_size=1_500, client=client), want)
    _same(edask.falsify_model(_model, da.from_array(theta, chunks=(3_000, 2)), y, t, client=client), want)
    batches = (theta[i:i + 1_234] for i in range(0, len(theta), 1_234))
    _same(edask.falsify_model(lambda b: _model(b), batches, y, t, client=client, window=3), want)


def test_model_error_on_a_worker_names_the_batch(client):
    theta = np.random.default_rng(4).uniform(-1.0, 1.0, (4_000, 2))
    _, y, t = _case()

    def fails(batch):
        if batch[0, 0] == theta[3_000, 0]:
            raise RuntimeError("mesh failed")
        return _model(batch)

    with pytest.raises(RuntimeError, match="mesh failed") as info:
        edask.falsify_model(fails, theta, y, t, batch_size=1_000, client=client)
    assert "batch 3, instances 3000..3999" in " ".join(info.value.__notes__)
    with pytest.raises(ValueError, match=r"expected a 2-D array with 8 columns"):
        edask.falsify(da.zeros((10, 3)), y, t, client=client)


def test_local_scheduler_without_distributed(monkeypatch):
    monkeypatch.setattr(edask, "_client", lambda client: None)
    predictions, y, t = _case(5_000)
    arr = da.from_array(predictions, chunks=(1_000, 4))
    _same(edask.falsify(arr, y, t), edmf_rs.falsify(predictions, y, t, keep_violations=False))
    theta = np.random.default_rng(4).uniform(-1.0, 1.0, (3_000, 2))
    _same(edask.falsify_model(_model, iter(np.array_split(theta, 5)), y, t, window=2),
          edmf_rs.falsify_model(_model, theta, y, t))


def test_dask_is_optional():
    code = "import sys, edmf_rs; assert 'dask' not in sys.modules and 'distributed' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)
    code = ("import sys; sys.modules['dask'] = None\n"
            "try:\n    import edmf_rs.dask\nexcept ImportError as e:\n    print(e)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    assert "pip install edmf_rs[dask]" in out


def test_model_batches_from_a_refilled_buffer_and_1d_parameters(client):
    theta = np.random.default_rng(8).uniform(-1.0, 1.0, (4_000, 2))
    _, y, t = _case()

    def refilled():
        buffer = np.empty((500, 2))
        for first in range(0, len(theta), 500):
            buffer[:] = theta[first:first + 500]
            yield buffer

    got = edask.falsify_model(_model, refilled(), y, t, client=client, window=8, progress=False)
    _same(got, edmf_rs.falsify_model(_model, theta, y, t, progress=False))
    one = theta[:, :1].ravel()
    got = edask.falsify_model(lambda b: _model(np.hstack([b, b])), one, y, t, batch_size=700, client=client,
                              progress=False)
    want = edmf_rs.falsify_model(lambda b: _model(np.hstack([b, b])), one, y, t, batch_size=700, progress=False)
    _same(got, want)


def test_a_list_of_parameter_rows_is_an_array_on_dask_too(client):
    _, y, t = _case()
    rows = [[0.0, 0.5], [2.0, 0.0], [0.25, 0.25], [-3.0, 1.0]]
    want = edmf_rs.falsify_model(_model, np.array(rows), y, t, progress=False)
    _same(edmf_rs.falsify_model(_model, rows, y, t, progress=False), want)
    _same(edask.falsify_model(_model, rows, y, t, client=client, batch_size=3, progress=False), want)
    assert want.n_instances == 4 and want.candidate_parameters.shape[1] == 2


def test_empty_batches_and_empty_1d_parameters_keep_shapes_and_dtypes(client):
    _, y, t = _case()

    def model32(theta):
        return _model(theta).astype(np.float32)

    theta = np.random.default_rng(5).normal(0.0, 0.5, (50, 2))
    batches = [theta[:20], theta[:0], theta[20:]]
    want = edmf_rs.falsify_model(model32, theta, y, t, progress=False)
    got = edask.falsify_model(model32, iter(batches), y, t, client=client, progress=False)
    _same(got, want)
    assert want.n_candidates and got.candidate_predictions.dtype == want.candidate_predictions.dtype == np.float32
    # A 1-D parameter array is (N, 1), with no rows too; results of row splits concatenate.
    one = lambda p: np.repeat(p, N_M, axis=1)  # noqa: E731
    empty = edmf_rs.falsify_model(one, np.arange(0.0), y, t, progress=False)
    assert empty.candidate_parameters.shape == (0, 1)
    assert edask.falsify_model(one, np.arange(0.0), y, t, client=client, progress=False).candidate_parameters.shape == (0, 1)
    full = edmf_rs.falsify_model(one, np.zeros(5), y, t, progress=False)
    assert edmf_rs.concatenate([empty, full]).candidate_parameters.shape == (5, 1)


def test_a_worker_lost_as_a_call_starts_does_not_fail_it(client, monkeypatch):
    # A call used to broadcast to every worker first (client.run), which failed
    # the whole call when a worker died meanwhile; now each task sizes its own
    # worker's pool, and Dask reschedules the tasks of a lost worker.
    predictions, y, t = _case()

    def worker_died(*args, **kwargs):
        raise OSError("Timed out trying to connect to a worker that died")

    monkeypatch.setattr(client, "run", worker_died)
    arr = da.from_array(predictions, chunks=(4_000, N_M))
    _same(edask.falsify(arr, y, t, client=client), edmf_rs.falsify(predictions, y, t, keep_violations=False))


def test_a_worker_killed_just_before_a_call(tmp_path):
    import os
    import signal

    predictions, y, t = _case()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as c:
        pids = c.run(os.getpid)
        os.kill(next(iter(pids.values())), signal.SIGKILL)
        arr = da.from_array(predictions, chunks=(4_000, N_M))
        _same(edask.falsify(arr, y, t, client=c), edmf_rs.falsify(predictions, y, t, keep_violations=False))
