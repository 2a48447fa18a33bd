"""Streaming falsification: files, iterables and models give exactly the
NumPy reference result whatever the chunking and the thread count, and bad
inputs fail with errors naming what is wrong."""

from __future__ import annotations

import _thread
import threading

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds, reference
from edmf_rs.stream import npy, progress
from scipy.stats import qmc

N_M = 6


def _data(n=3_001, seed=0, n_m=N_M):
    rng = np.random.default_rng(seed)
    predictions = rng.normal(0.0, 1.0, (n, n_m))
    predictions[rng.random(n) < 0.7] *= 0.4  # mix of candidates and falsified instances
    predictions[::97, 1] = 1.5  # exactly on the upper bound: a candidate (Eq. 8 is inclusive)
    predictions[5::211, 2] = np.nan  # invalid instances
    return predictions, np.zeros(n_m), Thresholds(np.full(n_m, -1.5), np.full(n_m, 1.5))


def _same(got, want, violations=True):
    assert got.n_instances == want.n_instances
    np.testing.assert_array_equal(got.candidate_indices, want.candidate_indices)
    assert got.candidate_indices.dtype == np.int64
    if got.per_sensor_falsified is not None:
        np.testing.assert_array_equal(got.per_sensor_falsified, want.per_sensor_falsified)
        np.testing.assert_array_equal(got.falsified_only_by, want.falsified_only_by)
        assert got.n_invalid == want.n_invalid
    if violations:
        np.testing.assert_array_equal(got.n_violated, want.n_violated)


@pytest.fixture
def threads():
    before = edmf_rs.get_num_threads()
    yield edmf_rs.set_num_threads
    edmf_rs.set_num_threads(before)


def _reader_threads():
    return [t for t in threading.enumerate() if t.name.startswith("edmf-rs-npy-")]  # reader and helper


# -- files -----------------------------------------------------------------

LAYOUTS = {
    "C float64": lambda p: p,
    "Fortran": np.asfortranarray,
    "big-endian": lambda p: p.astype(">f8"),
    "float32": lambda p: p.astype(np.float32),
    "big-endian float32": lambda p: np.asfortranarray(p.astype(">f4")),
    "int32": lambda p: np.nan_to_num(p * 3).astype(np.int32),
    "uint8": lambda p: np.nan_to_num(np.abs(p)).astype(np.uint8),
}


@pytest.mark.parametrize("layout", LAYOUTS)
def test_file_layouts_chunkings_and_threads_match_reference(tmp_path, threads, layout):
    predictions, y, t = _data()
    stored = LAYOUTS[layout](predictions)
    path = tmp_path / "p.npy"
    np.save(path, stored)
    want = reference.falsify(np.asarray(stored), y, t)
    for n_threads in (1, 2):
        threads(n_threads)
        for chunk_rows in (None, 1, 1000, 5_000):
            got = edmf_rs.falsify(path, y, t, chunk_rows=chunk_rows, keep_violations=True)
            _same(got, want)
            screened = edmf_rs.falsify(str(path), y, t, chunk_rows=chunk_rows, diagnostics=False)
            np.testing.assert_array_equal(screened.candidate_indices, want.candidate_indices)
    assert not _reader_threads()


def test_file_many_default_chunks_reuse_two_buffers(tmp_path, monkeypatch):
    predictions, y, t = _data(20_011)
    path = tmp_path / "p.npy"
    np.save(path, predictions.astype(np.float32))
    monkeypatch.setattr(npy, "CHUNK_BYTES", 24 * 1024)  # ~1000 rows a chunk
    addresses, rows = set(), []
    for block in npy.read_chunks(path):
        addresses.add(block.__array_interface__["data"][0])
        rows.append(block.copy())
    np.testing.assert_array_equal(np.concatenate(rows), predictions.astype(np.float32))
    assert len(rows) > 10 and len(addresses) == 2  # double buffered, memory independent of N
    _same(edmf_rs.falsify(path, y, t, keep_violations=True), reference.falsify(predictions.astype(np.float32), y, t))


def test_read_chunks_from_a_row_and_stop_early(tmp_path):
    predictions, _, _ = _data(5_000)
    path = tmp_path / "p.npy"
    np.save(path, np.asfortranarray(predictions))
    got = np.concatenate([b.copy() for b in npy.read_chunks(path, chunk_rows=700, start=1234)])
    np.testing.assert_array_equal(got, predictions[1234:])
    assert list(npy.read_chunks(path, start=5_000)) == []
    stream = npy.read_chunks(path, chunk_rows=100)
    next(stream)
    stream.close()  # a consumer that stops early stops the reader thread too
    assert not _reader_threads()


def test_ctrl_c_while_streaming_a_file_stops_the_reader(tmp_path, monkeypatch):
    predictions, y, t = _data(50_000)
    path = tmp_path / "p.npy"
    np.save(path, predictions)
    fill, fills = npy._Slot.fill, []

    def fill_then_ctrl_c(slot, *args):
        fills.append(1)
        if len(fills) == 3:
            _thread.interrupt_main()  # Ctrl-C while the main thread falsifies
        return fill(slot, *args)

    monkeypatch.setattr(npy._Slot, "fill", fill_then_ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify(path, y, t, chunk_rows=500)
    assert not _reader_threads() and len(fills) < 100


def test_empty_file(tmp_path):
    _, y, t = _data()
    path = tmp_path / "empty.npy"
    np.save(path, np.empty((0, N_M)))
    result = edmf_rs.falsify(path, y, t)
    assert result.n_instances == 0 and result.n_candidates == 0


def _npy_bytes(arr) -> bytes:
    import io

    buf = io.BytesIO()
    np.save(buf, arr)
    return buf.getvalue()


def test_truncated_file_is_refused_naming_it(tmp_path):
    predictions, y, t = _data()
    path = tmp_path / "cut.npy"
    path.write_bytes(_npy_bytes(predictions)[:-8])
    with pytest.raises(ValueError, match=r"cut\.npy is truncated"):
        edmf_rs.falsify(path, y, t)


@pytest.mark.parametrize("order, dtype", [("C", np.float64), ("F", np.float32), ("C", ">f4")])
def test_large_reads_split_between_two_threads_read_every_byte(tmp_path, order, dtype):
    # Chunks of several MiB are read half by a helper thread (positional reads).
    rng = np.random.default_rng(11)
    predictions = np.asarray(rng.normal(size=(170_003, 7)), order=order).astype(dtype)
    path = tmp_path / "big.npy"
    np.save(path, predictions)
    assert npy.CHUNK_BYTES >= 2 * npy.SPLIT_BYTES
    got = np.concatenate([b.copy() for b in npy.read_chunks(path, start=5)])
    np.testing.assert_array_equal(got, predictions[5:].astype(got.dtype))
    assert not _reader_threads()


@pytest.mark.parametrize("rows, chunk_rows", [(20_000, 1000), (200_000, 50_000)])  # the second splits reads
def test_file_truncated_while_read_fails_cleanly(tmp_path, rows, chunk_rows):
    predictions, _, _ = _data(rows)
    path = tmp_path / "shrinking.npy"
    np.save(path, predictions)
    stream = npy.read_chunks(path, chunk_rows=chunk_rows)
    next(stream)
    with open(path, "r+b") as fh:
        fh.truncate(200)
    with pytest.raises(ValueError, match=r"shrinking\.npy ended early"):
        for _ in stream:
            pass
    assert not _reader_threads()


@pytest.mark.parametrize("content, error, message", [
    (b"", ValueError, "not a readable .npy file"),
    (b"PK\x03\x04 this is a zip file, not npy", ValueError, "not a readable .npy file"),
    (b"\x93NUMPY\x01\x00\x10\x00{'descr': '<f8',  \n", ValueError, "not a readable .npy file"),
    (b"\x93NUMPY\x09\x00", ValueError, "not a readable .npy file"),
    (_npy_bytes(np.zeros(N_M)), ValueError, "expected a 2-D array"),
    (_npy_bytes(np.zeros((2, 3, N_M))), ValueError, "expected a 2-D array"),
    (_npy_bytes(np.zeros((4, N_M), dtype=complex)), TypeError, "numeric .npy file"),
    (_npy_bytes(np.zeros((4, N_M + 1))), ValueError, "has 7 columns"),
    # A header with a negative row count (np.load refuses it too): not an empty run.
    (_npy_bytes(np.zeros((5, N_M))).replace(b"(5, 6)", b"(-5, 6)"), ValueError, r"header gives shape \(-5, 6\)"),
])
def test_corrupt_files_are_refused_naming_them(tmp_path, content, error, message):
    _, y, t = _data()
    path = tmp_path / "bad.npy"
    path.write_bytes(content)
    with pytest.raises(error, match=message) as info:
        edmf_rs.falsify(path, y, t)
    assert "bad.npy" in str(info.value)


def test_missing_file(tmp_path):
    _, y, t = _data()
    with pytest.raises(ValueError, match="cannot open .*nowhere.npy"):
        edmf_rs.falsify(tmp_path / "nowhere.npy", y, t)


# -- iterables ---------------------------------------------------------------

def test_iterables_match_reference_whatever_the_chunks_and_threads(threads):
    predictions, y, t = _data()
    want = reference.falsify(predictions, y, t)
    rng = np.random.default_rng(3)
    for n_threads in (1, 2):
        threads(n_threads)
        cuts = np.sort(rng.integers(0, len(predictions), 12))
        pieces = np.split(predictions, cuts)  # includes empty chunks
        _same(edmf_rs.falsify(pieces, y, t), want)
        _same(edmf_rs.falsify(iter(pieces), y, t), want)
        _same(edmf_rs.falsify((p.astype(np.float32) for p in pieces), y, t),
              reference.falsify(predictions.astype(np.float32), y, t))


def test_generator_refilling_one_buffer():
    predictions, y, t = _data()
    buffer = np.empty((500, N_M))

    def refilled():
        for first in range(0, len(predictions), 500):
            block = buffer[:len(predictions[first:first + 500])]
            block[...] = predictions[first:first + 500]
            yield block

    _same(edmf_rs.falsify(refilled(), y, t), reference.falsify(predictions, y, t))


def test_iterable_chunk_of_wrong_width():
    predictions, y, t = _data()
    chunks = [predictions[:100], predictions[100:200, :-1]]
    with pytest.raises(ValueError, match=r"predictions: chunk 1 has 5 columns, expected 6 like the first chunk"):
        edmf_rs.falsify(chunks, y, t)


def test_array_chunking_and_threads(threads):
    predictions, y, t = _data()
    want = reference.falsify(predictions, y, t)
    for n_threads in (1, 2):
        threads(n_threads)
        for chunk_rows in (None, 1, 999):
            _same(edmf_rs.falsify(predictions, y, t, chunk_rows=chunk_rows), want)
            _same(edmf_rs.falsify(predictions[::-1], y, t, chunk_rows=chunk_rows),
                  reference.falsify(predictions[::-1], y, t))


def test_misaligned_array_is_copied_not_refused():
    predictions, y, t = _data()
    raw = np.empty(predictions.nbytes + 1, dtype=np.uint8)
    misaligned = raw[1:].view(np.float64).reshape(predictions.shape)  # e.g. from an unpickled buffer
    misaligned[...] = predictions
    assert not misaligned.flags.aligned
    _same(edmf_rs.falsify(misaligned, y, t), reference.falsify(predictions, y, t))


# -- falsify_model -----------------------------------------------------------

def _model(theta):
    """Sensor i reads a_i + b_i * theta_0 - theta_1 * (i - 2)."""
    i = np.arange(N_M)
    return 0.3 * i + theta[:, :1] * (1.0 + 0.1 * i) - theta[:, 1:2] * (i - 2)


def _model_case(n=4_000, seed=1):
    theta = np.random.default_rng(seed).uniform(-1.0, 1.0, (n, 2))
    y = _model(np.array([[0.2, -0.3]]))[0]
    t = Thresholds(np.full(N_M, -0.6), np.full(N_M, 0.6))
    return theta, y, t


def _same_model(got, theta, y, t):
    predictions = _model(theta)
    want = reference.falsify(predictions, y, t)
    _same(got, want, violations=False)
    np.testing.assert_array_equal(got.candidate_parameters, theta[want.candidate_indices])
    np.testing.assert_array_equal(got.candidate_predictions, predictions[want.candidate_indices])
    assert 0 < want.n_candidates < len(theta)


def test_model_batches_and_threads_match_reference(threads):
    theta, y, t = _model_case()
    for n_threads in (1, 2):
        threads(n_threads)
        for batch_size in (1, 333, 10_000):
            result = edmf_rs.falsify_model(_model, theta, y, t, batch_size=batch_size)
            _same_model(result, theta, y, t)
            assert result.n_violated is None  # only the candidates are kept
        batches = np.array_split(theta, 7)
        _same_model(edmf_rs.falsify_model(_model, iter(batches), y, t), theta, y, t)
        _same_model(edmf_rs.falsify_model(_model, batches, y, t, diagnostics=False), theta, y, t)


def test_model_with_sobol_generator():
    _, y, t = _model_case()
    sampler = qmc.Sobol(d=2, seed=7)
    theta = qmc.scale(qmc.Sobol(d=2, seed=7).random(4096), [-1, -1], [1, 1])

    def draws():
        for _ in range(8):
            yield qmc.scale(sampler.random(512), [-1, -1], [1, 1])

    _same_model(edmf_rs.falsify_model(_model, draws(), y, t), theta, y, t)


def test_model_with_generator_refilling_one_parameter_buffer():
    theta, y, t = _model_case()
    buffer = np.empty((400, 2))

    def refilled():
        for first in range(0, len(theta), 400):
            buffer[...] = theta[first:first + 400]
            yield buffer

    _same_model(edmf_rs.falsify_model(_model, refilled(), y, t), theta, y, t)


def test_model_that_raises_is_named_by_batch_and_instances():
    theta, y, t = _model_case()

    def fails(batch):
        if batch[0, 0] == theta[2000, 0]:
            raise RuntimeError("solver diverged")
        return _model(batch)

    with pytest.raises(RuntimeError, match="solver diverged") as info:
        edmf_rs.falsify_model(fails, theta, y, t, batch_size=500)
    assert "batch 4, instances 2000..2499" in " ".join(info.value.__notes__)


def test_model_wrong_shape_and_nan_are_named():
    theta, y, t = _model_case()
    with pytest.raises(ValueError, match=r"returned shape \(500, 5\).*batch 0, instances 0\.\.499.*expected \(500, 6\)"):
        edmf_rs.falsify_model(lambda b: _model(b)[:, :-1], theta, y, t, batch_size=500)

    def nan_at_1234(batch):
        out = _model(batch)
        out[batch[:, 0] == theta[1234, 0]] = np.nan
        return out

    with pytest.raises(ValueError, match=r"NaN for instance 1234 \(batch 2, instances 1000\.\.1499"):
        edmf_rs.falsify_model(nan_at_1234, theta, y, t, batch_size=500)
    counted = edmf_rs.falsify_model(nan_at_1234, theta, y, t, batch_size=500, nan="falsify")
    assert counted.n_invalid == 1 and 1234 not in counted.candidate_indices


def test_an_infinite_prediction_is_named_like_nan_and_falsified_when_asked():
    theta, y, t = _model_case()
    plain = edmf_rs.falsify_model(_model, theta, y, t, batch_size=500)
    k = int(plain.candidate_indices[len(plain.candidate_indices) // 2])  # a candidate, so the test can fail

    def minus_inf_at_k(batch):
        out = _model(batch)
        out[batch[:, 0] == theta[k, 0], 2] = -np.inf
        return out

    with pytest.raises(ValueError, match=rf"returned -inf for instance {k} \(batch {k // 500}, "):
        edmf_rs.falsify_model(minus_inf_at_k, theta, y, t, batch_size=500)
    falsified = edmf_rs.falsify_model(minus_inf_at_k, theta, y, t, batch_size=500, nan="falsify")
    assert falsified.n_invalid == 0
    np.testing.assert_array_equal(falsified.candidate_indices, np.setdiff1d(plain.candidate_indices, [k]))


def test_parameter_batch_of_wrong_width():
    theta, y, t = _model_case()
    with pytest.raises(ValueError, match=r"parameters: batch 1 has shape \(10, 3\), expected \(n, 2\)"):
        edmf_rs.falsify_model(_model, [theta[:10], np.zeros((10, 3))], y, t)
    with pytest.raises(TypeError, match="parameters: expected"):
        edmf_rs.falsify_model(_model, 42, y, t)


# -- progress ----------------------------------------------------------------

def test_progress_bar_on_streams_and_off_on_request(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(progress, "DELAY", 0.0)
    predictions, y, t = _data()
    path = tmp_path / "p.npy"
    np.save(path, predictions)
    theta, ym, tm = _model_case()
    edmf_rs.falsify(path, y, t)
    edmf_rs.falsify(iter([predictions]), y, t)
    edmf_rs.falsify_model(_model, theta, ym, tm)
    assert capsys.readouterr().err.count("falsifying") >= 3
    edmf_rs.falsify(path, y, t, progress=False)
    edmf_rs.falsify(iter([predictions]), y, t, progress=False)
    edmf_rs.falsify_model(_model, theta, ym, tm, progress=False)
    assert "falsifying" not in capsys.readouterr().err


def test_falsify_model_with_no_parameter_sets_keeps_the_parameter_width():
    t = edmf_rs.Thresholds([-1.0], [1.0])
    r = edmf_rs.falsify_model(lambda th: th[:, :1], np.empty((0, 3)), [0.0], t, progress=False)
    assert r.n_instances == 0
    assert r.candidate_parameters.shape == (0, 3) and r.candidate_predictions.shape == (0, 1)


def test_a_model_that_reuses_its_output_buffer_is_read_safely():
    # Rust falsifies batch k while the model fills batch k+1: the batch must be a copy.
    theta = np.random.default_rng(0).uniform(-2.0, 2.0, (60_000, 3))
    y, t = np.zeros(3), Thresholds(-np.ones(3), np.ones(3))
    buffer = np.empty((1_000, 3))

    def model(batch):
        buffer[: len(batch)] = batch
        return buffer[: len(batch)]

    r = edmf_rs.falsify_model(model, theta, y, t, batch_size=1_000, progress=False)
    expected = reference.falsify(theta, y, t)
    np.testing.assert_array_equal(r.candidate_indices, expected.candidate_indices)
    np.testing.assert_array_equal(r.candidate_parameters, theta[expected.candidate_indices])
    np.testing.assert_array_equal(r.candidate_predictions, theta[expected.candidate_indices])


def test_memory_mapped_and_converted_arrays_go_chunk_by_chunk(tmp_path):
    rng = np.random.default_rng(4)
    p = (rng.normal(size=(5_000, 3)) * 100).astype(">i4")  # integers, big-endian: must be converted
    path = tmp_path / "p.npy"
    np.save(path, p)
    mapped = np.load(path, mmap_mode="r")
    t = Thresholds([-60.0] * 3, [60.0] * 3)
    r = edmf_rs.falsify(mapped, np.zeros(3), t, chunk_rows=777, progress=False)
    expected = reference.falsify(p.astype(np.float64), np.zeros(3), t)
    np.testing.assert_array_equal(r.candidate_indices, expected.candidate_indices)
    np.testing.assert_array_equal(r.per_sensor_falsified, expected.per_sensor_falsified)
    assert r.n_violated is None  # no N-long array for a memory map by default
    source = edmf_rs.stream.chunks.open_source(mapped, 3)
    assert source.chunk_rows is not None  # converted per chunk, not as a whole
